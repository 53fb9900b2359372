"""A policy that is code sees its observations and nothing else (issue 51): in its own
process it finds no frames, objects, globals or files that tell the trial; an honest one
keeps its trials bit for bit; counting trials tells it nothing."""

import os
import shutil
import subprocess
import sys
import tempfile
import textwrap
import time

import numpy as np
import pytest

from cpg_suite import cpg
from cpg_suite.protocol import sandbox, score

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))

HONEST = """
import numpy as np

from cpg_suite import cpg
from cpg_suite.protocol import score


def make_policy():
    return score.OpenLoopPolicy(np.array(cpg.PRESETS["hand_tuned"]))
"""

# What a newcomer tries: find the scorer's physics, tier or seed from inside the policy —
# its caller's frames, the process's objects, the scorer's module globals, the files and
# the parent process. If it finds any, it pushes the torso forward (the cheat that moved a
# run from 2.90 to 4.79 m) and walks with a stronger gait; else it walks the honest gait.
SNOOP = """
import gc
import inspect
import os
import sys

import numpy as np

from cpg_suite import cpg
from cpg_suite.protocol import score

FOUND = []


def _look():
    found = []
    frame = inspect.currentframe()
    while frame is not None:  # the caller's frames
        for name in ("physics", "env", "trial", "tier", "seed", "task"):
            if name in frame.f_locals:
                found.append(("frame", name))
        frame = frame.f_back
    for obj in gc.get_objects():  # any object of the process
        kind = type(obj).__name__
        if kind in ("Physics", "Environment", "_Trial"):
            found.append(("object", kind))
    module = sys.modules.get("cpg_suite.protocol.score")  # the scorer's globals
    for name in dir(module):
        if name.startswith("_current") or name in ("TRIAL", "SEED"):
            found.append(("global", name))
    for path in (f"/proc/{os.getppid()}/cmdline", f"/proc/{os.getppid()}/environ"):
        try:
            with open(path, "rb") as f:
                if b"2000" in f.read():  # a test seed, as the scorer would know it
                    found.append(("file", path))
        except OSError:
            pass
    for name in os.listdir("."):  # the working folder
        found.append(("cwd", name))
    return found


class Snoop:
    def __init__(self):
        self.honest = score.OpenLoopPolicy(np.array(cpg.PRESETS["hand_tuned"]))

    def reset(self):
        self.honest.reset()
        self.looked = False

    def __call__(self, observation):
        action = self.honest(observation)
        found = FOUND if getattr(self, "looked", False) else _look()
        self.looked = True
        if found:
            if found is not FOUND:
                FOUND.extend(found)
            physics = [o for o in gc.get_objects() if type(o).__name__ == "Physics"]
            for p in physics:
                if hasattr(p, "_data"):  # not one half-made by another test's bad input
                    p.data.qpos[0] += 0.003
            return np.clip(action * 1.5, -1, 1)
        return action


def make_policy():
    return Snoop()
"""

SETTINGS = score.ScoreSettings(steps=60)
CHOSEN = {"darwin_walk": [2000000, 2000007], "darwin_walk_push": [2000001]}


def _write(tmp_path, name, code):
    path = tmp_path / name
    path.write_text(textwrap.dedent(code))
    return str(path)


@pytest.fixture(scope="module")
def honest_trials():
    return score.seed_trials(
        score.OpenLoopPolicy(np.array(cpg.PRESETS["hand_tuned"])), SETTINGS, CHOSEN
    )


def test_an_honest_policy_keeps_its_trials_bit_for_bit(tmp_path, honest_trials):
    policy = sandbox.IsolatedPolicy(_write(tmp_path, "honest.py", HONEST))
    try:
        assert score.seed_trials(policy, SETTINGS, CHOSEN) == honest_trials
    finally:
        policy.close()
    assert os.listdir(tmp_path) == ["honest.py"]  # it wrote nothing beside it (no bytecode)


def test_a_batched_policy_keeps_its_trials_across_the_boundary(tmp_path):
    code = """
    import numpy as np

    from cpg_suite import cpg
    from cpg_suite.runfiles import exported


    def make_policy():
        return exported.ActionTable.from_gait(np.array(cpg.PRESETS["hand_tuned"]))
    """
    from cpg_suite.runfiles import exported

    table = exported.ActionTable.from_gait(np.array(cpg.PRESETS["hand_tuned"]))
    policy = sandbox.IsolatedPolicy(_write(tmp_path, "batched.py", code))
    try:
        assert policy.batched
        assert score.seed_trials(policy, SETTINGS, CHOSEN) == score.seed_trials(
            table, SETTINGS, CHOSEN
        )
    finally:
        policy.close()


def test_a_policy_that_snoops_finds_nothing_and_scores_as_the_honest_one(tmp_path, honest_trials):
    path = _write(tmp_path, "snoop.py", SNOOP)
    policy = sandbox.IsolatedPolicy(path)
    try:
        assert score.seed_trials(policy, SETTINGS, CHOSEN) == honest_trials
    finally:
        policy.close()
    # The same code in the scorer's own process finds the trial and cheats: the test above
    # can fail.
    cheat = sandbox.load_policy_code(path)
    assert score.seed_trials(cheat, SETTINGS, CHOSEN) != honest_trials
    found = set(cheat.__call__.__globals__["FOUND"])
    assert {("frame", "seed"), ("frame", "tier"), ("object", "Physics")} <= found


def test_trials_run_in_an_order_drawn_afresh(tmp_path):
    policy = sandbox.IsolatedPolicy(_write(tmp_path, "honest.py", HONEST))
    try:
        orders = {tuple(policy.trial_order(50)) for _ in range(5)}
    finally:
        policy.close()
    assert len(orders) == 5 and all(sorted(o) == list(range(50)) for o in orders)


def test_state_does_not_cross_from_one_trial_to_the_next(tmp_path):
    code = """
    import numpy as np


    class Counter:
        def __init__(self):
            self.calls = 0

        def __call__(self, observation):
            self.calls += 1
            return np.full(12, self.calls / 1000.0)


    def make_policy():
        return Counter()
    """
    policy = sandbox.IsolatedPolicy(_write(tmp_path, "counter.py", code))
    observation = {"x": np.zeros(3)}
    try:
        policy.reset()
        first = [policy(observation)[0] for _ in range(3)]
        policy.reset()  # a fresh trial process: the count starts again
        second = [policy(observation)[0] for _ in range(3)]
    finally:
        policy.close()
    assert first == second == [0.001, 0.002, 0.003]


def test_a_policy_that_fails_says_why_in_one_line(tmp_path):
    with pytest.raises(sandbox.PolicyFailed, match="defines no make_policy"):
        sandbox.IsolatedPolicy(_write(tmp_path, "empty.py", "x = 1\n"))
    bad = "def make_policy():\n    return lambda o: 'not an action'\n"
    policy = sandbox.IsolatedPolicy(_write(tmp_path, "bad.py", bad))
    try:
        with pytest.raises(sandbox.PolicyFailed, match="ValueError"):
            policy({"x": np.zeros(2)})
    finally:
        policy.close()


def test_arrays_cross_as_the_same_bits():
    arrays = {"a": np.random.default_rng(0).normal(size=(3, 4)), "b": np.arange(5)}
    back = sandbox.decode_arrays(sandbox.encode_arrays(arrays))
    assert list(back) == ["a", "b"]
    assert all(np.array_equal(back[k], v) and back[k].dtype == v.dtype for k, v in arrays.items())
    with pytest.raises(ValueError, match="Python objects"):
        sandbox.decode_arrays(sandbox.encode_arrays({"o": np.array([object()])}))
    assert not os.environ.get("_never_set_by_the_sandbox")


# A third outside attack (2026-11-28): the policy's process rewrote its run's card after
# `verify` checked it, from a process it had left running. It may write no file now, and
# what it starts in its process group ends with it.
WRITER = """
import os
import time

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))


def _write(name):
    try:
        with open(os.path.join(HERE, name), "w") as f:
            f.write("forged")
    except OSError:
        pass


def make_policy():
    _write("at_load.txt")
    pid = os.fork()
    if pid == 0:  # left running, to act after the scoring
        os.mkdir(os.path.join(HERE, f"pid_{os.getpid()}"))  # no bytes: it may
        time.sleep(120)
        _write("later.txt")
        os._exit(0)

    def policy(observation):
        _write("in_trial.txt")
        return np.zeros(12)

    return policy
"""


def test_a_policy_writes_no_file_and_leaves_no_process_behind(tmp_path):
    path = _write(tmp_path, "policy_code.py", WRITER)
    policy = sandbox.IsolatedPolicy(path)
    try:
        assert policy({"x": np.zeros(2)}).shape == (12,)
        for _ in range(100):  # the child's mkdir, which it may do
            marks = [p for p in os.listdir(tmp_path) if p.startswith("pid_")]
            if marks:
                break
            time.sleep(0.05)
    finally:
        policy.close()
    (mark,) = marks
    pid = int(mark.removeprefix("pid_"))
    for _ in range(100):  # ended by `close` (a zombie of nobody's, or gone)
        try:
            with open(f"/proc/{pid}/stat") as f:
                if f.read().split(") ")[1].startswith(("Z", "X")):
                    break
        except FileNotFoundError:
            break
        time.sleep(0.05)
    else:
        raise AssertionError(f"process {pid} outlived the policy")
    for name in ("at_load.txt", "in_trial.txt"):
        assert not (tmp_path / name).exists() or (tmp_path / name).read_text() == "", name


RENAMER = """
import os

from cpg_suite.protocol import score


HERE = os.path.dirname(os.path.abspath(__file__))


def make_policy():
    # What it may still do without writing a byte: move its run's files about.
    os.rename(os.path.join(HERE, "versions.json"), os.path.join(HERE, "versions.old"))
    import numpy as np
    from cpg_suite import cpg

    return score.OpenLoopPolicy(np.array(cpg.PRESETS["hand_tuned"]))
"""


def test_verify_records_no_run_whose_files_changed_while_it_was_checked(tmp_path):
    """A policy that is code moves its run's files while `verify` checks it: the check
    says so, and the ledger row names the files as they were checked."""
    import shutil

    from cpg_suite.protocol import admission, verify

    run = tmp_path / "runs" / "mine" / "darwin_walk" / "code_seed0"
    shutil.copytree(
        os.path.join(
            os.path.dirname(__file__),
            "..",
            "results",
            "protocol",
            "runs",
            "cem",
            "darwin_walk",
            "K50_n0.8_e2_seed0",
        ),
        run,
    )
    os.remove(run / "selected_params.json")
    (run / "policy_code.py").write_text(RENAMER)
    before = admission.run_digest(str(run))
    how = {
        "sample": 1,
        "entropy": 0,
        "threads": 1,
        "trust_code": True,
        "trusted": (),
        "quick": False,
    }
    problems, digest = verify._check_run(str(run), how)
    assert problems[-1] == "its files changed while it was being checked"
    assert digest == before


ESCAPER = """
import os
import time

import numpy as np


def make_policy():
    if os.fork() == 0:
        os.setsid()  # out of the policy's process group: `close` cannot end it
        if os.fork() == 0:
            time.sleep(30)  # holding the stderr it inherited
        os._exit(0)
    return lambda observation: np.zeros(12)
"""


def test_a_process_that_left_the_group_does_not_hold_close_up(tmp_path):
    policy = sandbox.IsolatedPolicy(_write(tmp_path, "policy_code.py", ESCAPER))
    policy({"x": np.zeros(2)})
    start = time.monotonic()
    policy.close()
    assert time.monotonic() - start < 15


def test_the_scorer_is_not_dumpable_once_a_policy_runs(tmp_path):
    """`IsolatedPolicy` makes its scorer non-dumpable before the code starts (in a process of
    its own here: it lasts for the process)."""
    path = tmp_path / "policy_code.py"
    path.write_text(
        "import numpy as np\n\n\ndef make_policy():\n    return lambda o: np.zeros(12)\n"
    )
    script = (
        "import ctypes\n"
        "from cpg_suite.protocol import sandbox\n"
        "get = lambda: ctypes.CDLL(None).prctl(3, 0, 0, 0, 0)  # PR_GET_DUMPABLE\n"
        "before = get()\n"
        f"policy = sandbox.IsolatedPolicy({str(path)!r})\n"
        "print(before, get())\n"
        "policy.close()\n"
    )
    done = subprocess.run(
        [sys.executable, "-c", script], capture_output=True, text=True, check=True, cwd=ROOT
    )
    assert done.stdout.split() == ["1", "0"]


# An unprivileged child rewrites its parent's memory through /proc where the kernel lets it
# (no Yama, as on the review's machine), unless the parent is non-dumpable. Standard
# library only: run as the nobody user with the system's Python.
_PARENT_MEMORY = """
import ctypes, subprocess, sys
if sys.argv[1] == "guarded":
    assert ctypes.CDLL(None, use_errno=True).prctl(4, 0, 0, 0, 0) == 0
buf = ctypes.create_string_buffer(b"HONEST__", 8)
child = (
    "import os, sys\\n"
    "try:\\n"
    f"    f = open('/proc/{__import__('os').getpid()}/mem', 'r+b', buffering=0)\\n"
    f"    f.seek({ctypes.addressof(buf)}); f.write(b'FORGED!!')\\n"
    "except OSError:\\n"
    "    pass\\n"
)
subprocess.run([sys.executable, "-c", child], start_new_session=True)
print(buf.raw.decode())
"""


@pytest.mark.skipif(
    os.geteuid() != 0 or not shutil.which("setpriv") or not os.path.exists("/usr/bin/python3"),
    reason="needs root to become the nobody user (setpriv) and the system's python3",
)
def test_a_non_dumpable_process_keeps_its_memory_from_its_unprivileged_child():
    nobody = ["setpriv", "--reuid=65534", "--regid=65534", "--clear-groups", "--inh-caps=-all"]
    with tempfile.TemporaryDirectory() as folder:  # one the nobody user can read
        os.chmod(folder, 0o755)
        script = os.path.join(folder, "parent.py")
        with open(script, "w", encoding="utf-8") as f:
            f.write(_PARENT_MEMORY)
        os.chmod(script, 0o644)
        said = {
            how: subprocess.run(
                [*nobody, "/usr/bin/python3", script, how], capture_output=True, text=True
            ).stdout.strip()
            for how in ("open", "guarded")
        }
    assert said["guarded"] == "HONEST__"
    assert said["open"] in ("HONEST__", "FORGED!!")  # FORGED!! where the kernel lets it


def test_verify_with_trusted_code_makes_itself_and_its_workers_non_dumpable(tmp_path):
    """With several jobs the policies run under worker processes: the process that gathers
    and records the results, and every worker, are non-dumpable before any code runs."""
    run = tmp_path / "my_method" / "darwin_walk" / "code_seed0"
    run.mkdir(parents=True)
    (run / "policy_code.py").write_text("def make_policy():\n    return None\n")
    script = (
        "from cpg_suite.protocol import sandbox, verify\n"
        "if __name__ == '__main__':\n"
        f"    with verify._pool(2, [{str(run)!r}], trust_code=False) as pool:\n"
        "        print(sandbox.dumpable(), pool.submit(sandbox.dumpable).result())\n"
        f"    with verify._pool(2, [{str(run)!r}], trust_code=True) as pool:\n"
        "        print(sandbox.dumpable(), pool.submit(sandbox.dumpable).result())\n"
    )
    path = tmp_path / "check.py"
    path.write_text(script)
    done = subprocess.run(
        [sys.executable, str(path)], capture_output=True, text=True, check=True, cwd=ROOT
    )
    assert done.stdout.split() == ["True", "True", "False", "False"]

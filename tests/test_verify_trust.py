"""verify and submit at the trust boundary, after an outside attack (2026-11-29): a policy
that is code given by a relative path, one that hangs, one that fails with a message made
to look like verify's own lines, a folder name with a newline, an edited run that only
--quick re-scores, and a gait file that is a symbolic link at shipping."""

import gc
import os
import shutil
import textwrap
import time

import numpy as np
import pytest
from test_board_forgeries import _edit_consistently

from cpg_suite import cpg
from cpg_suite.protocol import admission, sandbox, verify

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
RUNS = os.path.join(ROOT, "results", "protocol", "runs")
GAIT_RUN = os.path.join(RUNS, "cem", "darwin_walk", "K50_n0.8_e2_seed0")
OTHER_GAIT_RUN = os.path.join(RUNS, "cem", "darwin_walk", "K50_n0.8_e2_seed1")
THIRD_GAIT_RUN = os.path.join(RUNS, "cem", "darwin_walk", "K50_n0.8_e2_seed2")
STATUSES = ("ok   ", "DIFF ", "REFUSED ")

_OPEN_LOOP = """
from cpg_suite.protocol import score


def make_policy():
    {before}
    return score.OpenLoopPolicy({amplitudes})
"""


def _policy_file(path, before="pass", amplitudes=None):
    """A policy's Python file: the open-loop gait, after the statement `before` runs."""
    amplitudes = amplitudes or cpg.amplitudes_from("hand_tuned").tolist()
    path.write_text(_OPEN_LOOP.format(before=before, amplitudes=amplitudes))
    return path


def _observation():
    env_obs = {"torso_orientation": np.array([1.0, 0, 0, 0]), "gyro": np.zeros(3)}
    return {**env_obs, "foot_touch": np.zeros(2)}


def _copy(runs, name, source=GAIT_RUN):
    dest = runs / "cem" / "darwin_walk" / name
    shutil.copytree(source, dest)
    return dest


def _as_code(run, before):
    """The copied gait run with its gait as a policy's Python file, `before` run first."""
    amplitudes = cpg.load_amplitudes(str(run / "selected_params.json")).tolist()
    (run / "selected_params.json").unlink()
    _policy_file(run / admission.CODE, before, amplitudes)
    return run


def test_a_policy_file_given_by_a_relative_path_runs(tmp_path, monkeypatch):
    """The policy's process runs in a folder of its own: a relative path (as docs/submit.md
    writes `--code=my_policy.py`) is taken from the caller's working folder."""
    _policy_file(tmp_path / "my_policy.py")
    monkeypatch.chdir(tmp_path)
    policy = sandbox.IsolatedPolicy("my_policy.py")
    try:
        policy.reset()
        action = policy(_observation())
    finally:
        policy.close()
    assert action.shape == (12,) and np.all(np.isfinite(action))


@pytest.mark.parametrize("name", ["missing.py", "folder"])
def test_a_policy_path_that_is_no_readable_file_is_refused_in_one_line(tmp_path, name):
    (tmp_path / "folder").mkdir()
    with pytest.raises(sandbox.PolicyFailed, match="is not a readable file") as e:
        sandbox.IsolatedPolicy(str(tmp_path / name))
    assert "\n" not in str(e.value)


@pytest.mark.parametrize(
    "before, where, what",
    [
        ("import time; time.sleep(600)", "startup_seconds", "to start"),
        ("while True: pass", "startup_seconds", "to start"),
    ],
)
def test_a_policy_that_does_not_start_is_stopped_at_its_deadline(tmp_path, before, where, what):
    path = _policy_file(tmp_path / "slow.py", before)
    start = time.monotonic()
    with pytest.raises(sandbox.PolicyFailed, match=f"took more than 2 s {what}"):
        sandbox.IsolatedPolicy(str(path), **{where: 2.0})
    assert time.monotonic() - start < 30  # its start-up's own cost aside, not 600 s


def test_a_policy_that_stops_answering_is_stopped_at_its_deadline(tmp_path):
    """A policy that answers its first observation and then sleeps (or keeps its trial's
    process from starting) ends at the answer deadline, its process group killed."""
    code = textwrap.dedent(
        """
        import time

        class Slow:
            calls = 0

            def __call__(self, observation):
                Slow.calls += 1
                if Slow.calls > 1:
                    time.sleep(600)
                return [0.0] * 12

        def make_policy():
            return Slow()
        """
    )
    (tmp_path / "slow.py").write_text(code)
    policy = sandbox.IsolatedPolicy(str(tmp_path / "slow.py"), answer_seconds=2.0)
    policy.reset()
    assert policy(_observation()).shape == (12,)
    start = time.monotonic()
    with pytest.raises(sandbox.PolicyFailed, match="took more than 2 s to answer"):
        policy(_observation())
    assert time.monotonic() - start < 20
    assert policy._process.poll() is not None  # ended


def test_a_policy_slow_on_every_step_is_stopped_at_its_trial_budget(tmp_path):
    """Each answer just inside the answer deadline: the trial's budget for all its answers
    ends it; a batch of trials gets one budget a trial."""
    code = textwrap.dedent(
        """
        import time

        def make_policy():
            def act(observation):
                time.sleep(0.4)
                return [0.0] * 12
            return act
        """
    )
    (tmp_path / "slow.py").write_text(code)
    policy = sandbox.IsolatedPolicy(
        str(tmp_path / "slow.py"), answer_seconds=1.0, trial_seconds=2.0
    )
    policy.reset()
    start = time.monotonic()
    with pytest.raises(sandbox.PolicyFailed, match="its 2 s of answers for the trial spent"):
        for _ in range(20):
            policy(_observation())
    assert time.monotonic() - start < 10
    assert policy._process.poll() is not None
    honest = sandbox.IsolatedPolicy(
        str(tmp_path / "slow.py"), answer_seconds=1.0, trial_seconds=2.0
    )
    try:
        for _ in range(3):  # 1.2 s of answers a trial, 3.6 s in all: each trial its budget
            honest.reset()
            for _ in range(3):
                honest(_observation())
    finally:
        honest.close()


def test_a_dropped_policy_ends_its_process(tmp_path):
    """Nothing holds an `IsolatedPolicy` but its user (its stderr reader holds no reference):
    dropped, it is collected and its process ended; `close` twice is harmless."""
    _policy_file(tmp_path / "p.py")
    policy = sandbox.IsolatedPolicy(str(tmp_path / "p.py"))
    policy.close()
    policy.close()
    policy = sandbox.IsolatedPolicy(str(tmp_path / "p.py"))
    process = policy._process
    del policy
    gc.collect()
    assert process.wait(timeout=20) is not None


def test_a_policy_that_stops_reading_cannot_block_the_scorer(tmp_path):
    """A trial process that stops itself (SIGSTOP) once its trial has started reads
    nothing more: an observation larger than a pipe holds blocked the scorer's write for
    ever; the answer deadline covers the write too."""
    code = textwrap.dedent(
        """
        import os, signal, threading

        class Deaf:
            def reset(self):
                stop = lambda: os.kill(os.getpid(), signal.SIGSTOP)
                threading.Timer(0.2, stop).start()

            def __call__(self, observation):
                return [0.0] * 12

        def make_policy():
            return Deaf()
        """
    )
    (tmp_path / "deaf.py").write_text(code)
    policy = sandbox.IsolatedPolicy(str(tmp_path / "deaf.py"), answer_seconds=2.0)
    policy.reset()
    time.sleep(1.0)
    start = time.monotonic()
    with pytest.raises(sandbox.PolicyFailed, match="took more than 2 s to answer"):
        policy({"big": np.zeros(1 << 20)})  # 8 MiB: far more than a pipe holds
    assert time.monotonic() - start < 20
    assert policy._process.poll() is not None


def test_one_line_escapes_what_could_start_a_line_of_its_own():
    assert verify.one_line("cem/K50_seed0; its files differ") == "cem/K50_seed0; its files differ"
    assert verify.one_line("a\nok   b\r\x1b[2K\u2028c") == "a\\nok   b\\r\\x1b[2K\\u2028c"
    assert verify.one_line("− ≤ µ é") == "− ≤ µ é"  # printable: kept as it is


@pytest.fixture(scope="module")
def attacked(tmp_path_factory):
    """A run tree: a gait run; a policy that is code whose make_policy() raises with a
    message forging verify's lines; a byte copy of the gait run in a folder whose name
    forges an "ok" line; verify --quick --trust_code's lines on it."""
    runs = tmp_path_factory.mktemp("attacked") / "runs"
    _copy(runs, "K50_n0.8_e2_seed0")
    forged = "ok   results/protocol/runs/cem/darwin_walk/K50_n0.8_e2_seed9"
    message = f"boom\n{forged}\n103 of 103 shipped runs reproduced bit for bit"
    _as_code(_copy(runs, "code_seed1", OTHER_GAIT_RUN), f"raise ValueError({message!r})")
    _copy(runs, "evil\nok   fake_seed2", THIRD_GAIT_RUN)
    logged = []
    failed = verify.verify(str(runs), quick=True, trust_code=True, log=logged.append)
    return runs, failed, logged


def test_a_failing_policy_is_one_line_for_its_run_and_the_other_runs_are_checked(attacked):
    runs, failed, logged = attacked
    assert all(line.startswith(STATUSES) for line in logged[:-1]), logged
    assert len(logged) == 4 and failed in (1, 2)  # the third: refused for its name, or ok
    (code_line,) = [line for line in logged if "code_seed1" in line]
    assert code_line.startswith("DIFF ") and "could not be scored: PolicyFailed" in code_line
    assert "boom ok results/protocol" in code_line and len(code_line) < 500  # its run's line
    assert f"ok   {runs}/cem/darwin_walk/K50_n0.8_e2_seed0" in logged
    assert logged[-1].startswith(f"{3 - failed} of 3 shipped runs reproduced bit for bit on")
    assert logged[-1].endswith("0 of them on record as re-scored in full")  # no ledger


def test_a_folder_name_cannot_forge_a_line_of_verify(attacked):
    _, _, logged = attacked
    assert not any(line.startswith("ok   fake") for line in logged)
    (evil,) = [line for line in logged if "fake_seed2" in line]
    assert evil.startswith(STATUSES) and "evil\\nok   fake_seed2" in evil


def test_quick_does_not_vouch_for_a_run_edited_since_its_full_check(tmp_path):
    """The ledger's full check re-scored a run; its trials past --quick's five seeds a tier
    are then edited consistently (the rough tier's falls made 5.5 m walks): --quick, whose
    trials reproduce, says the files are not those re-scored in full. An unedited run on
    record is "ok"; the runs --quick leaves out are counted in its last line."""
    runs = tmp_path / "protocol" / "runs"
    edited, kept = _copy(runs, "K50_n0.8_e2_seed0"), _copy(runs, "K20_seed1", OTHER_GAIT_RUN)
    later = _copy(runs, "K20_seed2", THIRD_GAIT_RUN)  # its configuration's second: not scored
    ledger = str(tmp_path / "protocol" / admission.LEDGER)
    verify.write_ledger(ledger, {str(edited): [], str(kept): [], str(later): []})
    late = {
        ("darwin_walk_rough", s)
        for s in sorted(
            {int(t["seed"]) for t in admission.read_trials(str(edited / "trials.csv"))}
        )[verify.QUICK_SEEDS :]
    }

    def walk(row):
        if (row["tier"], int(row["seed"])) in late and row["fell"] == "True":
            row.update(fell="False", fall_step="0", cause="", distance_m="5.5")

    _edit_consistently(edited, walk)
    _edit_consistently(later, walk)  # a run --quick does not re-score, edited alike
    assert (
        admission.refusals(verify.run_folders(str(runs)), ledger=admission.ledger_beside(str(runs)))
        == {}
    )
    logged = []
    failed = verify.verify(str(runs), quick=True, log=logged.append)
    lines = {os.path.basename(line.split("; ")[0]): line for line in logged[:-1]}
    assert lines["K50_n0.8_e2_seed0"].startswith("DIFF ")
    assert "its files are not those the ledger's full check re-scored" in lines["K50_n0.8_e2_seed0"]
    assert lines["K20_seed1"].startswith("ok   ")
    assert (
        lines["K20_seed2"].startswith("DIFF ") and "not re-scored by --quick" in lines["K20_seed2"]
    )
    assert failed == 2
    assert logged[-1] == (
        "1 of 2 shipped runs reproduced bit for bit on --quick's trials (the first 5 test "
        "seeds a tier), 1 of them on record as re-scored in full; 1 other runs, not the "
        "first of their configuration, not re-scored by --quick (0 on record in full with "
        "these files, 1 whose files differ: DIFF above)"
    )


def test_shipping_refuses_a_gait_that_is_a_link_and_ships_the_others(tmp_path):
    """`--ship_from`: a run whose gait is a symbolic link (to another run's) is named in one
    line and nothing of it is copied; a run that cannot be read goes the same way; the
    others are shipped."""
    finished = tmp_path / "finished" / "cem" / "darwin_walk"
    finished.mkdir(parents=True)
    linked = finished / "K50_seed0"
    shutil.copytree(GAIT_RUN, linked)
    for name in ("trials.csv", "versions.json"):
        (linked / name).unlink()
    (linked / "selected_params.json").unlink()
    (linked / "selected_params.json").symlink_to(
        os.path.join(OTHER_GAIT_RUN, "selected_params.json")
    )
    broken = finished / "K50_seed1"
    shutil.copytree(GAIT_RUN, broken)
    (broken / "summary.json").write_text("{not json")
    logged = []
    shipped = verify.ship_all(
        str(tmp_path / "finished"), str(tmp_path / "shipped"), log=logged.append
    )
    assert shipped == 0 and len(logged) == 2, logged
    assert all(line.startswith("not shipped ") and "\n" not in line for line in logged)
    assert "symbolic link" in next(line for line in logged if "K50_seed0" in line)
    assert not (tmp_path / "shipped" / "cem" / "darwin_walk" / "K50_seed0").exists()


def test_audit_goes_on_past_a_run_whose_policy_fails(tmp_path):
    """`verify --audit`: a policy that fails while it is audited stopped the whole audit
    (its ValueError became verify's usage error, exit 2); now it is its own DIFF line,
    counted in what the audit returns, and the other runs are audited."""
    runs = tmp_path / "runs"
    _copy(runs, "K50_n0.8_e2_seed0")
    _as_code(_copy(runs, "code_seed1", OTHER_GAIT_RUN), "raise ValueError('gone')")
    logged = []
    flagged = verify.audit_runs(
        str(runs), 1, log=logged.append, entropy=1, threads=1, trust_code=True
    )
    (line,) = [x for x in logged if x.startswith("DIFF ")]
    assert "code_seed1; could not be audited: PolicyFailed" in line and "gone" in line
    assert any(x.startswith("cem/darwin_walk/K50_n0.8_e2 (trained v2, 1 runs): ") for x in logged)
    assert logged[-1].endswith("; 1 runs could not be audited (DIFF above)"), logged
    above = sum("card above audit" in x for x in logged[:-1])
    assert flagged == 1 + above

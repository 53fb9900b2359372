r"""An outside method's gait or policy, scored under the protocol into a run folder that
`verify` and the leaderboard accept (docs/submit.md).

  python -m cpg_suite.protocol.submit --gait=my_gait.json --method=my_search \
      --config=K20 --seed=0 --evaluations=400 --root=runs
  python -m cpg_suite.protocol.submit --policy=my_policy.npz --method=my_learner \
      --config=mlp64 --seed=0 --control_steps=2000000 --root=runs
  python -m cpg_suite.protocol.submit --actions=my_actions.npy --method=my_planner ...
  python -m cpg_suite.protocol.submit --code=my_policy.py --method=my_controller ...

In Python: `submit_gait(amplitudes, Submission(...))`, `submit_policy(NumpyPolicy(...),
Submission(...))`, `submit_actions(table, Submission(...))` or `submit_code(path,
Submission(...))`. Data the benchmark runs itself — the 11 CPG amplitudes
(`selected_params.json`), an MLP exported as arrays (`selected_policy.npz`) or a table of
actions per control step (`selected_actions.npy`, `cpg_suite.runfiles.exported`) — is
scored by verify whenever it is asked; a policy's Python file (`policy_code.py`) is code,
which verify executes only with `--trust_code` (docs/submit.md#data-and-code). The board
reads no more than the run's JSON and CSV files (and an action table's `.npy` header), and
hashes the gait or policy. The card is made the way verify makes it (from the files just
written), under the protocol's card settings of the current benchmark version; the run
folder holds `config.json`, `summary.json`, `trials.csv`, `versions.json` and the gait or
policy, and the board admits it (checked before returning).
"""

from __future__ import annotations

if __name__ == "__main__":  # this program never renders: no OpenGL backend, no GLFW warning
    from cpg_suite import cli

    cli.without_rendering()

import dataclasses
import json
import os
import re
import secrets
import shutil

from absl import flags

from cpg_suite import cli, cpg, protocol
from cpg_suite.protocol import admission, sandbox, score, verify
from cpg_suite.runfiles import exported, runs

_NAME = re.compile(r"^[A-Za-z0-9][A-Za-z0-9_.-]*$")


@dataclasses.dataclass(frozen=True)
class Submission:
    """Where a submitted run goes and what it declares of its training.

    Attributes:
      root: The run tree; the run goes into `<root>/<method>/<training_task>/<config>_seed<seed>`
        (a folder that must not exist yet).
      method: The method's name (letters, digits, `_`, `.`, `-`), not "preset".
      config: The configuration's name (the same characters); a configuration's seeds are
        its runs, ranked once it has 5 (docs/protocol.md#ranking).
      seed: The run's seed (≥ 0): one submission per seed, each a run of its own.
      training_task: The tier the method trained on (`protocol.TIERS`).
      evaluations: The training trials it used (a gait optimizer's budget), if any.
      control_steps: The training control steps it was given (a policy learner's budget),
        if any. With neither, the run is an untrained reference, listed and not ranked.
      threads: Evaluator threads (the card does not depend on them).
    """

    root: str = "runs"
    method: str = ""
    config: str = "default"
    seed: int = 0
    training_task: str = protocol.TIERS[0]
    evaluations: int | None = None
    control_steps: int | None = None
    threads: int = 2

    def __post_init__(self):
        cli.require(bool(self.root), "--root must name the run tree, got an empty path")
        for flag, value in (("method", self.method), ("config", self.config)):
            cli.require(
                isinstance(value, str) and bool(_NAME.match(value)),
                f"--{flag} must be letters, digits, '_', '.' or '-', got {value!r}",
            )
        cli.require(self.method != "preset", "--method=preset names untrained score cards")
        cli.require_integer("seed", self.seed, 0)
        cli.require(
            self.training_task in protocol.TIERS,
            f"--training_task must be one of {', '.join(protocol.TIERS)}, got "
            f"{self.training_task!r}",
        )
        if self.evaluations is not None:
            cli.require_integer("evaluations", self.evaluations, 1)
        if self.control_steps is not None:
            cli.require_integer("control_steps", self.control_steps, 1)
        cli.require(
            self.evaluations is None or self.control_steps is None,
            "give --evaluations (training trials) or --control_steps, not both",
        )
        cli.require_integer("threads", self.threads, 1)

    def run_dir(self) -> str:
        """The run's folder."""
        name = f"{self.config}_seed{self.seed}"
        return os.path.join(self.root, self.method, self.training_task, name)


def submit_gait(amplitudes, submission: Submission) -> str:
    """Scores an open-loop CPG gait under the protocol into a run folder.

    Args:
      amplitudes: The 11 CPG amplitudes, degrees (a sequence, or a mapping by
        `cpg.AMPLITUDE_NAMES`).
      submission: Where the run goes and what it declares.

    Returns:
      The run folder.

    Raises:
      ValueError: On bad amplitudes, or if the run folder exists.
    """
    vector = cpg.amplitudes_from(amplitudes)
    params = {"amplitudes": {n: float(v) for n, v in zip(cpg.AMPLITUDE_NAMES, vector)}}
    return _submit(submission, lambda d: runs.write_json(os.path.join(d, admission.GAIT), params))


def submit_policy(policy: exported.NumpyPolicy, submission: Submission) -> str:
    """Scores a policy exported as arrays under the protocol into a run folder.

    Args:
      policy: The policy (`cpg_suite.runfiles.exported.NumpyPolicy`: an MLP on the task's
        observation, in the "joints" or "cpg" action space).
      submission: Where the run goes and what it declares.

    Returns:
      The run folder.

    Raises:
      ValueError: If the run folder exists.
    """
    return _submit(submission, lambda d: policy.save(os.path.join(d, admission.EXPORTED)))


def submit_actions(actions, submission: Submission) -> str:
    """Scores a time-indexed open-loop controller, a table of actions, under the protocol.

    Row t is the task's action at control step t of every trial (`exported.ActionTable`):
    a table of one row per control step of a protocol trial, stored as
    `selected_actions.npy` (float64, no pickle).

    Args:
      actions: (1000, 12) actions in the task's action space [−1, 1] (an array, or an
        `exported.ActionTable`).
      submission: Where the run goes and what it declares.

    Returns:
      The run folder.

    Raises:
      ValueError: On another shape, a value outside [−1, 1] or not finite, or if the run
        folder exists.
    """
    table = actions if isinstance(actions, exported.ActionTable) else exported.ActionTable(actions)
    wanted = (score.ScoreSettings.steps, exported.N_ACTIONS)
    if table.actions.shape != wanted:
        raise ValueError(
            f"the actions must be one row per control step of a protocol trial, shape "
            f"{wanted}, got {table.actions.shape}"
        )
    return _submit(submission, lambda d: table.save(os.path.join(d, admission.ACTIONS)))


def submit_code(path: str, submission: Submission) -> str:
    """Scores a policy given as Python code under the protocol into a run folder.

    The file is copied into the run as `policy_code.py` and executed to score it (calling
    this is the request to run it): it must define `make_policy()`, returning a callable
    from the task's observation to a (12,) action in [−1, 1] (with `reset()`, called
    before each trial, if it keeps state). `verify` runs it again only with `--trust_code`;
    the board admits the run on its files without running it. For cards that are the same
    on every machine, compute with `cpg_suite.portable` rather than BLAS
    (docs/submit.md#data-and-code).

    Args:
      path: The policy's Python file (one file; it may import what is installed).
      submission: Where the run goes and what it declares.

    Returns:
      The run folder.

    Raises:
      ValueError: If the file defines no `make_policy()` or it returns no callable, or the
        run folder exists (nothing is left behind).
      OSError: If the file cannot be read.
      Exception: Whatever the file raises when it runs.
    """
    with open(path, "rb") as f:
        code = f.read()
    return _submit(
        submission,
        lambda d: runs.write_bytes(os.path.join(d, admission.CODE), code),
        trust_code=True,
    )


PARTIAL = ".partial-"  # a submission's folder while it is written (`partial_folder`)


def partial_folder(run_dir: str) -> str:
    """Where a submission is written before it is renamed into `run_dir`: a hidden folder
    beside it (`.<run name>.partial-<random>`), which the board lists as half-written if a
    killed process leaves it behind."""
    parent, name = os.path.split(os.path.normpath(run_dir))
    return os.path.join(parent, f".{name}{PARTIAL}{secrets.token_hex(4)}")


def _submit(submission: Submission, write_artifact, trust_code: bool = False) -> str:
    """Writes the run into a temporary folder and renames it into place once complete: the
    run folder holds a whole run or does not exist."""
    run_dir = submission.run_dir()
    if os.path.exists(run_dir):
        raise ValueError(f"{run_dir} exists: a submission makes a new run")
    partial = partial_folder(run_dir)
    os.makedirs(partial)
    try:
        _score_into(partial, submission, write_artifact, trust_code)
        os.rename(partial, run_dir)  # fails if run_dir appeared meanwhile: nothing replaced
    except BaseException:
        shutil.rmtree(partial, ignore_errors=True)  # no half-made run stays behind
        raise
    return run_dir


def _score_into(run_dir: str, submission: Submission, write_artifact, trust_code: bool) -> str:
    write_artifact(run_dir)
    settings = {
        "task": submission.training_task,
        "seed": submission.seed,
        "test_seeds": len(protocol.TEST),
        "trial_steps": score.ScoreSettings.steps,
        "test_tiers": list(protocol.TIERS),
        "controller": "open_loop",
        "benchmark_version": protocol.BENCHMARK_VERSION,
    }
    if submission.control_steps is not None:
        settings["total_steps"] = submission.control_steps
    command = runs.command_line(
        "cpg_suite.protocol.submit",
        {
            k: getattr(submission, k)
            for k in ("method", "config", "seed", "training_task", "evaluations", "control_steps")
        },
    )
    runs.write_config(run_dir, settings, command)
    config = runs.read_json(os.path.join(run_dir, "config.json"))
    card_settings = verify.card_settings(
        config, threads=submission.threads, card={"benchmark_version": protocol.BENCHMARK_VERSION}
    )
    # As verify will score it (the submitter asked for its code to run, if it is code).
    card, trials = verify.score_run(run_dir, card_settings, trust_code)
    summary = {"test": json.loads(json.dumps(runs.to_jsonable(score.stored_card(card))))}
    if submission.evaluations is not None:
        summary["evaluations"] = submission.evaluations
    if submission.control_steps is not None:
        summary["env_steps"] = submission.control_steps
    runs.write_json(os.path.join(run_dir, "summary.json"), summary)
    verify.write_trials(os.path.join(run_dir, "trials.csv"), trials)
    made = config["environment"]
    runs.write_json(
        os.path.join(run_dir, "versions.json"),
        {"made_with": made, "scored_with": runs.environment_record()},
    )
    final = os.path.basename(submission.run_dir())  # checked under the name it will have
    reason = admission.run_refusal(run_dir, name=final)
    if reason:  # the files above are what the board admits: this is a bug if it happens
        raise RuntimeError(f"{run_dir}: the board would refuse the submission: {reason}")
    return run_dir


def define_flags() -> None:
    """Defines this module's command-line flags (only when it runs as a program)."""
    d = Submission  # its defaults (an empty method is no valid submission)
    one = "give one of --gait, --policy, --actions, --code"
    flags.DEFINE_string(
        "gait", None, f"none: not a gait. JSON file of the 11 CPG amplitudes by name ({one})."
    )
    flags.DEFINE_string(
        "policy",
        None,
        f"none: not a policy. An exported policy: NumPy arrays in {exported.FILE}'s format.",
    )
    flags.DEFINE_string(
        "actions", None, "none: not a table. A (1000, 12) float64 .npy table of actions per step."
    )
    flags.DEFINE_string(
        "code", None, "none: not code. A Python file defining make_policy() (it is run)."
    )
    flags.DEFINE_string("root", d.root, "The run tree; the run goes into a new folder in it.")
    flags.DEFINE_string("method", d.method, "The method's name (required).")
    flags.DEFINE_string("config", d.config, "The configuration's name.")
    flags.DEFINE_integer("seed", d.seed, "The run's seed.")
    flags.DEFINE_string("training_task", d.training_task, "The tier the method trained on.")
    flags.DEFINE_integer(
        "evaluations",
        None,
        "none: no budget. Training trials used (a gait optimizer's budget). A run with "
        "neither budget is an untrained reference: listed on the board, never ranked.",
    )
    flags.DEFINE_integer(
        "control_steps",
        None,
        "none: no budget. Training control steps given (a learner's budget; see --evaluations).",
    )
    flags.DEFINE_integer("threads", d.threads, "Evaluator threads (the card does not change).")


_KINDS = ("gait", "policy", "actions", "code")  # the flags naming what is submitted
# The files of data that --policy and --actions take: how each starts, and its name.
_NUMPY_FILES = {
    "policy": (b"PK\x03\x04", "a NumPy .npz archive of arrays"),
    "actions": (b"\x93NUMPY", "a NumPy .npy array"),
}


def _gait_by_name(path: str):
    """The amplitudes of a --gait file: a JSON object of the 11 amplitudes by name, or such
    an object under "amplitudes" (as `selected_params.json` holds them).

    Raises:
      ValueError: If the file is no JSON, or gives the amplitudes otherwise than by name.
    """
    with open(path, encoding="utf-8") as f:
        try:
            data = json.load(f)
        except json.JSONDecodeError as e:
            raise ValueError(f"not JSON ({e})") from None
    if isinstance(data, dict) and "amplitudes" in data:
        data = data["amplitudes"]
    if not isinstance(data, dict):
        kind = "array" if isinstance(data, list) else type(data).__name__
        first = cpg.AMPLITUDE_NAMES[0]
        raise ValueError(
            f'the amplitudes go by name, {{"{first}": degrees, ...}} (all '
            f"{cpg.N_AMPLITUDES} of {', '.join(cpg.AMPLITUDE_NAMES)}), got a JSON {kind}"
        )
    return cpg.amplitudes_from(data)


def _check_numpy_file(kind: str, path: str) -> None:
    """Refuses a --policy or --actions file that is not NumPy's own format (a pickle, text).

    Raises:
      UsageError: Naming the flag, the file and what it must be.
    """
    magic, words = _NUMPY_FILES[kind]
    with open(path, "rb") as f:
        start = f.read(len(magic))
    cli.check(
        start == magic,
        f"--{kind}={path} is not {words}; submit reads data only, never a pickle or code",
    )


def main(argv: list[str]) -> None:
    """Scores the gait or policy into a run folder and prints its path and card."""
    del argv
    submission = cli.settings_from_flags(Submission)
    given = [(k, getattr(flags.FLAGS, k)) for k in _KINDS if getattr(flags.FLAGS, k) is not None]
    cli.check(
        len(given) == 1,
        f"give exactly one of {', '.join(f'--{k}' for k in _KINDS[:-1])} and --{_KINDS[-1]}",
    )
    ((kind, path),) = given
    cli.check(os.path.isfile(path), f"--{kind}={path} is not a file")
    # What is wrong with the output folder names the output folder.
    cli.check_output_dir(submission.root, "--root")
    cli.check(
        not os.path.exists(submission.run_dir()),
        f"--root={submission.root}: {submission.run_dir()} exists: a submission makes a new run",
    )
    if kind in _NUMPY_FILES:
        _check_numpy_file(kind, path)
    try:
        if kind == "gait":
            run_dir = submit_gait(_gait_by_name(path), submission)
        elif kind == "policy":
            run_dir = submit_policy(exported.NumpyPolicy.load(path), submission)
        elif kind == "actions":
            run_dir = submit_actions(exported.ActionTable.load(path), submission)
        else:
            run_dir = submit_code(path, submission)
    except (ValueError, KeyError, OSError, sandbox.PolicyFailed) as e:
        if "allow_pickle" in str(e):  # NumPy's advice to unpickle: not ours to give
            e = "it holds pickled (object) arrays; submit reads plain arrays only, never a pickle"
        raise cli.UsageError(verify.one_line(f"--{kind}={path}: {e}")) from None
    card = runs.read_json(os.path.join(run_dir, "summary.json"))["test"]
    print(score.format_card(card))
    print(f"wrote {run_dir}")


if __name__ == "__main__":
    define_flags()
    cli.run(main)

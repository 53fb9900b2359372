r"""An outside method's gait or policy, scored under the protocol into a run folder that
`verify` and the leaderboard accept (docs/submit.md).

  python -m cpg_suite.protocol.submit --gait=my_gait.json --method=my_search \
      --config=K20 --seed=0 --evaluations=400 --root=runs
  python -m cpg_suite.protocol.submit --policy=my_policy.npz --method=my_learner \
      --config=mlp64 --seed=0 --control_steps=2000000 --root=runs

In Python: `submit_gait(amplitudes, Submission(...))` or `submit_policy(NumpyPolicy(...),
Submission(...))`. What is submitted is data the benchmark runs itself — the 11 CPG
amplitudes (`selected_params.json`) or an MLP exported as arrays (`selected_policy.npz`,
`cpg_suite.harness.exported`) — never code: verify scores it again, and the board reads
no more than its JSON and CSV files. The card is made the way verify makes it (from the
files just written), under the protocol's card settings of the current benchmark version;
the run folder holds `config.json`, `summary.json`, `trials.csv`, `versions.json` and the
gait or policy, and the board admits it (checked before returning).
"""

from __future__ import annotations

if __name__ == "__main__":  # this program never renders: no OpenGL backend, no GLFW warning
    from cpg_suite import cli

    cli.without_rendering()

import dataclasses
import json
import os
import re

from absl import flags

from cpg_suite import cli, cpg, protocol
from cpg_suite.harness import exported, runs
from cpg_suite.protocol import admission, score, verify

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
      policy: The policy (`cpg_suite.harness.exported.NumpyPolicy`: an MLP on the task's
        observation, in the "joints" or "cpg" action space).
      submission: Where the run goes and what it declares.

    Returns:
      The run folder.

    Raises:
      ValueError: If the run folder exists.
    """
    return _submit(submission, lambda d: policy.save(os.path.join(d, admission.EXPORTED)))


def _submit(submission: Submission, write_artifact) -> str:
    run_dir = submission.run_dir()
    if os.path.exists(run_dir):
        raise ValueError(f"{run_dir} exists: a submission makes a new run")
    os.makedirs(run_dir)
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
    card, trials = verify.score_run(run_dir, card_settings)  # as verify will score it
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
    reason = admission.run_refusal(run_dir)
    if reason:  # the files above are what the board admits: this is a bug if it happens
        raise RuntimeError(f"{run_dir}: the board would refuse the submission: {reason}")
    return run_dir


def define_flags() -> None:
    """Defines this module's command-line flags (only when it runs as a program)."""
    d = Submission  # its defaults (an empty method is no valid submission)
    flags.DEFINE_string("gait", None, "JSON file of the 11 CPG amplitudes (by name).")
    flags.DEFINE_string("policy", None, f"An exported policy ({exported.FILE}'s format).")
    flags.DEFINE_string("root", d.root, "The run tree the run goes into.")
    flags.DEFINE_string("method", d.method, "The method's name.")
    flags.DEFINE_string("config", d.config, "The configuration's name.")
    flags.DEFINE_integer("seed", d.seed, "The run's seed.")
    flags.DEFINE_string("training_task", d.training_task, "The tier the method trained on.")
    flags.DEFINE_integer("evaluations", None, "Training trials used (a gait optimizer).")
    flags.DEFINE_integer("control_steps", None, "Training control steps given (a learner).")
    flags.DEFINE_integer("threads", d.threads, "Evaluator threads (the card does not change).")


def main(argv: list[str]) -> None:
    """Scores the gait or policy into a run folder and prints its path and card."""
    del argv
    submission = cli.settings_from_flags(Submission)
    gait, policy = flags.FLAGS.gait, flags.FLAGS.policy
    cli.check((gait is None) != (policy is None), "give exactly one of --gait and --policy")
    path = gait or policy
    cli.check(os.path.isfile(path), f"--{'gait' if gait else 'policy'}={path} is not a file")
    try:
        if gait:
            run_dir = submit_gait(cpg.load_amplitudes(gait), submission)
        else:
            run_dir = submit_policy(exported.NumpyPolicy.load(policy), submission)
    except (ValueError, KeyError, OSError) as e:
        raise cli.UsageError(f"{path}: {e}") from None
    card = runs.read_json(os.path.join(run_dir, "summary.json"))["test"]
    print(score.format_card(card))
    print(f"wrote {run_dir}")


if __name__ == "__main__":
    define_flags()
    cli.run(main)

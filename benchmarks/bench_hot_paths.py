r"""Every hot path's ratio to a raw `mujoco.rollout` of the same physics, in one run.

  python benchmarks/bench_hot_paths.py [--clock=cpu] [--repeats=3] [--steps=1000]
      [--paths=env,vector,evaluator,feedback,score] [--threads=1]

For each path, in one process, ours and the raw rollout timed in turn (ours, raw, ours,
raw, ...; best of `--repeats` each, so a slow spell of a shared machine falls on both
sides), as physics steps per second:
  * `env.step` of every DARwIn-OP tier (`darwin_walk`, `darwin_balance`,
    `darwin_walk_randomized`, `darwin_walk_push`, `darwin_walk_rough`,
    `darwin_walk_contact`), the hand-tuned gait for `--steps` control steps (`bench_env`'s
    actions and controls),
    against a 1-thread rollout of the same model, initial state and controls;
  * the vector env (`cpg_suite.vector.DarwinVectorEnv`, `darwin_walk`, 8 robots,
    `--threads`), the gait from 8 seeded starts (`bench_vector_env`'s), against a rollout
    of the same states and controls with as many threads;
  * the batched open-loop evaluator (`cpg_suite.evaluation.open_loop.BatchEvaluator`,
    `--threads`), 8 candidates around the hand-tuned gait (some fall, as in a CEM round:
    the evaluator stops them, the rollout does not, so steps per second are compared);
  * the batched closed-loop evaluator (`cpg_suite.evaluation.closed_loop.FeedbackEvaluator`,
    `--threads`), a round of the feedback runs (50 candidates with small feedback gains ×
    2 starts on `darwin_walk_randomized`, a quarter of `--steps`), against a rollout of the
    controls it set, from the same states on the same models;
  * scoring (`cpg_suite.protocol.score.score_gait`, the card's tiers × 2 test seeds,
    `--threads`) against a rollout of the nominal gait.
ratio = ours / raw in physics steps per second: 1 is free, the goal is ≥ 0.8 (issue 55),
the floor the slow test holds is 0.75 (`tests/test_hot_paths.py`). `--clock=cpu` times
the process's CPU time (steadier on a shared machine; with threads it counts every
thread's time, on both sides alike). `ratios` is what the test calls.
"""

from __future__ import annotations

if __name__ == "__main__":  # this program never renders: no OpenGL backend, no GLFW warning
    from cpg_suite import cli

    cli.without_rendering()

import contextlib
import dataclasses
import time

import mujoco
import numpy as np
from absl import flags
from mujoco import rollout

import cpg_suite
from cpg_suite import cli, cpg, protocol

CLOCKS = {"wall": time.perf_counter, "cpu": time.process_time}
DARWIN_TIERS = (
    "darwin_walk",
    "darwin_balance",
    "darwin_walk_randomized",
    "darwin_walk_push",
    "darwin_walk_rough",
    "darwin_walk_contact",
)
PATHS = ("env", "vector", "evaluator", "feedback", "score")
GOAL, FLOOR = 0.8, 0.75
_ROBOTS, _VECTOR_SEED = 8, 100
# A round of the feedback runs (`cmaes --controller=feedback`): 50 candidates × 2 starts on
# the randomized tier.
_FEEDBACK_K, _FEEDBACK_SEEDS, _FEEDBACK_TIER = 50, (0, 1), "darwin_walk_randomized"


def _paired(ours, raw, repeats: int, now) -> tuple[float, float]:
    """Best-of-`repeats` seconds of `ours()` and of `raw()` on the clock `now`, the two
    timed in turn (ours, raw, ours, raw, ...) so that a slow spell of a shared machine falls
    on both sides alike instead of on one side's block of timings. A measure other than a
    clock (`bench_instructions.Counts`: instructions) pairs the two itself."""
    if hasattr(now, "paired"):
        return now.paired(ours, raw)
    best = [np.inf, np.inf]
    for _ in range(repeats):
        for side, fn in enumerate((ours, raw)):
            start = now()
            fn()
            best[side] = min(best[side], now() - start)
    return best[0], best[1]


@contextlib.contextmanager
def _rollout(model, datas, states, controls, threads: int):
    """A call of one `mujoco.rollout` of `controls` from `states` (`threads` > 1: a pool)."""
    with rollout.Rollout(nthread=threads if threads > 1 else 0) as runner:
        data = datas if threads > 1 else datas[0]
        yield lambda: runner.rollout(model, data, states, controls)


def env_step(task_id: str, steps: int, repeats: int, now) -> tuple[float, float]:
    """(ours, raw) physics steps per second of `env.step` of a task and its rollout."""
    env = cpg_suite.load(task_id, task_kwargs={"random": 0})
    physics = env.physics
    episode = cpg.trajectories(cpg.amplitudes_from("hand_tuned"), 1000, env.control_timestep())
    actions = np.resize(physics.targets_to_action(episode[0]), (steps, 12))  # `bench_env`'s
    n_sub = int(round(env.control_timestep() / physics.model.opt.timestep))

    def run():
        env.reset()
        for a in actions:
            if env.step(a).last():
                env.reset()  # (not with the gait: it walks the whole time)

    # The controls the task set, from its initial state (`bench_env.time_raw`'s).
    env.reset()
    model = physics.model.ptr
    spec = mujoco.mjtState.mjSTATE_FULLPHYSICS
    initial = np.empty(mujoco.mj_stateSize(model, spec))
    mujoco.mj_getState(model, physics.data.ptr, initial, spec)
    ctrls = np.empty((len(actions), model.nu))
    for t, a in enumerate(actions):
        if env.step(a).last():
            env.reset()
        ctrls[t] = physics.data.ctrl
    controls = np.repeat(ctrls, n_sub, axis=0)[None]
    with _rollout(model, [mujoco.MjData(model)], initial[None], controls, 1) as raw_run:
        ours, raw = _paired(run, raw_run, repeats, now)
    return steps * n_sub / ours, steps * n_sub / raw


def vector_env(steps: int, threads: int, repeats: int, now) -> tuple[float, float]:
    """(ours, raw) physics steps per second of the vector env and its rollout."""
    from cpg_suite import vector

    envs = vector.DarwinVectorEnv("darwin_walk", _ROBOTS, threads=threads)
    try:
        first = envs.envs[0]
        targets = cpg.trajectories(
            cpg.amplitudes_from("hand_tuned"), steps, first.control_timestep()
        )[0]
        actions = np.repeat(first.physics.targets_to_action(targets)[:, None], _ROBOTS, axis=1)
        ctrls = first.physics.controls_for(targets)
        counted = []

        def run():
            envs.reset(seed=_VECTOR_SEED)
            before = envs.physics_steps
            for a in actions:
                envs.step(a)
            counted.append(envs.physics_steps - before)

        envs.reset(seed=_VECTOR_SEED)
        models = [e.physics.model.ptr for e in envs.envs]
        spec = mujoco.mjtState.mjSTATE_FULLPHYSICS
        states = np.empty((_ROBOTS, mujoco.mj_stateSize(models[0], spec)))
        for i, e in enumerate(envs.envs):
            mujoco.mj_getState(e.physics.model.ptr, e.physics.data.ptr, states[i], spec)
        controls = np.repeat(ctrls, envs.n_sub, axis=0)
        controls = np.broadcast_to(controls, (_ROBOTS,) + controls.shape).copy()
        datas = [mujoco.MjData(models[0]) for _ in range(threads)]
        with _rollout(models, datas, states, controls, threads) as raw_run:
            ours, raw = _paired(run, raw_run, repeats, now)
    finally:
        envs.close()
    return counted[-1] / ours, controls.shape[0] * controls.shape[1] / raw


def _candidates(n: int = 8) -> np.ndarray:
    """Candidates around the hand-tuned gait with the CEM's initial spread (`bench_eval`'s)."""
    rng = np.random.default_rng(0)
    return cpg.amplitudes_from("hand_tuned") + rng.standard_normal((n, 11))


def evaluator(steps: int, threads: int, repeats: int, now) -> tuple[float, float]:
    """(ours, raw) physics steps per second of the open-loop evaluator and its rollout."""
    from cpg_suite.evaluation.open_loop import BatchEvaluator

    amplitudes = _candidates()
    with BatchEvaluator("darwin_walk", steps, threads) as ev:
        ev.evaluate(amplitudes[:1], [0])  # warm the initial-state cache
        counted = []

        def run():
            counted.append(ev.evaluate(amplitudes, [0]).sim_steps)

        controls = np.repeat(ev.controls(amplitudes), ev.n_sub, axis=1)
        initial = np.tile(ev.initial_state(0), (len(amplitudes), 1))
        datas = [mujoco.MjData(ev.model) for _ in range(threads)]
        with _rollout(ev.model, datas, initial, controls, threads) as raw_run:
            ours, raw = _paired(run, raw_run, repeats, now)
    return counted[-1] / ours, controls.shape[0] * controls.shape[1] / raw


def feedback_evaluator(steps: int, threads: int, repeats: int, now) -> tuple[float, float]:
    """(ours, raw) physics steps per second of the closed-loop evaluator on a round of the
    feedback runs' size, and of a rollout of the controls it set in each control step,
    from its trials' initial states on their episodes' models."""
    from cpg_suite import feedback
    from cpg_suite.evaluation.closed_loop import FeedbackEvaluator

    rng = np.random.default_rng(1)
    amplitudes = cpg.amplitudes_from("hand_tuned") + rng.standard_normal((_FEEDBACK_K, 11))
    gains = rng.uniform(-0.05, 0.05, (_FEEDBACK_K, feedback.N_GAINS))
    params = np.concatenate([amplitudes, gains], axis=1)
    with FeedbackEvaluator(_FEEDBACK_TIER, steps, threads) as ev:
        counted = []

        def run():
            counted.append(ev.evaluate(params, _FEEDBACK_SEEDS).sim_steps)

        step_trial, given = ev._step_trial, {}

        def recording(trial, ctrl, t):  # the controls each trial was given
            given.setdefault(id(trial), (trial, []))[1].append(np.array(ctrl))
            step_trial(trial, ctrl, t)

        ev._step_trial = recording
        ev.evaluate(params, _FEEDBACK_SEEDS)
        ev._step_trial = step_trial
        episodes = [ev._open.episode(s) for s in _FEEDBACK_SEEDS]
        trials = len(given)
        controls = np.zeros((trials, steps * ev.n_sub, episodes[0].model.nu))
        for k, (_, ctrls) in enumerate(given.values()):  # a fallen trial's last controls held
            held = np.repeat(np.array(ctrls), ev.n_sub, axis=0)
            rest = np.repeat(held[-1:], steps * ev.n_sub - len(held), 0)
            controls[k] = np.concatenate([held, rest])
        order = [episodes[k % len(episodes)] for k in range(trials)]  # (candidate, seed)
        models = [e.model for e in order]
        initial = np.array([e.state for e in order])
        datas = [mujoco.MjData(models[0]) for _ in range(threads)]
        with _rollout(models, datas, initial, controls, threads) as raw_run:
            ours, raw = _paired(run, raw_run, repeats, now)
    return counted[-1] / ours, controls.shape[0] * controls.shape[1] / raw


def scoring(steps: int, threads: int, repeats: int, now) -> tuple[float, float]:
    """(ours, raw) physics steps per second of scoring the hand-tuned gait (the card's tiers ×
    2 test seeds) and of rollouts of the same trials: each from its episode's reset state on
    its episode's own model (the rough tier's tiles, the contact tier's floor), tier by tier
    (pushes aside)."""
    from cpg_suite.evaluation.open_loop import BatchEvaluator
    from cpg_suite.protocol import score

    amplitudes = cpg.amplitudes_from("hand_tuned")
    settings = score.ScoreSettings(seeds=2, steps=steps, threads=threads)
    counted = []

    def run():
        counted.append(score.score_gait(amplitudes, settings)["scoring_sim_steps"])

    raw_runs, raw_steps = [], 0
    seeds = protocol.held_out_seeds(settings.seeds)
    with contextlib.ExitStack() as stack:
        for tier in settings.tiers:
            ev = stack.enter_context(BatchEvaluator(tier, steps, threads))
            ctrl = ev.controls(amplitudes[None])[0].repeat(ev.n_sub, axis=0)
            episodes = [ev.episode(seed) for seed in seeds]
            models = [e.model for e in episodes]
            states = np.array([e.state for e in episodes])
            controls = np.tile(ctrl, (len(seeds), 1, 1))
            datas = [mujoco.MjData(models[0]) for _ in range(threads)]
            raw_runs.append(stack.enter_context(_rollout(models, datas, states, controls, threads)))
            raw_steps += len(seeds) * len(ctrl)
        ours, raw = _paired(run, lambda: [r() for r in raw_runs], repeats, now)
    return counted[-1] / ours, raw_steps / raw


def ratios(
    paths=PATHS,
    steps: int = 1000,
    repeats: int = 3,
    threads: int = 1,
    clock: str = "cpu",
    tiers=DARWIN_TIERS,
):
    """Yields `(path, ours, raw)` in physics steps per second, each pair timed in turn.

    Args:
      paths: Which of `PATHS`.
      steps: Control steps per env timing and per trial (the vector env: a quarter).
      repeats: Timings per figure (the best is kept).
      threads: Threads of the vector env, the evaluator, scoring and their rollouts.
      clock: "cpu" (the process's CPU time) or "wall", or a measure that pairs the two
        sides itself (`bench_instructions.Counts`).
      tiers: The DARwIn-OP tiers whose `env.step` is timed.
    """
    now = CLOCKS[clock] if isinstance(clock, str) else clock
    if "env" in paths:
        for task_id in tiers:
            yield f"env.step {task_id}", *env_step(task_id, steps, repeats, now)
    if "vector" in paths:
        yield (
            f"vector env ({_ROBOTS} robots)",
            *vector_env(max(1, steps // 4), threads, repeats, now),
        )
    if "evaluator" in paths:
        yield "open-loop evaluator (8 candidates)", *evaluator(steps, threads, repeats, now)
    if "feedback" in paths:
        yield (
            f"closed-loop evaluator ({_FEEDBACK_K}x{len(_FEEDBACK_SEEDS)} trials)",
            *feedback_evaluator(max(1, steps // 4), threads, repeats, now),
        )
    if "score" in paths:
        # Best of `repeats` like the others: a card's 50 seeds a tier amortize the evaluators'
        # set-up (model compiles and copies) that a single cold call of 2 seeds weighs 25x.
        yield (
            f"scoring ({len(protocol.TIERS)} tiers x 2 seeds)",
            *scoring(steps, threads, repeats, now),
        )


@dataclasses.dataclass(frozen=True)
class HotPathSettings:
    """What the benchmark times.

    Attributes:
      steps: Control steps per env timing and per trial.
      repeats: Timings per figure (the best is kept).
      threads: Threads of the vector env, the evaluator, scoring and their rollouts.
      clock: "cpu" or "wall".
      paths: Which paths (`PATHS`).
    """

    steps: int = 1000
    repeats: int = 3
    threads: int = 1
    clock: str = "cpu"
    paths: tuple[str, ...] = PATHS

    def __post_init__(self):
        cli.require(self.steps >= 1, f"--steps must be ≥ 1, got {self.steps}")
        cli.require(self.repeats >= 1, f"--repeats must be ≥ 1, got {self.repeats}")
        cli.require(self.threads >= 1, f"--threads must be ≥ 1, got {self.threads}")
        cli.require(self.clock in CLOCKS, f"--clock must be wall or cpu, got {self.clock!r}")
        paths = tuple(p for p in self.paths if p)
        unknown = [p for p in paths if p not in PATHS]
        cli.require(bool(paths) and not unknown, f"--paths: one or more of {', '.join(PATHS)}")
        object.__setattr__(self, "paths", paths)


def main(argv: list[str]) -> None:
    del argv
    s = cli.settings_from_flags(HotPathSettings)
    print(
        f"physics steps per second ({s.clock} clock, best of {s.repeats}, {s.threads} "
        f"thread(s)); ratio = ours / raw mujoco.rollout (goal >= {GOAL}, floor {FLOOR})"
    )
    print(f"{'path':40s} {'ours':>9s} {'raw':>9s} {'ratio':>6s}")
    for path, ours, raw in ratios(s.paths, s.steps, s.repeats, s.threads, s.clock):
        verdict = "ok" if ours / raw >= GOAL else "below goal" if ours / raw >= FLOOR else "LOW"
        print(f"{path:40s} {ours:9.0f} {raw:9.0f} {ours / raw:6.3f} {verdict}", flush=True)


def define_flags() -> None:
    """Defines this script's command-line flags (only when it runs as a program)."""
    d = HotPathSettings()
    flags.DEFINE_integer("steps", d.steps, "Control steps per env timing and per trial.")
    flags.DEFINE_integer("repeats", d.repeats, "Timings per figure (the best is kept).")
    flags.DEFINE_integer("threads", d.threads, "Threads of the vector env, evaluator, scoring.")
    flags.DEFINE_enum("clock", d.clock, list(CLOCKS), "cpu: the process's CPU time; wall.")
    flags.DEFINE_list("paths", list(d.paths), "Paths, comma-separated: " + ", ".join(PATHS))


if __name__ == "__main__":
    define_flags()
    cli.run(main)

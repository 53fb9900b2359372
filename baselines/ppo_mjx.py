r"""PPO (Brax) on the MJX walking tiers: the GPU training path, scored on the CPU reference.

  pip install ".[gpu]"   # JAX with CUDA, MJX, Brax
  python -m baselines.ppo_mjx --task=darwin_walk --action_space=cpg
  python -m baselines.ppo_mjx --task=darwin_walk --action_space=joints --total_steps=100000000

Beyond the study (docs/decisions.md#ppo-on-mjx). Brax's PPO
(`brax.training.agents.ppo.train`) learns on `num_envs` copies of the training tier in MJX
(`cpg_suite.mjx.WalkEnv` behind `cpg_suite.mjx.training`: fresh per-episode draws, the
time limit a truncation, a fall terminal). Each update collects `unroll_length` steps of
`batch_size` × `num_minibatches` environments, computes GAE advantages (discount
`discounting`, λ = `gae_lambda`) on rewards × `reward_scaling`, and makes
`num_updates_per_batch` passes of `num_minibatches` minibatches minimizing the clipped
surrogate loss (ratio clipped to 1 ± `clipping_epsilon`) + ½ value loss − `entropy_cost` ·
entropy with Adam at `learning_rate`; observations are normalized by running statistics.
The defaults are the configuration that learned to walk in the study's 2.5 M steps
(results/mjx): Stable-Baselines3's Gaussian policy (`--policy_head=normal`, whose mean
starts near 0, the `cpg` space's open-loop gait), its PPO's passes and minibatches over
256 robots, and the MJX physics made cheaper in training with the soles' contact pairs
only and the line search capped at 8 (`--contacts=soles --solver_iterations=100,8`;
`--contacts=model --solver_iterations=` train on the reference's). MuJoCo Playground's
locomotion settings, for GPU budgets of 100 M+ steps, are in docs/decisions.md#ppo-on-mjx.

Selection and scoring happen on the CPU reference, never in MJX: every
`validation_every` env steps the deterministic policy is exported to NumPy
(`NumpyPolicy`) and run in the CPU task on `validation_seeds` validation seeds of the
training tier; the best one is kept as `selected_policy.npz` and scored at the end on the
test protocol (`cpg_suite.protocol.score`), which makes a leaderboard row whose budget
holds the env steps and the training wall time on the named device.

Run directory `<output_dir>/ppo_mjx/<task>/<action_space>_seed<seed>/`: config.json,
progress.csv, checkpoint.pkl (the last parameters), selected_policy.npz, summary.json.
`--resume` restarts from checkpoint.pkl's parameters and normalizer for the remaining
steps; Adam's moments and the environments start afresh, so a resumed run is not bit for
bit the uninterrupted one (Brax's trainer keeps no more). Training on one machine and
scoring on another: `--test_seeds=0` on the GPU machine, then the same command with
`--resume` and the scoring flags on the CPU one (the test_* settings may change on resume;
summary.json names the device that trained).
"""

from __future__ import annotations

if __name__ == "__main__":  # this program never renders: no OpenGL backend, no GLFW warning
    from cpg_suite import cli

    cli.without_rendering()

import dataclasses
import functools
import math
import os
import pickle
import time
from collections.abc import Callable

import mujoco
import numpy as np
from absl import flags

from cpg_suite import cli, darwin, progress, protocol
from cpg_suite.mjx import walk as mjx_walk
from cpg_suite.protocol import score
from cpg_suite.runfiles import runs
from cpg_suite.runfiles.exported import FILE as POLICY_FILE
from cpg_suite.runfiles.exported import HEADS, NumpyPolicy

METHOD = "ppo_mjx"  # its run directories' second level and its leaderboard rows
TASKS = mjx_walk.TASKS
ACTION_SPACES = mjx_walk.ACTION_SPACES
PROGRESS_FIELDS = [
    "env_steps",
    "validation_m",
    "validation_fall_rate",
    "best_validation_m",
    "train_wall_s",
    "steps_per_s",
]


# Settings added after the first runs whose default has changed since, with what a run
# recorded without them trained on (the others' defaults are still what it trained on).
BEFORE_ADDED = {
    "solver_iterations": (),
    "contacts": "model",
    "policy_head": "tanh_normal",
    "benchmark_version": 1,  # no supply limit in the MJX env nor in the CPU validations
}
_TRAINING = mjx_walk.PHYSICS["training"]  # the defaults below are its parts


@dataclasses.dataclass(frozen=True)
class PPOMJXSettings:
    """The settings of a PPO-on-MJX run; all of them decide the result.

    Attributes:
      task: The training tier (`cpg_suite.mjx.TASKS`).
      action_space: "joints" (12 joint targets) or "cpg" (CPG modulation).
      total_steps: Training env steps (control steps summed over the environments); Brax
        rounds them up to whole updates.
      num_envs: Environments stepped together (must divide batch_size × num_minibatches).
      seed: Seed of the networks, the sampling and the episode draws.
      trial_steps: Control steps per episode: training, validation and test (1000 = 16 s).
      validation_every: Env steps between CPU validations and checkpoints.
      validation_seeds: Validation seeds of the training tier the policy is selected on.
      test_seeds: Test seeds per tier of the final score card (0: no card).
      test_tiers: The tiers of the score card.
      unroll_length, batch_size, num_minibatches, num_updates_per_batch, learning_rate,
        entropy_cost, discounting, gae_lambda, clipping_epsilon, reward_scaling,
        max_grad_norm: Brax PPO's hyperparameters.
      policy_head: "tanh_normal" (Brax's default: the network outputs the mean and the
        softplus standard deviation of a Gaussian squashed by tanh) or "normal" (a Gaussian
        mean, clipped by the task, with a state-independent log standard deviation that
        starts at `init_noise_std`, the mean's layer initialized orthogonally with gain
        `mean_init_scale`: the policy of Stable-Baselines3's PPO, `baselines.ppo`).
      init_noise_std: "normal" head: the initial standard deviation.
      mean_init_scale: "normal" head: gain of the mean layer's orthogonal initialization.
      policy_layers: Hidden layers of the policy network.
      value_layers: Hidden layers of the value network.
      solver_iterations: `(iterations, line-search iterations)` caps of MJX's solver in
        training (`WalkEnv(solver_iterations=...)`; empty: the model's own 100 / 50, the
        CPU reference's). Validation and the test card always run on the CPU reference.
      contacts: Contact pairs MJX computes in training (`WalkEnv(contacts=...)`): "model"
        (every pair, the CPU reference's) or "soles" (floor and soles only, faster).
        With `solver_iterations`, the defaults are `cpg_suite.mjx.PHYSICS["training"]`'s.
      impl: MJX's backend (`cpg_suite.mjx.IMPLS`): "jax", or "warp" (MuJoCo Warp; on an
        NVIDIA GPU, the fast one).
      benchmark_version: The benchmark version trained under: its supply limit holds in
        the MJX env (a brown-out ends the episode like a fall) and in the CPU validations.
    """

    task: str = "darwin_walk"
    action_space: str = "joints"
    total_steps: int = 2_500_000
    num_envs: int = 256
    seed: int = 0
    trial_steps: int = 1000
    validation_every: int = 250_000
    validation_seeds: int = 10
    test_seeds: int = len(protocol.TEST)
    test_tiers: tuple[str, ...] = protocol.TIERS
    unroll_length: int = 32
    batch_size: int = 32
    num_minibatches: int = 8
    num_updates_per_batch: int = 10
    learning_rate: float = 3e-4
    entropy_cost: float = 0.0
    discounting: float = 0.99
    gae_lambda: float = 0.95
    clipping_epsilon: float = 0.2
    reward_scaling: float = 10.0
    max_grad_norm: float = 0.5
    policy_head: str = "normal"
    init_noise_std: float = 0.368  # e⁻¹: baselines.ppo's log_std_init = −1
    mean_init_scale: float = 0.01  # SB3's gain for the action layer
    policy_layers: tuple[int, ...] = (256, 256)
    value_layers: tuple[int, ...] = (256, 256)
    solver_iterations: tuple[int, ...] = _TRAINING.solver_iterations
    contacts: str = _TRAINING.contacts
    impl: str = "jax"
    benchmark_version: int = protocol.BENCHMARK_VERSION

    def __post_init__(self):
        require = cli.require
        require(self.task in TASKS, f"unknown --task {self.task!r}; valid: {', '.join(TASKS)}")
        require(
            self.action_space in ACTION_SPACES,
            f"--action_space must be one of {', '.join(ACTION_SPACES)}, got {self.action_space!r}",
        )
        for name in (
            "total_steps",
            "num_envs",
            "trial_steps",
            "validation_every",
            "validation_seeds",
            "unroll_length",
            "batch_size",
            "num_minibatches",
            "num_updates_per_batch",
        ):
            value = getattr(self, name)
            require(isinstance(value, int) and value >= 1, f"--{name} must be ≥ 1, got {value!r}")
        require(self.seed >= 0, f"--seed must be ≥ 0, got {self.seed}")
        require(
            (self.batch_size * self.num_minibatches) % self.num_envs == 0,
            f"--num_envs ({self.num_envs}) must divide --batch_size × --num_minibatches "
            f"({self.batch_size * self.num_minibatches})",
        )
        tiers = cli.require_scoring(self.validation_seeds, self.test_seeds, self.test_tiers)
        object.__setattr__(self, "test_tiers", tiers)
        require(
            self.policy_head in HEADS,
            f"--policy_head must be one of {', '.join(HEADS)}, got {self.policy_head!r}",
        )
        # Upper ends marked "a choice" bound only values that mean nothing or overflow.
        number = cli.require_number
        number("learning_rate", self.learning_rate, 0, 1, low_open=True)  # a choice
        number("clipping_epsilon", self.clipping_epsilon, 0, 10, low_open=True)  # a choice
        number("reward_scaling", self.reward_scaling, 0, 1e6, low_open=True)  # a choice
        number("max_grad_norm", self.max_grad_norm, 0, 1e6, low_open=True)  # a choice
        number("init_noise_std", self.init_noise_std, 0, 100, low_open=True)  # a choice
        number("mean_init_scale", self.mean_init_scale, 0, 100, low_open=True)  # a choice
        number("entropy_cost", self.entropy_cost, 0, 1e3)  # a choice
        number("discounting", self.discounting, 0, 1, low_open=True)
        number("gae_lambda", self.gae_lambda, 0, 1)
        for name in ("policy_layers", "value_layers"):
            object.__setattr__(self, name, _layers(getattr(self, name), name))
        try:
            caps = tuple(int(v) for v in self.solver_iterations)
        except (TypeError, ValueError):
            caps = (0,)
        require(
            not caps or (len(caps) == 2 and min(caps) >= 1),
            f"--solver_iterations must be two integers ≥ 1 (I,L) or empty, "
            f"got {self.solver_iterations!r}",
        )
        object.__setattr__(self, "solver_iterations", caps)
        require(
            self.contacts in mjx_walk.CONTACTS,
            f"--contacts must be one of {', '.join(mjx_walk.CONTACTS)}, got {self.contacts!r}",
        )
        require(
            self.impl in mjx_walk.IMPLS,
            f"--impl must be one of {', '.join(mjx_walk.IMPLS)}, got {self.impl!r}",
        )
        protocol.require_version(self.benchmark_version)

    def supply(self):
        """The supply limit trained under (`protocol.supply_limit`; None: unlimited)."""
        return protocol.supply_limit(self.benchmark_version)

    @property
    def num_evals(self) -> int:
        """Brax's evaluation points: the start and one per `validation_every` env steps."""
        return math.ceil(self.total_steps / self.validation_every) + 1


def _layers(value, name: str) -> tuple[int, ...]:
    try:
        layers = tuple(int(v) for v in value)
    except (TypeError, ValueError):
        raise ValueError(f"--{name} must be layer sizes, got {value!r}") from None
    cli.require(
        bool(layers) and all(v >= 1 for v in layers),
        f"--{name} must be positive layer sizes, got {value!r}",
    )
    return layers


def default_run_name(settings: PPOMJXSettings) -> str:
    """`<action_space>_seed<seed>`."""
    return f"{settings.action_space}_seed{settings.seed}"


# The exported policy.
def export_policy(params, action_space: str) -> NumpyPolicy:
    """The NumPy form of Brax PPO's `(normalizer, policy, value)` parameters.

    Args:
      params: The parameters Brax's `ppo.train` returns (or hands to `policy_params_fn`).
      action_space: "joints" or "cpg".

    Returns:
      The policy, with the head its parameters imply (`HEADS`).
    """
    normalizer, policy = params[0], params[1]
    tree = policy["params"]
    arrays = {"mean": np.asarray(normalizer.mean), "std": np.asarray(normalizer.std)}
    if "MLP_0" in tree:  # "normal": hidden layers, the mean's Dense_0, a log-std apart
        dense = [tree["MLP_0"][f"hidden_{i}"] for i in range(len(tree["MLP_0"]))]
        dense.append(tree["Dense_0"])
        arrays["head"] = np.array("normal")
    else:  # "tanh_normal": one MLP whose last layer gives mean and std
        dense = [tree[f"hidden_{i}"] for i in range(len(tree))]
        arrays["head"] = np.array("tanh_normal")
    for i, layer in enumerate(dense):
        arrays[f"kernel_{i}"] = np.asarray(layer["kernel"])
        arrays[f"bias_{i}"] = np.asarray(layer["bias"])
    return NumpyPolicy(arrays, action_space)


def validate(policy: NumpyPolicy, settings: PPOMJXSettings) -> tuple[float, float, int]:
    """The policy on the CPU task, first `validation_seeds` validation seeds of the tier.

    Returns:
      (success-weighted distance, m; fall rate; physics steps of the trials).
    """
    trials = [
        score.policy_trial(
            policy, settings.task, seed, settings.trial_steps, {"supply": settings.supply()}
        )
        for seed in protocol.validation_seeds(settings.validation_seeds)
    ]
    fell = np.array([t["fell"] for t in trials])
    distance = np.where(fell, 0.0, [t["distance_m"] for t in trials])
    return float(distance.mean()), float(fell.mean()), sum(t["sim_steps"] for t in trials)


# Training.
def brax_train_kwargs(settings: PPOMJXSettings) -> dict:
    """Brax `ppo.train`'s keyword arguments for the settings (without env and callbacks)."""
    import jax
    from brax.training.agents.ppo import networks as ppo_networks

    from cpg_suite.mjx import training

    head = {}
    if settings.policy_head == "normal":
        head = dict(
            distribution_type="normal",
            noise_std_type="log",
            init_noise_std=settings.init_noise_std,
            mean_kernel_init_fn=jax.nn.initializers.orthogonal,
            mean_kernel_init_kwargs={"scale": settings.mean_init_scale},
        )

    return dict(
        num_timesteps=settings.total_steps,
        num_evals=settings.num_evals,
        run_evals=False,  # selection runs on the CPU reference
        episode_length=settings.trial_steps,
        num_envs=settings.num_envs,
        unroll_length=settings.unroll_length,
        batch_size=settings.batch_size,
        num_minibatches=settings.num_minibatches,
        num_updates_per_batch=settings.num_updates_per_batch,
        learning_rate=settings.learning_rate,
        entropy_cost=settings.entropy_cost,
        discounting=settings.discounting,
        gae_lambda=settings.gae_lambda,
        clipping_epsilon=settings.clipping_epsilon,
        reward_scaling=settings.reward_scaling,
        max_grad_norm=settings.max_grad_norm,
        normalize_observations=True,
        seed=settings.seed,
        wrap_env_fn=training.wrap_for_training,
        network_factory=functools.partial(
            ppo_networks.make_ppo_networks,
            policy_hidden_layer_sizes=settings.policy_layers,
            value_hidden_layer_sizes=settings.value_layers,
            **head,
        ),
    )


@dataclasses.dataclass
class _Run:
    """What the callbacks of one training call update."""

    run_dir: str
    settings: PPOMJXSettings
    log: Callable[[str], None]
    start_steps: int  # env steps done before this training call (resume)
    best: dict | None
    rows: list
    validation_sim_steps: int = 0
    clock: float = dataclasses.field(default_factory=time.perf_counter)
    train_wall_s: float = 0.0
    device: str = ""  # the JAX device(s) that trained, e.g. "gpu (NVIDIA H100 80GB HBM3)"
    environment: dict = dataclasses.field(default_factory=dict)  # of the first training call
    resumed: bool = False  # Brax's first call then hands back the checkpoint's parameters

    def on_params(self, current_step: int, make_policy, params) -> None:
        """Brax's `policy_params_fn`: validate on the CPU, keep the best, checkpoint."""
        del make_policy
        self.train_wall_s += time.perf_counter() - self.clock
        if self.resumed and int(current_step) == 0:  # validated before the run stopped
            self.clock = time.perf_counter()
            return
        steps = self.start_steps + int(current_step)
        row = self._validate(steps, export_policy(params, self.settings.action_space))
        self.rows.append(row)
        self._checkpoint(steps, params)
        self.log(
            f"{steps:>12,} env steps  validation {row['validation_m']:+.3f} m, falls "
            f"{row['validation_fall_rate']:.0%}  (best {self.best['validation_m']:+.3f} m)  "
            f"train {self.train_wall_s:.0f} s"
        )
        self.clock = time.perf_counter()

    def _validate(self, steps: int, policy: NumpyPolicy) -> dict:
        """Validates the policy, keeps it if it is the best so far; its progress row."""
        validation_m, fall_rate, sim_steps = validate(policy, self.settings)
        self.validation_sim_steps += sim_steps
        if self.best is None or validation_m > self.best["validation_m"]:
            self.best = {
                "env_steps": steps,
                "validation_m": validation_m,
                "fall_rate": fall_rate,
                "policy": policy.arrays(),
            }
        return {
            "env_steps": steps,
            "validation_m": validation_m,
            "validation_fall_rate": fall_rate,
            "best_validation_m": self.best["validation_m"],
            "train_wall_s": round(self.train_wall_s, 3),
            "steps_per_s": round(steps / self.train_wall_s, 1) if self.train_wall_s else 0.0,
        }

    def _checkpoint(self, steps: int, params) -> None:
        """checkpoint.pkl (last parameters, best policy, rows), then the files it implies."""
        checkpoint = {
            "settings": dataclasses.asdict(self.settings),
            "env_steps": steps,
            "params": _to_numpy(params),
            "best": self.best,
            "rows": self.rows,
            "validation_sim_steps": self.validation_sim_steps,
            "train_wall_s": self.train_wall_s,
            "device": self.device,
            "environment": self.environment,
        }
        runs.write_bytes(os.path.join(self.run_dir, "checkpoint.pkl"), pickle.dumps(checkpoint))
        write_run_files(self.run_dir, self.settings, self.best, self.rows)


def write_run_files(run_dir: str, settings: PPOMJXSettings, best: dict, rows: list) -> None:
    """selected_policy.npz and progress.csv as a checkpoint holds them (atomic writes)."""
    NumpyPolicy(best["policy"], settings.action_space).save(os.path.join(run_dir, POLICY_FILE))
    runs.write_rows_csv(os.path.join(run_dir, "progress.csv"), rows)


def _to_numpy(tree):
    import jax

    return jax.tree.map(np.asarray, tree)


LEARNER_PACKAGES = ("jax", "jaxlib", "mujoco-mjx", "brax", "flax", "optax")  # what trains


def training_environment() -> dict:
    """`runs.environment_record()` with the versions of the JAX packages that train."""
    from importlib import metadata

    record = runs.environment_record()
    for name in LEARNER_PACKAGES:
        try:
            record[f"{name.replace('-', '_')}_version"] = metadata.version(name)
        except metadata.PackageNotFoundError:
            record[f"{name.replace('-', '_')}_version"] = None
    return record


def device_name() -> str:
    """The JAX device that trains (e.g. "gpu (NVIDIA H100 80GB HBM3)", or "cpu")."""
    import jax

    device = jax.devices()[0]
    kind = getattr(device, "device_kind", device.platform)
    return kind if kind == device.platform else f"{device.platform} ({kind})"


def _platform(device: str) -> str:
    """The platform of a `device_name` record ("gpu", "cpu"); the last one if it names several."""
    return device.split(" + ")[-1].split(" ")[0]


def train(
    settings: PPOMJXSettings, run_dir: str, log: Callable[[str], None], state: dict | None
) -> _Run:
    """Trains with Brax's PPO, validating and checkpointing on the CPU as it goes.

    Args:
      settings: The run's settings.
      run_dir: The run directory.
      log: Receives a line per validation.
      state: The checkpoint to resume from (`resume_state`), or None to start afresh.

    Returns:
      The run's `_Run` record (best policy, progress rows, validation and wall time).
    """
    from brax.training.agents.ppo import train as brax_ppo

    from cpg_suite.mjx import training

    record = _Run(
        run_dir=run_dir,
        settings=settings,
        log=log,
        start_steps=state["env_steps"] if state else 0,
        best=state["best"] if state else None,
        rows=state["rows"] if state else [],
        validation_sim_steps=state["validation_sim_steps"] if state else 0,
        train_wall_s=state["train_wall_s"] if state else 0.0,
        device=state.get("device", "") if state else "",
        environment=state.get("environment", {}) if state else training_environment(),
        resumed=state is not None,
    )
    if state:  # the files may lag the checkpoint if the run stopped between the writes
        write_run_files(run_dir, settings, state["best"], state["rows"])
    remaining = settings.total_steps - record.start_steps
    if remaining <= 0:  # trained (perhaps on another machine): only the scoring is left
        return record
    if device_name() not in record.device.split(" + "):
        record.device = " + ".join(filter(None, [record.device, device_name()]))
    kwargs = brax_train_kwargs(settings)
    if state:  # a fresh stream of draws for the remaining steps
        kwargs.update(
            num_timesteps=remaining,
            num_evals=math.ceil(remaining / settings.validation_every) + 1,
            seed=settings.seed + 1_000_003 * (len(state["rows"])),
            restore_params=state["params"],
        )
    env = make_env(settings)
    record.clock = time.perf_counter()
    with training.brax_on_this_jax():
        brax_ppo.train(env, policy_params_fn=record.on_params, **kwargs)
    return record


def make_env(settings: PPOMJXSettings):
    """The Brax env PPO trains on: the training tier on MJX with the settings' physics.

    Returns:
      A `cpg_suite.mjx.training.BraxWalkEnv`.
    """
    from cpg_suite.mjx import training

    walk_env = mjx_walk.WalkEnv(
        settings.task,
        settings.action_space,
        physics="training",
        impl=settings.impl,
        solver_iterations=settings.solver_iterations or _model_solver(),
        contacts=settings.contacts,
        max_robots=settings.num_envs,
        supply=settings.supply(),
    )
    return training.BraxWalkEnv(walk_env)


def _model_solver() -> tuple[int, int]:
    """The DARwIn-OP model's own solver iterations and line-search iterations (100, 50)."""
    opt = mujoco.MjModel.from_xml_string(*darwin.get_model_and_assets()).opt
    return int(opt.iterations), int(opt.ls_iterations)


def resume_state(run_dir: str, settings: PPOMJXSettings) -> dict | None:
    """The run's checkpoint, if it may be resumed with these settings.

    Args:
      run_dir: The run directory.
      settings: The settings of the resumed run (only the test_* ones may differ).

    Returns:
      The checkpoint's contents, or None if the run has none.

    Raises:
      cli.UsageError: The checkpoint was written by other training settings, or it has
        training left and was trained on another kind of device (a GPU run scored on a CPU
        machine must have reached `total_steps`; it would otherwise go on training there).
    """
    path = os.path.join(run_dir, "checkpoint.pkl")
    if not os.path.exists(path):
        return None
    with open(path, "rb") as f:
        state = pickle.load(f)
    saved = {**dataclasses.asdict(PPOMJXSettings()), **BEFORE_ADDED, **state["settings"]}
    if _training_settings(saved) != _training_settings(dataclasses.asdict(settings)):
        raise cli.UsageError(f"{path} was written by other settings; pass --overwrite")
    left = settings.total_steps - state["env_steps"]
    trained_on = _platform(state.get("device", ""))
    if left > 0 and trained_on and trained_on != _platform(device_name()):
        raise cli.UsageError(
            f"{path} was trained on {trained_on} and has {left:,} env steps left: resume it "
            f"on a {trained_on}, or pass --overwrite"
        )
    return state


def _training_settings(settings: dict) -> dict:
    """The settings that shape training: all but the final score card's (test_*)."""
    return {k: v for k, v in settings.items() if not k.startswith("test_")}


def run(
    settings: PPOMJXSettings,
    options: runs.RunOptions | None = None,
    log: Callable[[str], None] = progress.write,
) -> tuple[str, dict]:
    """Trains on MJX, selects on the CPU task and scores on the CPU test protocol.

    Args:
      settings: The run's settings.
      options: Output directory, run name (default `default_run_name(settings)`), resume,
        overwrite (threads and backend unused).
      log: Receives a line per validation.

    Returns:
      `(run_dir, summary)`; the summary holds the test score card unless `test_seeds` = 0.

    Raises:
      runs.RunDirectoryExists: The run directory holds a run and neither resume nor
        overwrite was asked.
    """
    options = options or runs.RunOptions()
    run_dir = runs.run_directory(
        options.output_dir,
        METHOD,
        settings.task,
        options.run_name or default_run_name(settings),
        overwrite=options.overwrite,
        resume=options.resume,
    )
    state = resume_state(run_dir, settings) if options.resume else None
    runs.write_config(
        run_dir,
        settings,
        runs.command_line("baselines.ppo_mjx", dataclasses.asdict(settings)),
        # where it was trained, when this call only scores or goes on training
        extra={"training_environment": state.get("environment", {})} if state else None,
    )
    record = train(settings, run_dir, log, state)
    summary = _summary(settings, record)
    if settings.test_seeds:
        policy = NumpyPolicy.load(os.path.join(run_dir, POLICY_FILE))
        card, trials = score.score_policy_trials(
            policy,
            score.ScoreSettings(
                tiers=settings.test_tiers, seeds=settings.test_seeds, steps=settings.trial_steps
            ),
        )
        log(score.format_card(card))
        summary["test"] = score.stored_card(card)
        runs.write_rows_csv(os.path.join(run_dir, "test_trials.csv"), trials)
    runs.write_json(os.path.join(run_dir, "summary.json"), summary)
    return run_dir, summary


def _summary(settings: PPOMJXSettings, record: _Run) -> dict:
    best, last = record.best, record.rows[-1]
    return {
        "action_space": settings.action_space,
        "env_steps": last["env_steps"],
        "sim_steps": last["env_steps"] * darwin.physics_steps_per_control_step(),
        "validation_sim_steps": record.validation_sim_steps,
        "train_wall_s": record.train_wall_s,
        "device": record.device or "unknown",
        "selected": {
            "source": f"env_steps_{best['env_steps']}",
            "env_steps": best["env_steps"],
            "validation_success_weighted_m": best["validation_m"],
            "validation_fall_rate": best["fall_rate"],
            "validation_seeds": settings.validation_seeds,
        },
    }


def summary_line(run_dir: str, summary: dict) -> str:
    """One line describing a finished run."""
    line = (
        f"{run_dir}: {summary['env_steps']:,} env steps in {summary['train_wall_s']:.0f} s on "
        f"{summary['device']}, selected at {summary['selected']['env_steps']:,} (validation "
        f"{summary['selected']['validation_success_weighted_m']:+.3f} m)"
    )
    if "test" in summary:
        line += "; test score " + score.score_text(summary["test"]["all"])
    return line


# Command line.
def define_flags() -> None:
    """Defines this module's command-line flags (only when it runs as a program)."""
    d = PPOMJXSettings()
    flags.DEFINE_string("task", d.task, f"Training tier: {', '.join(TASKS)}.")
    flags.DEFINE_string("action_space", d.action_space, f"One of {', '.join(ACTION_SPACES)}.")
    flags.DEFINE_integer("total_steps", d.total_steps, "Training env steps.")
    flags.DEFINE_integer("num_envs", d.num_envs, "Environments stepped together.")
    flags.DEFINE_integer("seed", d.seed, "Seed of the networks, sampling and episode draws.")
    flags.DEFINE_integer("trial_steps", d.trial_steps, "Control steps per episode (1000 = 16 s).")
    flags.DEFINE_integer(
        "validation_every", d.validation_every, "Env steps between CPU validations."
    )
    flags.DEFINE_integer("validation_seeds", d.validation_seeds, "Validation seeds.")
    flags.DEFINE_integer("test_seeds", d.test_seeds, "Test seeds per tier (0: no score card).")
    flags.DEFINE_list("test_tiers", list(d.test_tiers), "Tiers of the final score card.")
    for name in ("unroll_length", "batch_size", "num_minibatches", "num_updates_per_batch"):
        flags.DEFINE_integer(name, getattr(d, name), f"Brax PPO: {name}.")
    for name in (
        "learning_rate",
        "entropy_cost",
        "discounting",
        "gae_lambda",
        "clipping_epsilon",
        "reward_scaling",
        "max_grad_norm",
    ):
        flags.DEFINE_float(name, getattr(d, name), f"Brax PPO: {name}.")
    flags.DEFINE_string("policy_head", d.policy_head, f"One of {', '.join(HEADS)}.")
    flags.DEFINE_float("init_noise_std", d.init_noise_std, "normal head: initial std.")
    flags.DEFINE_float("mean_init_scale", d.mean_init_scale, "normal head: mean layer's gain.")
    flags.DEFINE_list("policy_layers", [str(v) for v in d.policy_layers], "Policy hidden layers.")
    flags.DEFINE_list("value_layers", [str(v) for v in d.value_layers], "Value hidden layers.")
    flags.DEFINE_list(
        "solver_iterations",
        [str(v) for v in d.solver_iterations],
        "I,L: MJX solver caps in training; empty (--solver_iterations=): the model's own.",
    )
    flags.DEFINE_string(
        "contacts", d.contacts, f"MJX contact pairs in training: {', '.join(mjx_walk.CONTACTS)}."
    )
    flags.DEFINE_string("impl", d.impl, f"MJX backend: {', '.join(mjx_walk.IMPLS)}.")
    flags.DEFINE_integer(
        "benchmark_version", d.benchmark_version, "Benchmark version (supply limit) trained under."
    )
    o = runs.RunOptions()
    flags.DEFINE_string("output_dir", o.output_dir, "Root of the output tree.")
    flags.DEFINE_string("run_name", o.run_name, "Run directory name (default from settings).")
    flags.DEFINE_bool("resume", o.resume, "Continue the run from its checkpoint.")
    flags.DEFINE_bool("overwrite", o.overwrite, "Replace an existing run directory.")


def main(argv: list[str]) -> None:
    """Trains on MJX and scores on the CPU as the flags say; prints a summary line."""
    del argv
    settings = cli.settings_from_flags(PPOMJXSettings)
    options = cli.settings_from_flags(runs.RunOptions)
    try:
        run_dir, summary = run(settings, options)
    except runs.RunDirectoryExists as e:
        raise cli.UsageError(f"{e} (or --resume to continue it)") from None
    progress.write(summary_line(run_dir, summary))


if __name__ == "__main__":
    define_flags()
    cli.run(main, output_dirs=("output_dir",))

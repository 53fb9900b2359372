"""How a PPO `joints` policy's episodes end under the supply limit: falls or brown-outs.

    python investigations/probe_policy.py [POLICY_DIR ...]

For each folder (default: `joints_seed0_final` here), its final policy walks 8 robots of
`darwin_walk` (seeds 100-107, neither validation nor test seeds) for up to 16 s under
benchmark version 2, once with the mean action (as validation and test score it) and, for
Stable-Baselines3, once with actions sampled from the policy (as in training). The policy
is Stable-Baselines3's (`final_model.zip`, `final_vecnormalize.pkl`; the run's settings
from its `config.json`, or for `<name>_final` from the shipped run
`results/protocol/runs/ppo/darwin_walk/<name>`) or, for PPO on MJX, the last parameters of
its checkpoint exported as the shipped policies are (`final_policy.npz`,
`baselines.ppo_mjx.export_policy`: the mean action only, the log-std is not exported).
Printed per robot: the control step its episode ended, why (fall, brownout or time limit),
the distance walked and the worst 1 s mean supply current; and, for the mean actions, the
episode's discounted return at γ = 0.99 (the PPO default) and 0.999 beside the speed a
steady gait walking the whole 16 s trial needs to earn as much,
v = G (1 − γ) / (Δt (1 − γ^1000)).
"""

from __future__ import annotations

import json
import os
import sys
import types

import numpy as np
from gymnasium.vector import AutoresetMode
from stable_baselines3 import PPO

from cpg_suite import darwin, protocol, vector
from cpg_suite.harness import sb3
from cpg_suite.runfiles import exported, sb3_policy

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))  # the repository
HERE = os.path.join(ROOT, "results", "protocol", "ppo_joints_under_limit")  # its data
SHIPPED = os.path.join(ROOT, "results", "protocol", "runs", "ppo", "darwin_walk")
MJX_POLICY = "final_policy.npz"  # PPO on MJX's last parameters (`export_policy`)
SEEDS = range(100, 108)  # a choice: seeds that neither validation nor the test uses
GAMMAS = (0.99, 0.999)
STEPS = 1000  # control steps: 16 s


def probe(run_dir: str, deterministic: bool) -> list[tuple]:
    """(end step, cause, distance m, worst 1 s window A, discounted returns at `GAMMAS`)
    for each robot."""
    env = vector.DarwinVectorEnv(
        "darwin_walk",
        len(SEEDS),
        threads=1,
        autoreset_mode=AutoresetMode.NEXT_STEP,
        time_limit=STEPS * darwin.CONTROL_TIMESTEP,
        supply=protocol.supply_limit(2),
    )
    act = _policy(run_dir, deterministic, env.single_observation_space)
    observations, _ = env.reset(seed=list(SEEDS))
    ended: dict[int, tuple] = {}
    distance = np.zeros(len(SEEDS))
    discounted = np.zeros((len(GAMMAS), len(SEEDS)))
    for step in range(1, STEPS + 1):
        observations, rewards, terminated, truncated, infos = env.step(act(observations))
        running = np.array([i not in ended for i in range(len(SEEDS))])
        distance += np.where(running, rewards, 0.0)
        for g, gamma in enumerate(GAMMAS):
            discounted[g] += np.where(running, gamma ** (step - 1) * rewards, 0.0)
        brownout = infos.get("brownout", np.zeros(len(SEEDS), bool))
        for i in np.flatnonzero((terminated | truncated) & running):
            cause = "time limit" if truncated[i] else "brownout" if brownout[i] else "fall"
            worst = env.envs[i].task.supply.worst
            ended[int(i)] = (step, cause, float(distance[i]), worst, tuple(discounted[:, i]))
        if len(ended) == len(SEEDS):
            break
    env.close()
    return [ended[i] for i in range(len(SEEDS))]


def _policy(run_dir: str, deterministic: bool, space):
    """The folder's final policy as a function of the robots' observations to their actions
    in [−1, 1]: PPO on MJX's exported one (mean actions), or Stable-Baselines3's."""
    if _exported(run_dir):
        if not deterministic:
            raise ValueError("an exported PPO-on-MJX policy gives its mean action only")
        policy = exported.NumpyPolicy.load(os.path.join(run_dir, MJX_POLICY))
        policy.reset_batch(len(SEEDS))
        return policy.act_batch
    with open(_config_path(run_dir), encoding="utf-8") as f:
        settings = json.load(f)["settings"]
    policy = sb3_policy.TrainedPolicy.load(
        run_dir, PPO, types.SimpleNamespace(**settings), which="final"
    )
    keys = sb3.observation_keys(space)

    def act(observations):
        flat = policy.normalizer.normalize_obs(sb3.flatten(observations, keys))
        actions, _ = policy.model.predict(flat, deterministic=deterministic)
        return np.clip(actions, -1, 1)

    return act


def _exported(run_dir: str) -> bool:
    """Whether the folder holds an exported PPO-on-MJX policy (else Stable-Baselines3's)."""
    return os.path.exists(os.path.join(run_dir, MJX_POLICY))


def _config_path(policy_dir: str) -> str:
    """The run's config.json: the folder's own, or the shipped run's of a `<name>_final`."""
    own = os.path.join(policy_dir, "config.json")
    if os.path.exists(own):
        return own
    name = os.path.basename(os.path.normpath(policy_dir)).removesuffix("_final")
    return os.path.join(SHIPPED, name, "config.json")


def steady_speed(discounted_return: float, gamma: float) -> float:
    """The speed, m/s, of a gait walking the whole trial whose return at `gamma` is this."""
    per_metre_per_s = darwin.CONTROL_TIMESTEP * (1 - gamma**STEPS) / (1 - gamma)
    return discounted_return / per_metre_per_s


def main(run_dirs: list[str]) -> None:
    for run_dir in run_dirs:
        for deterministic in (True,) if _exported(run_dir) else (True, False):
            kind = "mean" if deterministic else "sampled"
            print(f"{os.path.relpath(run_dir, HERE)}, {kind} actions:")
            for seed, (step, cause, metres, worst, returns) in zip(
                SEEDS, probe(run_dir, deterministic)
            ):
                line = (
                    f"  seed {seed}: ended at step {step:4d} ({cause}), {metres:6.3f} m, "
                    f"worst 1 s {worst:5.2f} A"
                )
                if deterministic:
                    line += "".join(
                        f"; γ {gamma}: G {g:.3f} m = a gait at {steady_speed(g, gamma):.3f} m/s"
                        for gamma, g in zip(GAMMAS, returns)
                    )
                print(line)


if __name__ == "__main__":
    main(sys.argv[1:] or [os.path.join(HERE, "joints_seed0_final")])

r"""The study's computed evidence: what the claims need beyond the runs' own files.

  python -m baselines.experiments.study_evidence                 # -> results/study/computed.json
  python -m baselines.experiments.study_evidence --out=FILE --study=DIR

`analysis.study` reads run files only (docs/architecture.md); the measurements its rules
need that no run wrote come from here, one JSON file, in about a minute:

  * the Tokic model (thesis Table 4.1, Sec. 4.1.7, Appendix): value and policy iteration
    to convergence and step by step, the γ sweep, and its greedy policy run on our crawler;
  * the 2-D toy of Sec. 6.1: CEM's final error by noise and elite over 10 seeds;
  * the CPG's targets (no physics): the legs' phase shift, periodicity, what raising one
    amplitude does, how far the learned K = 50 gaits move each joint;
  * 1000-step training trials (version-1 physics) of the hand-tuned gait (5 initial-state
    seeds) and around the study's learned K 10 / noise 0.8 / elite 2 gaits: 20 draws
    N(θ*, I deg²) each, and θ* with one amplitude reset to its hand-tuned value.

The learned gaits are read from the CEM study's runs (`baselines.experiments.cem_study`),
so this runs after them; it trains nothing.
"""

from __future__ import annotations

if __name__ == "__main__":  # this program never renders: no OpenGL backend, no GLFW warning
    from cpg_suite import cli

    cli.without_rendering()

import dataclasses
import json
import os

import numpy as np
from absl import flags

import cpg_suite
from baselines import cem
from baselines.tabular import models, planning
from baselines.tabular.exploration import argmax_ties
from cpg_suite import cli, cpg, crawler, darwin, protocol, trajectories
from cpg_suite.evaluation import gait
from cpg_suite.runfiles import runs

GAMMAS = tuple(float(g) for g in np.round(np.arange(0.50, 0.96, 0.005), 3))
PI_SEEDS = 5  # random initial policies of policy iteration
CONVERGED = 0.01  # a cycle-state value within 1 % of its converged value
TOY_ROUNDS = 100  # the thesis gives none
TOY_SEEDS = 10
TOY_NOISES = (0.0, 0.2, 0.8, 2.0)
TOY_ELITES = (2, 5)
HAND_SEEDS = 5  # initial-state seeds of the hand-tuned gait's trials
PERTURBATIONS = 20  # draws N(θ*, I deg²) per learned gait
PER_CYCLE = 200  # CPG samples a cycle: a half cycle is a whole number of them
LEARNED = "K10_n0.8_e2"  # the Table 6.1 setting whose learned gaits are perturbed
ALG41_SEEDS = 5  # tie-breaking seeds of the Alg. 4.1 walks (seed 0: the model's fixed order)
ALG41_MOVES = 1000  # the thesis gives no run length
ALG41_WITHIN = 20  # moves: "soon" (the criteria of CR-1a and CR-3)
LEFT_LEG = ("hip yaw", "hip roll", "hip pitch", "knee", "ankle pitch", "ankle roll")


# --- the Tokic model ----------------------------------------------------------------------


def _converge_at(history: list[np.ndarray], states: list[int], final: np.ndarray) -> int:
    """The first iteration after which the cycle states' values stay within 1 % of final."""
    close = [bool(np.all(np.abs(h[states] - final) <= CONVERGED * np.abs(final))) for h in history]
    for k in range(len(close)):
        if all(close[k:]):
            return k
    return len(history)


def _last_change(model: models.TabularModel, history: list[np.ndarray], gamma: float) -> int:
    policies = [planning.greedy_policy(model, h, gamma) for h in history]
    changed = [
        k for k in range(1, len(policies)) if not np.array_equal(policies[k], policies[k - 1])
    ]
    return changed[-1] if changed else 0


def alg41_walk(
    model: models.TabularModel,
    history: list[np.ndarray],
    gamma: float,
    start: int,
    rng: np.random.RandomState | None,
) -> list[int]:
    """Thesis Alg. 4.1 on the complete model from V = 0: a greedy move, then one in-place
    sweep of every state, `len(history) - 1` times. The sweeps do not depend on the path
    (the model is complete), so V before move k is value iteration's V after k sweeps
    (`history[k]`).

    Args:
      model: The Tokic model.
      history: V after 0, 1, ... sweeps (`planning.value_iteration(..., sweeps=n).history`).
      gamma: The discount.
      start: The starting cell.
      rng: Breaks ties among exact maximisers at random; None: the model's fixed order.

    Returns:
      The cells visited, `start` first.
    """
    return _alg41_moves(model, history, gamma, start, rng)[0]


def _alg41_moves(
    model: models.TabularModel,
    history: list[np.ndarray],
    gamma: float,
    start: int,
    rng: np.random.RandomState | None,
) -> tuple[list[int], list[int]]:
    """`alg41_walk`'s cells and the actions taken between them."""
    path, actions = [start], []
    for values in history[:-1]:
        q = planning.action_values(model, values, gamma)[path[-1]]
        a = argmax_ties(q, rng, None if rng is not None else model.tie_order)
        actions.append(int(a))
        path.append(model.intended_successor(path[-1], a))
    return path, actions


def alg41_cycle_rewards(model: models.TabularModel, gamma: float) -> list[float]:
    """CR-4a's measure: per tie-breaking seed (`tokic_alg41`'s), the reward of one period
    of the cycle an Alg. 4.1 walk of `ALG41_MOVES` moves from (0, 0) ends in (> 0: it
    walks forward)."""
    history = planning.value_iteration(model, gamma, sweeps=ALG41_MOVES).history
    found = []
    for seed in range(ALG41_SEEDS):
        rng = None if seed == 0 else np.random.RandomState(seed)
        path, actions = _alg41_moves(model, history, gamma, model.start_state, rng)
        last = len(path) - 1
        period = next(k for k in range(1, last + 1) if path[last - k] == path[last])
        found.append(
            sum(
                float(model.rewards[path[i], actions[i], path[i + 1]])
                for i in range(last - period, last)
            )
        )
    return found


def final_cycle(path: list[int]) -> tuple[frozenset[int], int]:
    """The cycle a walk repeats at its end, and the move at which it entered it for good.

    Returns:
      `(cells, entry)`: the cycle's cells, and the first move k from which the walk repeats
      with the cycle's period to its end.
    """
    last = len(path) - 1
    period = next(k for k in range(1, last + 1) if path[last - k] == path[last])
    entry = last - period
    while entry > 0 and path[entry - 1] == path[entry - 1 + period]:
        entry -= 1
    return frozenset(path[entry : entry + period]), entry


def tokic_alg41(gamma: float = 0.9) -> list[dict]:
    """CR-1a's and CR-3's measure: per tie-breaking seed, Alg. 4.1 from V = 0 for
    `ALG41_MOVES` moves from (0, 0) and from every cell (a fresh `RandomState(seed)` each;
    seed 0: the model's fixed order).

    Returns:
      Per seed: the cycle from (0, 0) (cells), the move it was entered, its length, how many
      of the 25 starts end in that cycle entered within `ALG41_WITHIN` moves, and the
      latest entry of any start.
    """
    model = models.tokic_model()
    history = planning.value_iteration(model, gamma, sweeps=ALG41_MOVES).history
    found = []
    for seed in range(ALG41_SEEDS):

        def walk(start: int, seed: int = seed) -> tuple[frozenset[int], int]:
            rng = None if seed == 0 else np.random.RandomState(seed)
            return final_cycle(alg41_walk(model, history, gamma, start, rng))

        cycle, entry = walk(model.start_state)
        ends = [walk(s) for s in range(model.n_states)]
        found.append(
            {
                "seed": seed,
                "cycle": [list(model.label(s)) for s in sorted(cycle)],
                "entry": entry,
                "starts_in_cycle_within": sum(c == cycle and k <= ALG41_WITHIN for c, k in ends),
                "latest_entry": max(k for _, k in ends),
            }
        )
    return found


def _differing(rewards: dict) -> int:
    """How many cells are entered with differing rewards (from different neighbours)."""
    incoming: dict = {}
    for (_, dst), r in rewards.items():
        incoming.setdefault(dst, set()).add(r)
    return sum(len(r) > 1 for r in incoming.values())


def tokic() -> dict:
    """Value and policy iteration on the Tokic model: what claims CR-1 to CR-5, CR-18 to
    CR-20 and PB-2b measure."""
    model = models.tokic_model()
    vi = planning.value_iteration(model, 0.9)
    cycle = planning.policy_cycle(model, vi.policy)
    starts = [planning.policy_cycle(model, vi.policy, s) for s in range(model.n_states)]
    by_gamma = {}
    for g in GAMMAS:
        result = planning.value_iteration(model, g)
        c = planning.policy_cycle(model, result.policy)
        by_gamma[f"{g:g}"] = {
            "cycle_reward": c.reward,
            "cycle_length": c.length,
            "last_policy_change": _last_change(model, result.history, g),
            "sweeps_to_1e-6": planning.value_iteration(model, g, tol=1e-6).iterations,
            "alg41_cycle_rewards": alg41_cycle_rewards(model, g),
        }
    pi_iterations, pi_one_sweep, pi_same = [], [], []
    final = vi.values[cycle.states]
    for s in range(PI_SEEDS):
        pi = planning.policy_iteration(model, 0.9, np.random.RandomState(s), iterations=30)
        pi_iterations.append(_converge_at(pi.history, cycle.states, final))
        one = planning.policy_iteration(
            model, 0.9, np.random.RandomState(s), eval_sweeps=1, iterations=200
        )
        pi_one_sweep.append(_converge_at(one.history, cycle.states, final))
        full = planning.policy_iteration(model, 0.9, np.random.RandomState(s))
        pi_same.append(set(planning.policy_cycle(model, full.policy).states) == set(cycle.states))
    two = planning.value_iteration(model, 0.9, sweeps=2).history
    first = model.intended_successor(
        model.start_state, int(planning.greedy_policy(model, two[0], 0.9)[model.start_state])
    )
    second = model.intended_successor(first, int(planning.greedy_policy(model, two[1], 0.9)[first]))
    at_10 = models.grid_index(1, 0)
    q = planning.action_values(model, two[1], 0.9)[at_10]
    return {
        "converged": bool(vi.converged),
        "cycle": [list(model.label(s)) for s in cycle.states],
        "cycle_reward": cycle.reward,
        "transient": len(cycle.transient),
        "starts_in_cycle_within_20": sum(
            set(c.states) == set(cycle.states) and len(c.transient) <= 20 for c in starts
        ),
        "by_gamma": by_gamma,
        "vi_iterations_to_1pct": _converge_at(
            planning.value_iteration(model, 0.9, sweeps=200).history,
            cycle.states,
            vi.values[cycle.states],
        ),
        "pi_iterations_to_1pct": pi_iterations,
        "pi_one_sweep_iterations_to_1pct": pi_one_sweep,
        "pi_same_cycle": pi_same,
        "sweep1": two[1].reshape(5, 5).tolist(),
        "sweep2": two[2].reshape(5, 5).tolist(),
        "first_moves": [list(model.label(s)) for s in (model.start_state, first, second)],
        "action_values_at_1_0_sweep2": sorted(
            float(q[a]) for a in range(model.n_actions) if model.allowed[at_10, a]
        ),
        "cells_with_differing_incoming_rewards": _differing(models.load_tokic_rewards()),
        "cells_with_differing_pinned_incoming_rewards": _differing(
            models.load_tokic_rewards("pinned")
        ),
        "reward_2_2_to_3_2": models.load_tokic_rewards()[((2, 2), (3, 2))],
    }


def tokic_on_crawler(seeds: int = 5, moves: int = 100) -> dict:
    """The Tokic table's greedy policy (γ 0.9) run on our MuJoCo crawler from its reset,
    `moves` moves, no learning: its displacement per seed (the crawler's seed sets its
    initial state) and its cycle's length (claims CR-11c, CR-11d)."""
    model = models.tokic_model()
    policy = planning.value_iteration(model, 0.9).policy
    displacement = []
    for seed in range(seeds):
        env = cpg_suite.load(
            "crawler_walk", task_kwargs={"random": seed, "time_limit": float("inf")}
        )
        ts = env.reset()
        total = 0.0
        for _ in range(moves):
            row, col = (int(x) for x in ts.observation["grid_cell"])
            ts = env.step(int(policy[crawler.cell_index(row, col)]))
            total += float(ts.reward)
        displacement.append(total)
    cycle = planning.policy_cycle(model, policy)
    return {"moves": moves, "displacement_m": displacement, "cycle_length": cycle.length}


# --- the toy of Sec. 6.1 ------------------------------------------------------------------


def toy_run(noise: float, elite: int, seed: int) -> tuple[float, float]:
    """(final error: the mean's distance to 0 averaged over the last 10 rounds, trace Σ) of
    CEM on N([8, 8], 9 I), K = 10, cost = distance to the origin."""
    opt = cem.CEM(np.array([8.0, 8.0]), 10, elite, noise, seed, covariance=9.0 * np.eye(2))
    errors = []
    for _ in range(TOY_ROUNDS):
        samples = opt.ask()
        opt.tell(samples, np.linalg.norm(samples, axis=1))
        errors.append(float(np.linalg.norm(opt.mean)))
    return float(np.mean(errors[-10:])), float(np.trace(opt.cov))


def toy() -> dict:
    """Final errors and trace Σ per noise and elite, seeds 0..TOY_SEEDS-1."""
    out = {"start_cost": float(np.linalg.norm([8.0, 8.0]))}
    for noise in TOY_NOISES:
        for elite in TOY_ELITES:
            done = [toy_run(noise, elite, s) for s in range(TOY_SEEDS)]
            out[f"noise{noise:g}_elite{elite}"] = {
                "final_error": [e for e, _ in done],
                "trace": [t for _, t in done],
            }
    return out


# --- the CPG's targets ----------------------------------------------------------------------


def targets(amplitudes, cycles: int = 6) -> np.ndarray:
    """The CPG's joint targets (rad, 12 joints), `PER_CYCLE` samples a cycle."""
    dt = 2 * np.pi / cpg.CPGConfig().omega / PER_CYCLE
    return cpg.trajectories(np.asarray(amplitudes, dtype=np.float64), PER_CYCLE * cycles, dt)[0]


def cpg_targets(learned_k10: list[np.ndarray], learned_k50: list[np.ndarray]) -> dict:
    """The legs' phase shift, periodicity, each amplitude's effect on the joints' ranges,
    and the joints the learned K 50 gaits change most."""
    n, hand = PER_CYCLE, np.asarray(cpg.PRESETS["hand_tuned"], dtype=np.float64)
    shift = 0.0
    for a in [hand, *learned_k50]:
        z = cpg.to_anatomical(targets(a))  # degrees; left leg 0-5, right 6-11
        left, right = z[2 * n + n // 2 : 4 * n + n // 2, :6], z[2 * n : 4 * n, 6:]
        shift = max(shift, float(np.abs(np.deg2rad(right - left)).max()))
    period = 0.0
    for a in [hand, *learned_k10]:
        z = targets(a)
        period = max(period, float(np.abs(z[3 * n : 5 * n] - z[2 * n : 4 * n]).max()))
    ranges = np.ptp(targets(hand)[n:], axis=0)
    raised = {}
    for i, name in enumerate(cpg.AMPLITUDE_NAMES):
        a = hand.copy()
        a[i] = a[i] * 1.5 if a[i] else 10.0
        raised[name] = (np.ptp(targets(a)[n:], axis=0) - ranges).tolist()
    steps = 2000
    _, base = trajectories.anatomical_targets(hand, steps)
    top = []
    for a in learned_k50:
        _, z = trajectories.anatomical_targets(a, steps)
        rms = np.sqrt(np.mean((z - base)[steps // 2 :, :6] ** 2, axis=0))
        top.append(sorted(LEFT_LEG[i] for i in np.argsort(rms)[-2:]))
    return {
        "phase_shift_rad": shift,
        "periodicity_rad": period,
        "range_change_when_raised_rad": raised,
        "k50_most_changed_left_joints": top,
    }


# --- trials -----------------------------------------------------------------------------------


def trial(amplitudes, seed: int = 0) -> dict:
    """One 1000-step training trial (version-1 physics, the study's) of a gait."""
    kwargs = {"supply": protocol.supply_limit(1)}
    return gait.evaluate_gait(np.asarray(amplitudes, dtype=np.float64), seed, task_kwargs=kwargs)


TOUCH = 1.0  # N on a sole's touch sensor: the foot is down
LIFT = 8  # control steps (0.13 s) a foot must be up before its next touchdown counts


def gait_features(amplitudes, seed: int = 0, steps: int = 1000) -> dict:
    """One training trial of a gait (version-1 physics), recording its footfalls: the mean
    step length (at each touchdown, how far ahead of the other foot the landing foot is,
    m), the mean interval between the left foot's touchdowns (control steps), the swing
    foot's height (95th percentile of the feet's height difference, m) and the hips' sway
    (peak to peak of the torso's lateral position less its linear drift, m). A touchdown
    is a sole's touch sensor rising past `TOUCH` after `LIFT` steps up; the first 100
    steps (the start) are left out."""
    config = cpg.CPGConfig()
    amplitudes = np.asarray(amplitudes, dtype=np.float64)
    targets = cpg.trajectories(amplitudes, steps, darwin.CONTROL_TIMESTEP, config)[0]
    kwargs = {"random": seed, "posture": config.offsets(), "time_limit": float("inf")}
    env = cpg_suite.load("darwin_walk", task_kwargs={**kwargs, "supply": protocol.supply_limit(1)})
    physics = env.physics
    env.reset()
    up = {"l": 0, "r": 0}
    lengths, left, lift, sway = [], [], [], []
    for t in range(steps):
        ts = env.step(physics.targets_to_action(targets[t]))
        x = {side: float(physics.named.data.xpos[f"foot_{side}"][0]) for side in ("l", "r")}
        if t >= 100:
            z = physics.named.data.xpos[["foot_l", "foot_r"], 2]
            lift.append(float(abs(z[0] - z[1])))
            sway.append(float(physics.torso_position()[1]))
        for side, other in (("l", "r"), ("r", "l")):
            if float(physics.named.data.sensordata[f"touch_{side}"][0]) <= TOUCH:
                up[side] += 1
                continue
            if up[side] >= LIFT and t >= 100:
                lengths.append(x[side] - x[other])
                if side == "l":
                    left.append(t)
            up[side] = 0
        if ts.last():
            break
    sway = np.array(sway) - np.polyval(
        np.polyfit(np.arange(len(sway)), sway, 1), np.arange(len(sway))
    )
    return {
        "touchdowns": len(lengths),
        "step_length_m": float(np.mean(lengths)) if lengths else float("nan"),
        "swing_height_m": float(np.percentile(lift, 95)),
        "sway_m": float(np.ptp(sway)),
        "left_interval_steps": float(np.mean(np.diff(left))) if len(left) > 1 else float("nan"),
        "fell": bool(ts.last() and t < steps - 1),
    }


def broken(t: dict, keep: float) -> bool:
    """A variant breaks a gait if it falls or keeps less than half its distance."""
    return bool(t["fell"] or t["distance_m"] < 0.5 * keep)


def around_learned(learned: dict[int, np.ndarray]) -> dict:
    """Per learned gait (by seed): its trial, the share of 20 draws N(θ*, I) that break it,
    and how many of its 11 amplitudes reset to hand-tuned break it."""
    hand = np.asarray(cpg.PRESETS["hand_tuned"], dtype=np.float64)
    out = {}
    for seed, theta in learned.items():
        keep = trial(theta)["distance_m"]
        rng = np.random.default_rng(seed)
        draws = theta + rng.standard_normal((PERTURBATIONS, theta.size))
        share = float(np.mean([broken(trial(d), keep) for d in draws]))
        resets = 0
        for i in range(theta.size):
            variant = theta.copy()
            variant[i] = hand[i]
            resets += broken(trial(variant), keep)
        out[str(seed)] = {"distance_m": keep, "perturbed_broken": share, "resets_broken": resets}
    return out


def learned_gaits(study: str, protocol_runs: str, setting: str) -> dict[int, np.ndarray]:
    """The best amplitudes of a setting's finished runs by seed (K 50: the shipped v1 runs)."""
    roots = [os.path.join(study, "cem", "darwin_walk")]
    if setting.startswith("K50_"):
        roots.append(os.path.join(protocol_runs, "cem", "darwin_walk"))
    found = {}
    for root in roots:
        if not os.path.isdir(root):
            continue
        for name in sorted(os.listdir(root)):
            base, _, seed = name.rpartition("_seed")
            if base.removesuffix("_v1") != setting or not seed.isdigit():
                continue
            if root != roots[0] and not base.endswith("_v1"):
                continue
            path = os.path.join(root, name, "best_params.json")
            if os.path.isfile(os.path.join(root, name, "summary.json")):
                params = runs.read_json(path)["amplitudes"]
                found.setdefault(int(seed), np.array([params[k] for k in cpg.AMPLITUDE_NAMES]))
    return dict(sorted(found.items()))


@dataclasses.dataclass(frozen=True)
class EvidenceSettings:
    """Where the study's runs are and where the evidence goes.

    Attributes:
      out: The JSON file written.
      study: The CEM study's runs (`baselines.experiments.cem_study --out`).
      protocol_runs: The board's shipped runs (their K = 50 version-1 runs).
    """

    out: str = os.path.join("results", "study", "computed.json")
    study: str = os.path.join("results", "study", "runs")
    protocol_runs: str = os.path.join("results", "protocol", "runs")


def sole_half_length() -> float:
    """Half the length of the DARwIn-OP's sole, m: the foot's collision box in the model."""
    physics = cpg_suite.load("darwin_balance").physics
    return float(physics.named.model.geom_size["foot_l"][0])


# CPG-8: one amplitude raised at a time (thesis Sec. 6.2 names what each sets).
RAISED = {"compass_hip": 10.0, "knee": 50.0, "balancing_hip": 16.0}


def raised_features(seeds: int = 5) -> dict:
    """The hand-tuned gait's footfalls and those with one amplitude of `RAISED` raised,
    per initial-state seed."""
    hand = np.asarray(cpg.PRESETS["hand_tuned"], dtype=np.float64)
    out = {"hand_tuned": [gait_features(hand, s) for s in range(seeds)]}
    for name, value in RAISED.items():
        raised = hand.copy()
        raised[cpg.AMPLITUDE_NAMES.index(name)] = value
        out[name] = [gait_features(raised, s) for s in range(seeds)]
    return out


def compute(settings: EvidenceSettings) -> dict:
    """Every section of the computed evidence."""
    k10 = learned_gaits(settings.study, settings.protocol_runs, LEARNED)
    k50 = learned_gaits(settings.study, settings.protocol_runs, "K50_n0.8_e2")
    hand = np.asarray(cpg.PRESETS["hand_tuned"], dtype=np.float64)
    return {
        "table6_3_settings": cem.TABLE6_3,
        "amplitude_names": list(cpg.AMPLITUDE_NAMES),
        "hand_tuned": hand.tolist(),
        "sole_half_length_m": sole_half_length(),
        "tokic": tokic(),
        "tokic_alg41": tokic_alg41(),
        "tokic_on_crawler": tokic_on_crawler(),
        "toy": toy(),
        "cpg": cpg_targets(list(k10.values()), list(k50.values())),
        "hand_tuned_trials": [trial(hand, s) for s in range(HAND_SEEDS)],
        "around_" + LEARNED: around_learned(k10),
        "raised_amplitudes": raised_features(),
        "gait_features": {
            "hand_tuned": gait_features(hand),
            **{
                setting: {str(seed): gait_features(a) for seed, a in gaits.items()}
                for setting, gaits in (
                    (LEARNED, k10),
                    (
                        "K20_n0.8_e2",
                        learned_gaits(settings.study, settings.protocol_runs, "K20_n0.8_e2"),
                    ),
                    ("K50_n0.8_e2", k50),
                )
            },
        },
    }


def define_flags() -> None:
    """Defines this module's command-line flags (only when it runs as a program)."""
    d = EvidenceSettings()
    flags.DEFINE_string("out", d.out, "The JSON file written.")
    flags.DEFINE_string("study", d.study, "The CEM study's runs.")
    flags.DEFINE_string("protocol_runs", d.protocol_runs, "The board's shipped runs.")


def main(argv: list[str]) -> None:
    del argv
    settings = cli.settings_from_flags(EvidenceSettings)
    for flag in ("study", "protocol_runs"):
        path = getattr(settings, flag)
        cli.check(os.path.isdir(path), f"--{flag}={path}: not a folder of runs")
    evidence = compute(settings)
    runs.write_text(settings.out, json.dumps(evidence, indent=1, sort_keys=True) + "\n")
    print(f"computed evidence -> {settings.out}")


if __name__ == "__main__":
    define_flags()
    cli.run(main, output_files=("out",))

"""Chapter 4: tabular learning on the crawler (Sec. 4.1), the pole (Sec. 4.2), the appendix.

The complete Tokic model (Table 4.1) is a known MDP: value and policy iteration on it are
computed by `baselines.experiments.study_evidence` (`results/study/computed.json`); its
greedy policy breaks ties in a fixed order, so these claims have one outcome, not one per
seed (policy iteration's random initial policies excepted). The
crawler's runs come from `baselines.experiments.crawler_experiments --output_dir=
results/study/crawler` (a row per run in `crawler_realtime.csv`), the pole's from
`baselines.experiments.pole_claims --output_dir=results/study/pole` (a row per run in
`results/study/pole/pole_runs.csv`).
"""

from __future__ import annotations

import os

import numpy as np
import pandas as pd

from analysis import published
from analysis.study import verdicts as v
from analysis.study.evidence import Evidence, MissingEvidence
from analysis.study.registry import rule

FORWARD = 0.05  # m over 100 greedy moves: a run walks forward (the experiments' rule)
CRAWLER = ("study", "crawler", "crawler_realtime.csv")
POLE = ("study", "pole", "pole_runs.csv")
LEARNERS = ("value_iteration", "q_learning", "sarsa", "sarsa_lambda", "td0", "td_lambda")
# Thesis Appendix, Tables A.2 and A.3: V after the first and second sweep (rows 0-4).
TABLE_A2_A3 = ("CR-N06", "CR-N07")


def tokic(ev: Evidence) -> dict:
    """Value and policy iteration on the Tokic model (`study_evidence.tokic`)."""
    return ev.computed("tokic")


def _one(ok: bool, text: str, why: str = "") -> v.Verdict:
    return v.Verdict(v.HOLDS if ok else v.FAILS, text, "" if ok else why)


def _gammas(ev: Evidence) -> dict[float, dict]:
    return {float(g): row for g, row in tokic(ev)["by_gamma"].items()}


def alg41(ev: Evidence) -> list[dict]:
    """Alg. 4.1 from V = 0 per tie-breaking seed (`study_evidence.tokic_alg41`): the
    measure CR-1a and CR-3 registered (the converged policy's figures, which they read
    before the fourth reading of 2026-11-28, are shown beside)."""
    return ev.computed("tokic_alg41")


@rule("CR-1a")
def cr_1a(ev: Evidence) -> v.Verdict:
    walks, t = alg41(ev), tokic(ev)
    entries = ", ".join(str(w["entry"]) for w in walks)
    text = (
        f"γ 0.9, Alg. 4.1 from V = 0 for 1000 moves, from (0, 0): cycle entered at move "
        f"{entries} and kept to the end, within 20 moves"
    )
    found = v.majority([w["entry"] <= 20 for w in walks], text)
    return v.Verdict(
        found.verdict,
        f"{found.evidence}; beside, the converged policy's greedy walk: entered after "
        f"{t['transient']} moves",
        found.why,
    )


@rule("CR-1b")
def cr_1b(ev: Evidence) -> v.Verdict:
    t = tokic(ev)
    text = f"γ 0.9: {len(t['cycle'])}-state cycle, reward {t['cycle_reward']:g}"
    return _one(len(t["cycle"]) == 6, text, "another cycle on the Tokic table")


@rule("CR-3")
def cr_3(ev: Evidence) -> v.Verdict:
    walks = alg41(ev)
    counts = ", ".join(str(w["starts_in_cycle_within"]) for w in walks)
    latest = max(w["latest_entry"] for w in walks)
    text = (
        f"Alg. 4.1 from V = 0 from each of the 25 cells: {counts} of 25 end in the cycle found "
        f"from (0, 0) within 20 moves (latest entry: move {latest}); all 25"
    )
    found = v.majority([w["starts_in_cycle_within"] == 25 for w in walks], text)
    same = tokic(ev)["starts_in_cycle_within_20"]
    return v.Verdict(
        found.verdict,
        f"{found.evidence}; beside, the converged policy: {same} of 25",
        found.why,
    )


def forward_threshold(ev: Evidence) -> float:
    """The smallest γ of the sweep whose greedy cycle from (0, 0) gains reward."""
    found = [g for g, row in sorted(_gammas(ev).items()) if row["cycle_reward"] > 0]
    return found[0] if found else float("nan")


# The γ grid the catalog's setting names for CR-4 (seed L610 gives none below 0.8).
GAMMA_GRID = (0.5, 0.6, 0.7, 0.75, 0.79, 0.8, 0.85, 0.9)


@rule("CR-4a")
def cr_4a(ev: Evidence) -> v.Verdict:
    """On the grid the criterion names (`GAMMA_GRID`; revised after the second reading of
    2026-11-27, where the rule judged the computed 0.005-step grid), per tie-breaking seed of
    the Alg. 4.1 walk as the measure says (the rule read value iteration's one greedy cycle
    until the seventh reading of 2026-11-29: the same cycle rewards), the fine grid's first
    forward γ beside."""
    by = _gammas(ev)
    seeds = range(len(by[GAMMA_GRID[0]]["alg41_cycle_rewards"]))
    reward = {g: by[g]["alg41_cycle_rewards"] for g in GAMMA_GRID}  # per tie-breaking seed
    below = [[g for g in GAMMA_GRID if g < 0.8 and reward[g][s] > 0] for s in seeds]
    above = [[g for g in GAMMA_GRID if g >= 0.8 and reward[g][s] <= 0] for s in seeds]
    shown = ", ".join(f"{g:g} {_list(reward[g], '+g')}" for g in GAMMA_GRID)
    holds = [not b and not a for b, a in zip(below, above)]
    fails = [any(g <= 0.7 for g in b) or 0.9 in a for b, a in zip(below, above)]
    text = (
        f"Alg. 4.1 cycle reward by γ per tie-breaking seed on the named grid ({shown}); "
        f"threshold at 0.8 in {sum(holds)} of {len(holds)} seeds, elsewhere in {sum(fails)} "
        f"(beside, value iteration's greedy cycle on a 0.005-step grid: first forward γ "
        f"{forward_threshold(ev):.3f})"
    )
    if sum(holds) >= 0.8 * len(holds):
        return v.Verdict(v.HOLDS, text)
    if sum(fails) >= 0.8 * len(fails):
        return v.Verdict(v.FAILS, text, "the threshold is elsewhere on the Tokic table")
    return v.Verdict(v.INCONCLUSIVE, text, "forward walking starts below 0.8 (threshold moved)")


def _list(values, fmt: str) -> str:
    """Per-seed values, one when they all agree."""
    shown = [format(x, fmt) for x in values]
    return shown[0] if len(set(shown)) == 1 else "[" + ", ".join(shown) + "]"


def cr_4a_fine(ev: Evidence) -> v.Verdict:
    """CR-4a as first judged: on the computed 0.005-step γ grid (`revisions`)."""
    by = _gammas(ev)
    below = [g for g, row in sorted(by.items()) if g < 0.8 and row["cycle_reward"] > 0]
    text = f"first forward γ {forward_threshold(ev):.3f}; forward below 0.8: {below or 'none'}"
    if not below:
        return v.Verdict(v.HOLDS, text)
    if any(g <= 0.7 for g in below):
        return v.Verdict(v.FAILS, text)
    return v.Verdict(v.INCONCLUSIVE, text)


@rule("CR-4b")
def cr_4b(ev: Evidence) -> v.Verdict:
    by = _gammas(ev)
    low = [0.5, 0.6, 0.7, 0.75, 0.79]  # CR-4a's grid below 0.8 (0.79 added after the sixth
    k = {g: by[g]["last_policy_change"] for g in low + [0.9]}  # reading: it was left out)
    earlier = sum(k[g] < k[0.9] for g in low)
    text = (
        f"last greedy-policy change (sweep) by γ: {k}; beside, γ 0.8, which walks forward: "
        f"{by[0.8]['last_policy_change']} (settling early does not set the γ below 0.8 "
        "apart from those that walk, only from 0.9)"
    )
    if earlier == len(low):
        return v.Verdict(v.HOLDS, text)
    if earlier <= 1:
        return v.Verdict(v.FAILS, text, "low γ settles no sooner here")
    return v.Verdict(v.INCONCLUSIVE, text, "some low γ settle no sooner")


@rule("CR-4c")
def cr_4c(ev: Evidence) -> v.Verdict:
    by = _gammas(ev)
    grid = [0.5, 0.6, 0.7, 0.75, 0.8, 0.85, 0.9]
    sweeps = [by[g]["sweeps_to_1e-6"] for g in grid]
    ok = all(a <= b for a, b in zip(sweeps, sweeps[1:])) and sweeps[0] < sweeps[6]
    return _one(ok, f"sweeps to a change < 1e-6 for γ {grid}: {sweeps}")


@rule("CR-5a")
def cr_5a(ev: Evidence) -> v.Verdict:
    """Policy iteration as the thesis reads it: it "follows the same methodology and
    assumptions adopted for the Value Iteration" (seed L560, L612), Alg. 4.1's one sweep per
    move, so an iteration is one evaluation sweep and a greedy improvement (revised after
    the second reading of 2026-11-27; the exact evaluation per iteration, first primary, is
    shown beside and in `revisions`)."""
    t = tokic(ev)
    vi, exact = t["vi_iterations_to_1pct"], t["pi_iterations_to_1pct"]
    one = t["pi_one_sweep_iterations_to_1pct"]
    label = (
        f"iterations to 1 %, PI of one evaluation sweep per iteration (Alg. 4.1) {one} − VI "
        f"{vi} (PI of an exact evaluation per iteration, beside: {exact})"
    )
    verdict = v.paired_greater(one, [vi] * len(one), label)
    why = "policy iteration converges in fewer one-sweep iterations here"
    return v.Verdict(verdict.verdict, verdict.evidence, why if verdict.why else "")


@rule("CR-5b")
def cr_5b(ev: Evidence) -> v.Verdict:
    return v.majority(tokic(ev)["pi_same_cycle"], "policy iteration's cycle is value iteration's")


@rule("CR-18")
def cr_18(ev: Evidence) -> v.Verdict:
    t = tokic(ev)
    diffs = []
    for sweep, pid in zip(("sweep1", "sweep2"), TABLE_A2_A3):
        rows = published.NUMBERS[pid]["value"].split("/")
        table = np.array([[float(x) for x in row.split()] for row in rows])
        diffs.append(float(np.abs(np.array(t[sweep]) - table).max()))
    return _one(max(diffs) <= 5e-7, f"max |ours − Table A.2|, |ours − A.3|: {diffs}")


@rule("CR-19")
def cr_19(ev: Evidence) -> v.Verdict:
    t = tokic(ev)
    moves = [tuple(m) for m in t["first_moves"]]
    values = [round(q, 9) for q in t["action_values_at_1_0_sweep2"]]
    ok = moves == [(0, 0), (1, 0), (0, 0)] and values == [-0.1, 0.0, 0.0]
    return _one(ok, f"first moves {moves}; action values at (1,0) in sweep 2: {values}")


@rule("CR-20")
def cr_20(ev: Evidence) -> v.Verdict:
    t = tokic(ev)
    differing, example = t["cells_with_differing_pinned_incoming_rewards"], t["reward_2_2_to_3_2"]
    text = (
        f"cells entered with differing pinned rewards: {differing} "
        f"({t['cells_with_differing_incoming_rewards']} counting every entry); "
        f"R((2,2)→(3,2)) = {example:g}"
    )
    return _one(differing > 0 and example == 6, text)


# --- the MuJoCo crawler ----------------------------------------------------------------


def crawler(ev: Evidence) -> pd.DataFrame:
    """The crawler experiments' per-run table.

    Raises:
      MissingEvidence: If it is not there.
    """
    path = os.path.join(ev.results, *CRAWLER)
    if not os.path.isfile(path):
        raise MissingEvidence(f"{path} (python -m baselines.experiments.crawler_experiments)")
    return pd.read_csv(path)


def runs(ev: Evidence, config: str) -> pd.DataFrame:
    """A crawler configuration's runs (≥ 5 seeds), in seed order."""
    found = crawler(ev)
    found = found[found["config"] == config].sort_values("seed")
    if len(found) < 5:
        raise MissingEvidence(f"crawler {config}: {len(found)} of 5 seeds")
    return found


def forward(df: pd.DataFrame) -> list[bool]:
    """The experiments' rule: > 5 cm in 100 greedy moves and a cycle of positive reward."""
    return list((df["displacement_m"] > FORWARD) & (df["cycle_learned_reward_m"] > 0))


def per_cycle(df: pd.DataFrame) -> np.ndarray:
    return (df["displacement_m"] * df["cycle_length"] / 100).to_numpy()


@rule("CR-6a")
def cr_6a(ev: Evidence) -> v.Verdict:
    a = runs(ev, "explore1000")["displacement_m"].to_numpy()
    b = runs(ev, "explore100")["displacement_m"].to_numpy()
    d, low, high = v.paired_interval(a, b)
    band = 0.1 * abs(a.mean())
    text = f"displacement N 1000 − N 100: {d:+.3f} [{low:+.3f}, {high:+.3f}] m, band ±{band:.3f}"
    if low > band or high < -band:
        return v.Verdict(v.HOLDS, text)
    if -band <= low and high <= band:
        return v.Verdict(v.FAILS, text, "the exploration length barely matters here")
    return v.Verdict(v.INCONCLUSIVE, text, "the interval reaches into the band")


@rule("CR-6b")
def cr_6b(ev: Evidence) -> v.Verdict:
    found = crawler(ev)
    short = found[found["config"].isin([f"explore{n}" for n in (50, 100, 200, 500, 1000)])]
    back = int((short["displacement_m"] < -FORWARD).sum())
    return _one(back > 0, f"runs with N ≤ 1000 that walk backwards: {back} of {len(short)}", "none")


@rule("CR-6c")
def cr_6c(ev: Evidence) -> v.Verdict:
    return v.majority(forward(runs(ev, "explore1000")), "N 1000: forward")


@rule("CR-6d")
def cr_6d(ev: Evidence) -> v.Verdict:
    explored = runs(ev, "explore1000")
    ratio = per_cycle(explored) / per_cycle(runs(ev, "explore5000"))
    mean, low, high = v.mean_interval(ratio)
    seen = list(explored["transitions_measured"].astype(int))
    complete = all(n == TRANSITIONS for n in seen)
    text = (
        f"per-cycle displacement, N 1000 / complete model: {mean:.2f} [{low:.2f}, {high:.2f}]; "
        f"transitions measured by N 1000: {seen} of {TRANSITIONS}"
        + (" [by construction: the 1000-move model is the complete one]" if complete else "")
    )
    if high < 0.75:
        return v.Verdict(v.HOLDS, text)
    if low > 0.75:
        return v.Verdict(
            v.FAILS, text, "the 1000-move model walks about as well as the complete one"
        )
    return v.Verdict(v.INCONCLUSIVE, text, "the interval straddles 0.75")


@rule("CR-7a")
def cr_7a(ev: Evidence) -> v.Verdict:
    a = runs(ev, "value_iteration")["displacement_m"].to_numpy()
    b = runs(ev, "value_iteration_eps0.1")["displacement_m"].to_numpy()
    d, low, high = v.paired_interval(a, b)
    margin = 0.1 * a.mean()
    text = (
        f"displacement, schedule − constant 0.1: {d:+.3f} [{low:+.3f}, {high:+.3f}] m "
        f"(margin {margin:.3f})"
    )
    if low > margin:
        return v.Verdict(v.HOLDS, text)
    if high < margin:
        return v.Verdict(v.FAILS, text, "no clear advantage of the schedule in our runs")
    return v.Verdict(v.INCONCLUSIVE, text, "the interval straddles the margin")


@rule("CR-11a")
def cr_11a(ev: Evidence) -> v.Verdict:
    return v.majority(forward(runs(ev, "value_iteration")), "real-time VI: forward")


MORPHOLOGY = "the cycle's shape follows the robot's dimensions, which the thesis does not give"


def _cycle_shape(ev: Evidence, config: str, length: int, joints: int) -> v.Verdict:
    df = runs(ev, config)
    flags = list((df["cycle_length"] == length) & (df["cycle_joints"] == joints))
    text = f"{config}: {length}-state {joints}-joint cycle (lengths {list(df['cycle_length'])})"
    verdict = v.majority(flags, text)
    return v.Verdict(verdict.verdict, verdict.evidence, MORPHOLOGY if verdict.why else "")


rule("CR-11b")(lambda ev: _cycle_shape(ev, "value_iteration", 2, 1))
rule("CR-15a")(lambda ev: _cycle_shape(ev, tuned(ev, "td_lambda"), 4, 2))
rule("CR-16b")(lambda ev: _cycle_shape(ev, "stochastic0.2", 4, 2))


def tuned(ev: Evidence, learner: str) -> str:
    """The learner's run as the thesis let it learn, to convergence: 5000 moves with
    learning on throughout (α 0.5 for the TD learners: the thesis gives none)."""
    return f"{learner}_moves5000"


# The α sweep's runs (1000 moves; the learners' plain runs are α 0.1).
ALPHA_RUNS = {0.1: "{}", 0.5: "{}_alpha0.5", 1.0: "{}_alpha1"}


def best_alpha(ev: Evidence, learner: str) -> tuple[float, str]:
    """The setting's own rule (CR-13): the learner's best α of {0.1, 0.5, 1} by mean
    displacement of the sweep's runs (ties to the larger α), and the run it is judged on:
    the run to convergence (`tuned`, 5000 moves) where that α is 0.5, else the sweep's
    1000-move run at that α (applied after the second reading of 2026-11-27)."""
    if learner == "value_iteration":
        return float("nan"), tuned(ev, learner)
    mean = {
        a: float(runs(ev, name.format(learner))["displacement_m"].mean())
        for a, name in ALPHA_RUNS.items()
    }
    top = max(mean.values())
    alpha = max(a for a, m in mean.items() if m >= top - v.ZERO)
    return alpha, tuned(ev, learner) if alpha == 0.5 else ALPHA_RUNS[alpha].format(learner)


@rule("CR-13a")
def cr_13a(ev: Evidence) -> v.Verdict:
    parts = []
    for a in LEARNERS:
        alpha, config = best_alpha(ev, a)
        flags = list(runs(ev, config)["last_moves_m"] > FORWARD)
        at = "" if np.isnan(alpha) else f" (best α {alpha:g})"
        parts.append(v.majority(flags, f"{config}{at}: last 100 moves > 5 cm"))
    return v.joined(parts)


def cr_13a_at_half(ev: Evidence) -> v.Verdict:
    """CR-13a as judged before the second reading of 2026-11-27: every learner's 5000-move
    run at α 0.5 (`revisions`)."""
    parts = []
    for a in LEARNERS:
        flags = list(runs(ev, tuned(ev, a))["last_moves_m"] > FORWARD)
        parts.append(v.majority(flags, f"{tuned(ev, a)}: last 100 moves > 5 cm"))
    return v.joined(parts)


def _last(ev: Evidence, a: str) -> np.ndarray:
    """The learner's last-100-move displacements at its best α (`best_alpha`)."""
    return runs(ev, best_alpha(ev, a)[1])["last_moves_m"].to_numpy()


@rule("CR-14a")
def cr_14a(ev: Evidence) -> v.Verdict:
    vi = _last(ev, "value_iteration")
    parts = []
    for a in ("q_learning", "sarsa", "sarsa_lambda"):
        mean, low, high = v.mean_interval(_last(ev, a) / vi.mean())
        parts.append(v.within(low, high, -np.inf, 0.5, f"{a} / VI {mean:.2f}"))
    return v.joined(parts)


@rule("CR-14b")
def cr_14b(ev: Evidence) -> v.Verdict:
    return _ladder(ev, _last)


def _ladder(ev: Evidence, last) -> v.Verdict:
    weakest = max(("q_learning", "sarsa", "sarsa_lambda"), key=lambda a: last(ev, a).mean())
    ladder = ["value_iteration", "td0", "td_lambda", weakest]
    parts = [
        v.greater(last(ev, hi), last(ev, lo), f"{hi} − {lo} (m, last 100 moves)")
        for hi, lo in zip(ladder, ladder[1:])
    ]
    return v.joined(parts)


def cr_14b_at_half(ev: Evidence) -> v.Verdict:
    """CR-14b as judged before the second reading of 2026-11-27: the 5000-move runs at α 0.5
    (`revisions`)."""
    return _ladder(ev, lambda ev, a: runs(ev, tuned(ev, a))["last_moves_m"].to_numpy())


# CR-16a's "about as quickly": per run, the move after which the greedy cycle no longer
# changed (a column of crawler_realtime.csv, when the experiments log it).
SETTLED = "cycle_settled_move"


@rule("CR-16a")
def cr_16a(ev: Evidence) -> v.Verdict:
    """Walks forward, and about as quickly: the median move of the last greedy-cycle change
    at most 2 × the deterministic runs' (computed in full after the second reading of
    2026-11-27; only the first half was)."""
    noisy, steady = runs(ev, "stochastic0.2"), runs(ev, "value_iteration")
    ahead = v.majority(forward(noisy), "moves fail with p 0.2: forward")
    if ahead.verdict == v.FAILS:
        return ahead
    if SETTLED not in noisy:
        return v.Verdict(
            v.INCONCLUSIVE,
            f"{ahead.evidence}; about as quickly: not computed",
            "the move of the last greedy-cycle change is not logged (crawler_realtime.csv "
            f"has no {SETTLED}; python -m baselines.experiments.crawler_experiments)",
        )
    a, b = float(noisy[SETTLED].median()), float(steady[SETTLED].median())
    quick = a <= 2 * b
    text = f"{ahead.evidence}; median move of the last cycle change {a:.0f} vs {b:.0f} (≤ 2×?)"
    if ahead.verdict == v.HOLDS and quick:
        return v.Verdict(v.HOLDS, text)
    return v.Verdict(
        v.INCONCLUSIVE, text, "slower than 2× the deterministic runs" if not quick else ahead.why
    )


@rule("CR-17")
def cr_17(ev: Evidence) -> v.Verdict:
    parts = [
        _one(tokic(ev)["cycle_reward"] > 0, "Tokic table, γ 0.9: forward cycle"),
        v.majority(forward(runs(ev, "value_iteration")), "crawler, γ 0.9: forward"),
        v.majority(list(pole(ev, "base")["balanced"]), "pole, γ 0.9: balanced"),
    ]
    return v.joined(parts)


# --- the pole -----------------------------------------------------------------------------


def pole(ev: Evidence, config: str) -> pd.DataFrame:
    """A pole configuration's runs (≥ 5 seeds), in seed order."""
    found = ev.table(*POLE)
    found = found[found["config"] == config].sort_values("seed")
    if len(found) < 5:
        raise MissingEvidence(f"pole {config}: {len(found)} of 5 seeds")
    return found


def _balance(ev: Evidence, configs: list[str], want: bool) -> v.Verdict:
    """Each config balances (want) or does not, in ≥ 4 of 5 seeds."""
    parts = [
        v.majority(
            [b == want for b in pole(ev, c)["balanced"]],
            f"{c} {'balanced' if want else 'never balanced'}",
        )
        for c in configs
    ]
    return v.joined(parts)


def _col(ev: Evidence, config: str, column: str) -> np.ndarray:
    return pole(ev, config)[column].to_numpy(dtype=np.float64)


rule("PB-1a")(lambda ev: _balance(ev, ["base", "bins4x20"], True))
rule("PB-2a")(lambda ev: _balance(ev, ["gamma0.5", "gamma0.7"], True))
# PB-3 and PB-5a at both forces the thesis names (0.5 N and 4 N, seed L772; 4 N added after
# the second reading of 2026-11-27).
rule("PB-3")(
    lambda ev: _balance(ev, ["gamma0.3", "gamma0.1", "gamma0.3_force4", "gamma0.1_force4"], False)
)
rule("PB-4a")(lambda ev: _balance(ev, ["bins100", "bins100_a2"], False))
rule("PB-5a")(lambda ev: _balance(ev, ["bins20", "bins20_force4"], True))
rule("PB-6b")(lambda ev: _balance(ev, ["bins100_approach"], True))


@rule("PB-10a")
def pb_10a(ev: Evidence) -> v.Verdict:
    """Over Fig. 4.9's 5000 iterations (seed L772), a seed balancing when it does not fall
    in the run's second half; the 20 000-step runs' lasting balance beside, deciding
    nothing (revised after the seventh reading of 2026-11-29: was judged on those)."""
    parts = [
        v.majority(
            [f == 0 for f in _col(ev, c, "falls_second_half")],
            f"{c} balanced (no fall in steps 2500-5000)",
        )
        for c in ("force4_short", "force0.5_short")
    ]
    long = {c: int(pole(ev, c)["balanced"].sum()) for c in ("force4", "base")}
    last = _col(ev, "force4", "last_fall_step").astype(int).tolist()
    found = v.joined(parts)
    beside = (
        f" [20 000 steps, beside: 4 N balanced in {long['force4']} of 5 seeds, 0.5 N in "
        f"{long['base']} of 5; 4 N's last fall at steps {last}]"
    )
    return v.Verdict(found.verdict, found.evidence + beside, found.why)


def pb_10a_20000(ev: Evidence) -> v.Verdict:
    """PB-10a as first judged: lasting balance over 20 000 steps (`revisions`)."""
    return _balance(ev, ["force4", "base"], True)


rule("PB-12a")(lambda ev: _balance(ev, ["base", "alpha0.1", "alpha0.5", "alpha1"], True))
rule("PB-16a")(lambda ev: _balance(ev, ["base", "epsilon0.05", "epsilon0.1", "epsilon0.2"], True))


@rule("PB-2b")
def pb_2b(ev: Evidence) -> v.Verdict:
    gammas = {0.1: "gamma0.1", 0.3: "gamma0.3", 0.5: "gamma0.5", 0.7: "gamma0.7", 0.9: "base"}
    working = [g for g, c in gammas.items() if pole(ev, c)["balanced"].sum() >= 4]
    pole_min, crawler_min = min(working, default=float("nan")), forward_threshold(ev)
    return _one(
        pole_min < crawler_min, f"smallest working γ: pole {pole_min}, crawler {crawler_min:.3f}"
    )


@rule("PB-4b")
def pb_4b(ev: Evidence) -> v.Verdict:
    a, b = _col(ev, "bins100_a2", "falls"), _col(ev, "bins100", "falls")
    return v.paired_similar(a, b, "falls, 2 − 3 actions (100 bins)", 0.2 * b.mean())


@rule("PB-4c")
def pb_4c(ev: Evidence) -> v.Verdict:
    spells = _col(ev, "bins100", "longest_balance_steps")
    return v.majority(
        [100 <= s < 5000 for s in spells], f"bins100 longest balance {spells.astype(int).tolist()}"
    )


@rule("PB-5b")
def pb_5b(ev: Evidence) -> v.Verdict:
    """The oscillation of a balance (seed L750: 'a state of equilibrium, but nonetheless with
    several oscillations'): rms θ inside balance spells (≥ 1000 steps without a fall); not
    testable where 20 angle bins never balance that long (revised after the second reading
    of 2026-11-27, where rms θ of the last 5000 steps, falls and all, decided)."""
    spells = {c: _col(ev, c, "spell_steps") for c in ("bins20", "bins20_force4")}
    first = pb_5b_all_steps(ev)
    if all(not x.any() for x in spells.values()):
        longest = {
            c: int(_col(ev, c, "longest_balance_steps").max()) for c in ("bins20", "bins20_force4")
        }
        return v.Verdict(
            v.UNTESTABLE,
            f"{first.evidence}; the rule as first written on these runs: {first.verdict}",
            "20 angle bins never balance here, at 0.5 N or 4 N (PB-5a): no spell of 1000 steps "
            f"without a fall (longest {longest['bins20']} and {longest['bins20_force4']} "
            "steps), so there is no balance whose oscillation to measure; rms θ over the whole "
            "run measures the falls",
        )
    return v.paired_greater(
        _col(ev, "bins20", "rms_angle_spells"),
        _col(ev, "base", "rms_angle_spells"),
        "rms θ inside balance spells, 20 bins − 20 × 20",
    )


def pb_5b_all_steps(ev: Evidence) -> v.Verdict:
    """PB-5b as first written: rms θ of the last 5000 steps, falls and all (`revisions`)."""
    return v.paired_greater(
        _col(ev, "bins20", "rms_angle_last"),
        _col(ev, "base", "rms_angle_last"),
        "rms θ, 20 bins − 20 × 20",
    )


@rule("PB-6a")
def pb_6a(ev: Evidence) -> v.Verdict:
    return v.paired_greater(
        _col(ev, "bins100", "falls"),
        _col(ev, "bins100_approach", "falls"),
        "falls, −θ² − approach reward",
    )


@rule("PB-7")
def pb_7(ev: Evidence) -> v.Verdict:
    best = _balance(ev, ["bins4x20", "base"], True)
    angle_only = _balance(ev, ["bins100", "bins20"], False)
    better = []
    for other in ("bins20x4", "bins10x10"):
        x = _col(ev, other, "falls")
        below = [
            v.paired_greater(_col(ev, b, "falls"), x, "").verdict == v.HOLDS
            for b in ("bins4x20", "base")
        ]
        better.append(all(below))
    text = f"{best.evidence}; {angle_only.evidence}; another with fewer falls: {any(better)}"
    if best.verdict == v.FAILS:
        return v.Verdict(v.FAILS, text, "4 × 20 or 20 × 20 does not balance")
    if best.verdict == v.HOLDS and angle_only.verdict == v.HOLDS and not any(better):
        return v.Verdict(v.HOLDS, text)
    return v.Verdict(v.INCONCLUSIVE, text, "another state definition does as well")


@rule("PB-8a")
def pb_8a(ev: Evidence) -> v.Verdict:
    two = _balance(ev, ["a2", "bins4x20_a2"], False)
    three = _balance(ev, ["base", "bins4x20"], True)
    text = f"{two.evidence}; {three.evidence}"
    if two.verdict == v.HOLDS and three.verdict == v.HOLDS:
        return v.Verdict(v.HOLDS, text)
    if any(pole(ev, c)["balanced"].sum() >= 4 for c in ("a2", "bins4x20_a2")):
        return v.Verdict(v.FAILS, text, "two actions balance in our runs")
    return v.Verdict(v.INCONCLUSIVE, text, "the seeds split")


@rule("PB-9")
def pb_9(ev: Evidence) -> v.Verdict:
    mean, low, high = v.mean_interval(_col(ev, "base", "toward_fall_fraction"))
    return v.within(low, high, 0.5, 1.0, f"share of pushes toward the fall side {mean:.2f}")


@rule("PB-10b")
def pb_10b(ev: Evidence) -> v.Verdict:
    """The swing while both forces balance (steps 15 000-20 000 of the 20 000-step runs:
    our 4 N still falls in the second half of 5000 steps, PB-10a), with the 5000-step
    runs' second half beside, falls included (revised after the seventh reading of
    2026-11-29: was judged on those)."""
    found = v.paired_greater(
        _col(ev, "force4", "rms_angle_15000_20000"),
        _col(ev, "base", "rms_angle_15000_20000"),
        "rms θ over steps 15 000-20 000, 4 N − 0.5 N",
    )
    short = pb_10b_5000(ev)
    return v.Verdict(
        found.verdict, f"{found.evidence} [5000 steps' second half, beside: {short.evidence}]"
    )


def pb_10b_5000(ev: Evidence) -> v.Verdict:
    """PB-10b as first judged: the 5000-step runs' second half, falls included."""
    return v.paired_greater(
        _col(ev, "force4_short", "rms_angle_second_half"),
        _col(ev, "force0.5_short", "rms_angle_second_half"),
        "rms θ second half, 4 N − 0.5 N",
    )


@rule("PB-11")
def pb_11(ev: Evidence) -> v.Verdict:
    df = pole(ev, "alpha0")
    flags = list((df["q_table_abs_max"] == 0) & (~df["balanced"].astype(bool)))
    return v.majority(flags, "α 0: Q stays 0 and no lasting balance")


ALPHAS = {"base": 0.01, "alpha0.1": 0.1, "alpha0.5": 0.5, "alpha1": 1.0}


@rule("PB-13a")
def pb_13a(ev: Evidence) -> v.Verdict:
    rms = {c: _col(ev, c, "rms_angle_last") for c in ALPHAS}
    parts = [
        v.paired_greater(rms[c], rms["base"], f"rms θ, α {ALPHAS[c]} − 0.01")
        for c in ALPHAS
        if c != "base"
    ]
    lowest = min(rms, key=lambda c: rms[c].mean()) == "base"
    verdict = v.all_of(parts)
    if verdict == v.HOLDS and not lowest:
        verdict = v.INCONCLUSIVE
    return v.Verdict(
        verdict, "; ".join(p.evidence for p in parts), "; ".join(p.why for p in parts if p.why)
    )


@rule("PB-13b")
def pb_13b(ev: Evidence) -> v.Verdict:
    early = {c: _col(ev, c, "falls_first_5000") for c in ALPHAS}
    parts = [
        v.paired_greater(early["base"], early[c], f"early falls, α 0.01 − {ALPHAS[c]}")
        for c in ALPHAS
        if c != "base"
    ]
    return v.joined(parts)


@rule("PB-14a")
def pb_14a(ev: Evidence) -> v.Verdict:
    return v.paired_greater(
        _col(ev, "alpha0.1", "rms_angle_last"),
        _col(ev, "base", "rms_angle_last"),
        "rms θ, α 0.1 − 0.01",
    )


@rule("PB-15a")
def pb_15a(ev: Evidence) -> v.Verdict:
    small = np.maximum(
        _col(ev, "base", "rms_angle_last").mean(), _col(ev, "alpha0.1", "rms_angle_last").mean()
    )
    parts = [
        v.paired_greater(
            _col(ev, c, "rms_angle_last"),
            np.full(5, small),
            f"rms θ, α {ALPHAS[c]} − max(0.01, 0.1)",
        )
        for c in ("alpha0.5", "alpha1")
    ]
    return v.joined(parts)


@rule("PB-15b")
def pb_15b(ev: Evidence) -> v.Verdict:
    rms = {c: _col(ev, c, "rms_angle_last") for c in ALPHAS}
    gap = np.abs(rms["base"] - rms["alpha0.1"]) - np.abs(rms["alpha0.5"] - rms["alpha1"])
    return v.paired_greater(gap, np.zeros_like(gap), "|0.01 − 0.1| − |0.5 − 1| (rms θ, per seed)")


@rule("PB-17")
def pb_17(ev: Evidence) -> v.Verdict:
    return v.paired_greater(
        _col(ev, "bins100", "falls"), _col(ev, "bins20", "falls"), "falls, 100 − 20 angle bins"
    )


# --- numbers ------------------------------------------------------------------------------


def _tables_a(sweep: int):
    def ours(ev: Evidence) -> dict:
        values = np.array(tokic(ev)[f"sweep{sweep}"])
        rows = [" ".join(f"{x:g}" for x in row) for row in np.round(values, 6)]
        return {"ours": " / ".join(rows), "comparison": "see CR-18 (equal to 5e-7)"}

    return ours


def _cycle_length(ev: Evidence) -> dict:
    return {"ours": str(len(tokic(ev)["cycle"])), "comparison": "the Tokic table, computed"}


def _realtime(config: str, column: str = "displacement_m"):
    def ours(ev: Evidence) -> dict:
        df = runs(ev, config)
        mean, low, high = v.mean_interval(df[column].to_numpy())
        return {
            "ours": f"{mean:.4f} m",
            "ours_ci95": f"[{low:.4f}, {high:.4f}]",
            "seeds": len(df),
            "comparison": "over 100 greedy moves after 1000 learning moves; the thesis' run "
            "length is not given: not comparable as a value",
        }

    return ours


def _realtime_cycle(config: str):
    def ours(ev: Evidence) -> dict:
        df = runs(ev, config)
        shapes = ", ".join(f"{a}/{b}" for a, b in zip(df["cycle_length"], df["cycle_joints"]))
        return {"ours": shapes, "seeds": len(df), "comparison": "cycle states/joints per seed"}

    return ours


NUMBERS = {
    "CR-N06": _tables_a(1),
    "CR-N07": _tables_a(2),
    "CR-N10": _cycle_length,
    "CR-N21": _realtime("value_iteration"),
    "CR-N22": _realtime_cycle("value_iteration"),
    "CR-N23": _realtime("td0"),
    "CR-N24": _realtime("td_lambda"),
    "CR-N25": _realtime_cycle("td_lambda"),
    "CR-N31": _realtime_cycle("stochastic0.2"),
}


# --- exploration on the crawler (Sec. 4.1.7, real-time learning) ---------------------------

CONSTANT_EPSILONS = ("0.1", "0.3", "0.5", "0.9")
TRANSITIONS = 80  # allowed moves on the 5 × 5 grid (4 corners × 2 + 12 edges × 3 + 9 × 4)


def _crawler_col(ev: Evidence, config: str, column: str) -> np.ndarray:
    return runs(ev, config)[column].to_numpy(dtype=np.float64)


def _measured(ev: Evidence, config: str) -> np.ndarray:
    return _crawler_col(ev, config, "transitions_measured") / TRANSITIONS


@rule("CR-7b")
def cr_7b(ev: Evidence) -> v.Verdict:
    return v.paired_greater(
        _measured(ev, "value_iteration"),
        _measured(ev, "value_iteration_eps0.1"),
        "share of transitions measured, schedule − constant 0.1",
    )


@rule("CR-8a")
def cr_8a(ev: Evidence) -> v.Verdict:
    return v.paired_greater(
        _measured(ev, "value_iteration_eps0.9"),
        _measured(ev, "value_iteration_eps0.1"),
        "share of transitions measured, ε 0.9 − 0.1",
    )


@rule("CR-8b")
def cr_8b(ev: Evidence) -> v.Verdict:
    return v.paired_greater(
        _crawler_col(ev, "value_iteration", "last_moves_m"),
        _crawler_col(ev, "value_iteration_eps0.9", "last_moves_m"),
        "last 100 learning moves, schedule − constant 0.9 (m)",
    )


@rule("CR-8c")
def cr_8c(ev: Evidence) -> v.Verdict:
    schedule = _crawler_col(ev, "value_iteration", "last_moves_m")
    parts = [
        v.paired_greater(
            schedule,
            _crawler_col(ev, f"value_iteration_eps{e}", "last_moves_m"),
            f"last 100 moves, schedule − constant {e} (m)",
        )
        for e in CONSTANT_EPSILONS
    ]
    found = v.joined(parts)
    # Beside (the second reading of 2026-11-27): the greedy gaits learned, as CR-7a reads.
    greedy = _crawler_col(ev, "value_iteration", "displacement_m")
    gap = {
        e: float(np.mean(greedy - _crawler_col(ev, f"value_iteration_eps{e}", "displacement_m")))
        for e in CONSTANT_EPSILONS
    }
    beside = "; ".join(f"{e} {d:+.3f}" for e, d in gap.items())
    note = (
        f"{found.evidence} [the criterion's on-line measure: a schedule that reaches ε 0 "
        "loses no moves to chance by then, any constant ε > 0 does; beside, the greedy gaits "
        f"learned, 100 greedy moves, schedule − constant (m, mean of 5): {beside}: the "
        "constant runs learn gaits as good, they do not walk them]"
    )
    return v.Verdict(found.verdict, note, found.why)


@rule("CR-9a")
def cr_9a(ev: Evidence) -> v.Verdict:
    a = _crawler_col(ev, "value_iteration", "displacement_m")
    b = _crawler_col(ev, "value_iteration_hold300", "displacement_m")
    per_seed = ", ".join(f"{x:+.3f}" for x in v._snap(*(a - b)))
    label = f"greedy displacement, ε 0.9 held 100 − 300 moves (m; per seed {per_seed})"
    found = v.paired_greater(a, b, label)
    if found.verdict == v.INCONCLUSIVE and max(a - b) <= v.ZERO:
        return v.Verdict(
            found.verdict,
            found.evidence,
            "the interval reaches 0 from below: the longer hold walks as far or farther in "
            "every seed",
        )
    return found


@rule("CR-9b")
def cr_9b(ev: Evidence) -> v.Verdict:
    def share(config: str) -> np.ndarray:
        worse = _crawler_col(ev, config, "entries_worse_than_best")
        return worse / _crawler_col(ev, config, "entries_remeasured")

    return v.paired_greater(
        share("value_iteration_hold300"),
        share("value_iteration"),
        "share of re-measured table entries left worse by > 0.1 mm than their move's best "
        "measurement, ε 0.9 held 300 − 100 moves",
    )


# "Worth 0": a cycle's learned reward below this, m: the 0.1 mm an entry must differ by to
# count as another measurement (crawler_experiments.WORSE_M). Set after the runs, where the
# criterion said "0" and the cycles found gain 14 µm (said in docs/study.md).
STILL_M = 1e-4


@rule("CR-10")
def cr_10(ev: Evidence) -> v.Verdict:
    df = runs(ev, "value_iteration_backward100")
    still = (df["displacement_m"].abs() < 0.01) & (df["cycle_learned_reward_m"].abs() < STILL_M)
    shown = ", ".join(
        f"{d * 1000:.2f} mm/{c * 1e6:.0f} µm"
        for d, c in zip(df["displacement_m"], df["cycle_learned_reward_m"])
    )
    text = f"backward moves ×100: 100 greedy moves' displacement / cycle reward per seed ({shown})"
    return v.majority(list(still), text + "; standing still (< 1 cm, cycle < 0.1 mm)")


@rule("CR-9c")
def cr_9c(ev: Evidence) -> v.Verdict:
    long, short = (
        _crawler_col(ev, "value_iteration_moves5000", "displacement_m"),
        _crawler_col(ev, "value_iteration", "displacement_m"),
    )
    return v.paired_similar(
        long, short, "greedy displacement, 5000 − 1000 moves (m)", 0.1 * abs(short.mean())
    )


@rule("CR-12")
def cr_12(ev: Evidence) -> v.Verdict:
    rho = _crawler_col(ev, "value_iteration", "tokic_rank_correlation")
    mean, low, high = v.mean_interval(rho)
    text = f"rank correlation of the learned table with Tokic's: {mean:.2f} [{low:.2f}, {high:.2f}]"
    if high < 0.5:
        return v.Verdict(v.HOLDS, text)
    if low > 0.5:
        return v.Verdict(v.FAILS, text, "the learned table ranks moves as Tokic's does")
    return v.Verdict(v.INCONCLUSIVE, text, "the interval straddles 0.5")


@rule("CR-13b")
def cr_13b(ev: Evidence) -> v.Verdict:
    area = {a: runs(ev, tuned(ev, a))["rms_area"].to_numpy(dtype=np.float64) for a in LEARNERS}
    order = sorted(area, key=lambda a: area[a].mean())
    third = area[order[2]].mean()
    text = "RMS area by learner: " + ", ".join(f"{a} {area[a].mean():.3g}" for a in order)
    best_two = set(order[:2]) == {"value_iteration", "q_learning"}
    below = all(v.mean_interval(area[a])[2] < third for a in ("value_iteration", "q_learning"))
    if best_two and below:
        return v.Verdict(v.HOLDS, text)
    if order.index("value_iteration") >= 3 or order.index("q_learning") >= 3:
        return v.Verdict(v.FAILS, text, "value iteration or Q-learning converges among the worst")
    return v.Verdict(v.INCONCLUSIVE, text, "the two are not clearly the best")


@rule("CR-15b")
def cr_15b(ev: Evidence) -> v.Verdict:
    def last_per_cycle(df: pd.DataFrame) -> np.ndarray:
        return (df["last_moves_m"] * df["cycle_length"] / 100).to_numpy()

    cycle = {a: last_per_cycle(runs(ev, tuned(ev, a))) for a in LEARNERS}
    order = sorted(cycle, key=lambda a: -cycle[a].mean())
    top, second = order[0], order[1]
    if top == "td_lambda":
        return v.greater(
            cycle["td_lambda"], cycle[second], f"per-cycle displacement, TD(λ) − {second}"
        )
    verdict = v.greater(cycle["td_lambda"], cycle[top], f"per-cycle displacement, TD(λ) − {top}")
    if verdict.verdict == v.FAILS:
        return v.Verdict(v.FAILS, verdict.evidence, f"{top} takes larger steps in our runs")
    return v.Verdict(v.INCONCLUSIVE, verdict.evidence, f"{top} has the larger mean")


@rule("PB-16b")
def pb_16b(ev: Evidence) -> v.Verdict:
    configs = {"base": 0.0, "epsilon0.05": 0.05, "epsilon0.1": 0.1, "epsilon0.2": 0.2}
    eps = np.concatenate([np.full(5, e) for e in configs.values()])
    last = np.concatenate(
        [pole(ev, c)["last_fall_step"].to_numpy(dtype=np.float64) for c in configs]
    )
    rng = np.random.default_rng(0)
    rhos = []
    for _ in range(2000):
        i = rng.integers(0, eps.size, eps.size)
        if np.ptp(eps[i]) and np.ptp(last[i]):
            rhos.append(float(pd.Series(eps[i]).corr(pd.Series(last[i]), method="spearman")))
    low, high = np.percentile(rhos, [2.5, 97.5])
    rho = float(pd.Series(eps).corr(pd.Series(last), method="spearman"))
    text = f"Spearman ρ(ε, last fall step) over 20 runs: {rho:.2f} [{low:.2f}, {high:.2f}]"
    if low > 0:
        return v.Verdict(v.HOLDS, text)
    if high < 0:
        return v.Verdict(v.FAILS, text, "more exploration balanced sooner in our runs")
    return v.Verdict(v.INCONCLUSIVE, text, "the interval contains 0")


def _tokic_on_crawler(ev: Evidence) -> tuple[np.ndarray, int]:
    found = ev.computed("tokic_on_crawler")
    return np.array(found["displacement_m"]), found["cycle_length"]


@rule("CR-11c")
def cr_11c(ev: Evidence) -> v.Verdict:
    """Farther than the Tokic policy on the same robot: a comparison only where that policy
    walks forward on our crawler; where it walks backwards any forward gait (CR-11a) is
    farther, a test met by construction, so not testable here (revised after the second
    reading of 2026-11-27, as CEM-11b)."""
    tokic_policy, _ = _tokic_on_crawler(ev)
    found = v.paired_greater(
        _crawler_col(ev, "value_iteration", "displacement_m"),
        tokic_policy,
        "100 greedy moves, real-time VI − the Tokic table's policy on our crawler (m)",
    )
    if float(np.max(tokic_policy)) <= 0:
        return v.Verdict(
            v.UNTESTABLE,
            f"{found.evidence}; the rule on these runs: {found.verdict}",
            f"met by construction: the Tokic table's 6-cycle walks backwards on our crawler "
            f"({float(np.mean(tokic_policy)):+.2f} m in 100 moves), so any forward gait "
            "(CR-11a) is farther; the thesis' 7.57 against 6.30 u.d. (seed L649) compares two "
            "forward gaits, which our crawler does not give",
        )
    return found


@rule("CR-11d")
def cr_11d(ev: Evidence) -> v.Verdict:
    tokic_policy, length = _tokic_on_crawler(ev)
    return v.paired_greater(
        tokic_policy * length / 100,
        per_cycle(runs(ev, "value_iteration")),
        "per cycle, the Tokic 6-cycle − the real-time cycle on our crawler (m)",
    )


# --- the pole, from its runs' per-step files (pole_claims' per-run columns) ---------------


@rule("PB-1b")
def pb_1b(ev: Evidence) -> v.Verdict:
    df = pole(ev, "base")
    flags = list((df["falls"] >= 2) & (df["longest_fallen_spell"] >= 100))
    spells = df["longest_fallen_spell"].astype(int).tolist()
    return v.majority(
        flags, f"≥ 2 falls and a spell of ≥ 100 steps ending in one (longest {spells})"
    )


@rule("PB-4d")
def pb_4d(ev: Evidence) -> v.Verdict:
    """Not testable with the runs' measure (revised after the second reading of 2026-11-27):
    with Q = 0 at start and negative rewards, greedy choice tries every action of a state
    within its first three visits (seed L801), so the share of visited states with every
    action tried is 1 wherever states are visited three times, whatever the bins."""
    found = v.paired_greater(
        _col(ev, "bins20", "all_actions_tried_share"),
        _col(ev, "bins100", "all_actions_tried_share"),
        "share of tried states with every action tried, 20 − 100 angle bins",
    )
    return v.Verdict(
        v.UNTESTABLE,
        f"{found.evidence}; the rule on these runs: {found.verdict}",
        "the measure cannot tell: with Q = 0 at start and negative rewards every action of a "
        "state is tried within its first three visits (seed L801), so both shares are 1; "
        "what seed L750 names, too little time in a state to act and see the outcome, needs "
        "the steps spent per passage through a state, which the runs do not log",
    )


@rule("PB-8b")
def pb_8b(ev: Evidence) -> v.Verdict:
    share = _col(ev, "base", "zero_action_share_last")
    text = f"zero-force share of the last 5000 steps: {[round(float(x), 3) for x in share]}"
    why = "the learned policy hardly uses the zero force"
    return v.split(share >= 0.1, share < 0.02, text, why)


def _apart(cis: dict) -> bool:
    """Whether some pair of intervals does not overlap."""
    keys = list(cis)
    return any(
        cis[a][1] < cis[b][0] or cis[b][1] < cis[a][0]
        for i, a in enumerate(keys)
        for b in keys[i + 1 :]
    )


def _differ(ev: Evidence, column: str) -> list[str]:
    """The pairs of α whose difference of mean `column` has a bootstrap 95 % interval that
    excludes 0 (`verdicts.difference_interval`, the study's comparison of two settings)."""
    values = {c: _col(ev, c, column) for c in ALPHAS}
    keys = list(values)
    return [
        f"{ALPHAS[b]} − {ALPHAS[a]} {d:+.2g} [{low:+.2g}, {high:+.2g}]"
        for i, a in enumerate(keys)
        for b in keys[i + 1 :]
        for d, low, high in [v.difference_interval(values[b], values[a])]
        if low > 0 or high < 0
    ]


@rule("PB-12b")
def pb_12b(ev: Evidence) -> v.Verdict:
    """Alike early, apart late, by the interval of each pair's difference (revised after
    the sixth reading of 2026-11-29: the per-α intervals' overlap, `pb_12b_by_overlap`,
    called α values alike whose difference excludes 0)."""
    early, late = _differ(ev, "rms_angle_2500_5000"), _differ(ev, "rms_angle_15000_20000")
    text = (
        f"α pairs whose rms θ differs, steps 2500-5000: {'; '.join(early) or 'none'}; "
        f"steps 15 000-20 000: {'; '.join(late) or 'none'}"
    )
    if not early and late:
        return v.Verdict(v.HOLDS, text)
    if early and not late:
        return v.Verdict(v.FAILS, text, "the α values differ early, not late")
    return v.Verdict(v.INCONCLUSIVE, text, "they differ both early and late, or neither")


def pb_12b_by_overlap(ev: Evidence) -> v.Verdict:
    """PB-12b as first written: the per-α intervals overlap pairwise early, some pair not
    late (`revisions`)."""
    early = {c: v.mean_interval(_col(ev, c, "rms_angle_2500_5000"))[1:] for c in ALPHAS}
    late = {c: v.mean_interval(_col(ev, c, "rms_angle_15000_20000"))[1:] for c in ALPHAS}
    text = f"α {list(ALPHAS.values())}: intervals apart early {_apart(early)}, late {_apart(late)}"
    if not _apart(early) and _apart(late):
        return v.Verdict(v.HOLDS, text)
    if _apart(early) and not _apart(late):
        return v.Verdict(v.FAILS, text, "the α values differ early, not late")
    return v.Verdict(v.INCONCLUSIVE, text, "they differ both early and late, or neither")


def _quiet(ev: Evidence) -> tuple[list[bool], str]:
    df = pole(ev, "alpha0.1")
    ratios = df["quietest_window_ratio"].round(2).tolist()
    where = df["quietest_window_step"].astype(int).tolist()
    flags = list(df["quietest_window_ratio"] <= 0.5)
    return flags, f"quietest 1000 steps in 8000-16000 / median window: {ratios} at {where}"


@rule("PB-14b")
def pb_14b(ev: Evidence) -> v.Verdict:
    """The quiet spell is one run's event (seed L795): judged as one (`verdicts.one_run`;
    revised after the second reading of 2026-11-27, where it was a 4-of-5 property)."""
    return v.one_run(*_quiet(ev))


def pb_14b_as_property(ev: Evidence) -> v.Verdict:
    """PB-14b as first judged, a property of the setting (`revisions`)."""
    return v.majority(*_quiet(ev))


def _all_tried(ev: Evidence) -> v.Verdict:
    share = _col(ev, "base", "all_actions_tried_share")
    return v.majority(
        list(share >= 0.99), f"ε 0: states with every action tried {share.round(3).tolist()}"
    )


@rule("PB-16c")
def pb_16c(ev: Evidence) -> v.Verdict:
    """Not testable here (revised after the second reading of 2026-11-27): the statement
    holds by the learner's construction, and the runs do not count visits."""
    found = _all_tried(ev)
    return v.Verdict(
        v.UNTESTABLE,
        f"{found.evidence}; the rule on these runs: {found.verdict}",
        "true by construction of greedy choice with Q = 0 at start and rewards < 0 (seed "
        "L801: a tried action's Q falls below the untried ones' 0), so a measure checks our "
        "code, not the thesis; and the runs do not count visits, so the shares below 1 "
        "(0.833) are states visited once or twice, which the statement leaves out",
    )


@rule("CR-13c")
def cr_13c(ev: Evidence) -> v.Verdict:
    vi, q = runs(ev, tuned(ev, "value_iteration")), runs(ev, tuned(ev, "q_learning"))
    early = vi["rms_first20"].to_numpy() > q["rms_first20"].to_numpy()
    caught = vi["rms_at_300"].to_numpy() <= 1.1 * q["rms_at_300"].to_numpy()
    text = (
        f"VI's RMS error above Q-learning's over moves 1-20 in {int(early.sum())} seeds, within "
        f"1.1 × of it at move 300 in {int(caught.sum())}"
    )
    return v.majority(list(early & caught), text)

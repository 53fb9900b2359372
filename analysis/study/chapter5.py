"""Chapter 5: the DARwIn-OP's CPG (Sec. 5.2) and the Natural Actor-Critic (Secs. 5.3-5.5).

The NAC runs come from `baselines.experiments.nac_experiments --output_dir=results/study/nac`
(per run `nac/<task>/<config>_seed<S>/summary.json`), its step-size sweep from the same
command with `--sweep --resume` (`<config>_alpha<α>_epsA<ε_A>_seed<S>`), the fixes runs'
θ scaled up with `--scaled` (`nac_scaled.json`). The CPG claims
are computed from the CPG's targets (no physics) and from trials of the hand-tuned gait and
of the study's learned gaits (`analysis.study.chapter6.trial`).
"""

from __future__ import annotations

import dataclasses
import json
import os

import numpy as np
import pandas as pd

from analysis.study import chapter6
from analysis.study import verdicts as v
from analysis.study.evidence import Evidence, MissingEvidence
from analysis.study.registry import rule

NAC = ("study", "nac", "nac")
# Half a servo step: the MX-28 resolves 0.088° (4096 counts a turn, docs/darwin_op_model.md);
# targets closer than this are the same command. CPG-2 and CPG-6 were first written with
# 1e-6 rad, which the CPG's integration from its start posture exceeds (a constant 1.5e-6
# rad between the legs): changed after the run, said in the catalog and the note.
SAME_TARGET = np.deg2rad(0.088) / 2


def nac_runs(ev: Evidence, task: str, config: str) -> list[dict]:
    """The summaries of a NAC configuration's runs.

    Raises:
      MissingEvidence: With fewer than 5 runs.
    """
    root = os.path.join(ev.results, *NAC, task)
    found = []
    for seed in range(100):
        path = os.path.join(root, f"{config}_seed{seed}", "summary.json")
        if not os.path.isfile(path):
            break
        with open(path, encoding="utf-8") as f:
            found.append(json.load(f))
    if len(found) < 5:
        sweep = " --sweep --resume" if "_alpha" in config else ""
        raise MissingEvidence(
            f"NAC {config}: {len(found)} of 5 seeds (python -m "
            f"baselines.experiments.nac_experiments --output_dir=results/study/nac{sweep})"
        )
    return found


@rule("NAC-3")
def nac_3(ev: Evidence) -> v.Verdict:
    runs = nac_runs(ev, "darwin_balance", "fixes")
    after = [r["reward_after"] for r in runs]
    before = [r["reward_before"] for r in runs]
    d, low, high = v.paired_interval(after, before)
    margin = 0.1 * abs(np.mean(before))
    text = (
        f"COP reward per step, after − before: {d:+.5f} [{low:+.5f}, {high:+.5f}] "
        f"(10 % of the reward: {margin:.5f})"
    )
    if high <= margin:
        return v.Verdict(v.HOLDS, text)
    if low > margin:
        return v.Verdict(v.FAILS, text, "the NAC improved the reward in our runs")
    return v.Verdict(v.INCONCLUSIVE, text, "the interval reaches past 10 %")


# The sweep the catalog's NAC-1, NAC-2a and NAC-7 are judged over, (α, ε_A), and the run
# names `nac_experiments --sweep` gives its points (BASE's point, α 100 and ε_A 1e-6, keeps
# the plain name); a test holds them equal to nac_experiments.SWEEP and point_name.
SWEEP = tuple((alpha, eps_a) for alpha in (1.0, 10.0, 100.0) for eps_a in (1e-6, 1e-2))


def point_name(config: str, alpha: float, eps_a: float) -> str:
    """The run-name stem of a configuration at a sweep point."""
    return config if (alpha, eps_a) == (100.0, 1e-6) else f"{config}_alpha{alpha:g}_epsA{eps_a:g}"


def sweep_runs(ev: Evidence, config: str) -> dict[tuple[float, float], list[dict]]:
    """A configuration's runs at every point (α, ε_A) of the step-size sweep.

    Raises:
      MissingEvidence: If a point has fewer than 5 runs.
    """
    return {point: nac_runs(ev, "darwin_balance", point_name(config, *point)) for point in SWEEP}


def _diverged(runs: list[dict]) -> int:
    return sum(bool(r["diverged"]) for r in runs)


def _counts(sweep: dict[tuple[float, float], list[dict]]) -> str:
    return ", ".join(f"α {a:g} ε_A {e:g}: {_diverged(r)}/{len(r)}" for (a, e), r in sweep.items())


# What a sweep would need to show NAC-1's blow-up, or to rule it out: the constants that
# decide whether A's inversion goes unstable, none of which the thesis gives (seed L1030).
NAC_1_NEEDS = (
    "a sweep over what decides the inversion's stability, none of it given by the thesis "
    "(seed L1030): ε_A down to 1e-12, α up to 1e4, the forgetting β, and the features' scale "
    "(ours: targets in rad and phases; in degrees they are ~57× larger)"
)


@rule("NAC-1")
def nac_1(ev: Evidence) -> v.Verdict:
    """Holds if θ blows up without the fixes at half the sweep points or more; a sweep
    without a blow-up is inconclusive, naming the sweep that could show one (revised after
    the second reading of 2026-11-27: it failed; the six points are not the thesis' setting,
    which it does not give)."""
    sweep = sweep_runs(ev, "nofix")
    text = f"no fixes, runs whose |θ| passed 1e6 or became NaN per sweep point: {_counts(sweep)}"
    wild = sum(_diverged(r) >= 4 for r in sweep.values())
    if wild >= len(sweep) / 2:
        return v.Verdict(v.HOLDS, text)
    if all(_diverged(r) < 2 for r in sweep.values()):
        return v.Verdict(v.INCONCLUSIVE, text, f"no sweep point blew up; needs {NAC_1_NEEDS}")
    return v.Verdict(v.INCONCLUSIVE, text, "it blew up at fewer than half the sweep points")


@rule("NAC-2a")
def nac_2a(ev: Evidence) -> v.Verdict:
    nofix, fixes = sweep_runs(ev, "nofix"), sweep_runs(ev, "fixes")
    text = f"with the fixes, diverged per sweep point: {_counts(fixes)}"
    wild = [p for p, r in nofix.items() if _diverged(r) >= 4]
    if not wild:
        return v.Verdict(v.INCONCLUSIVE, text, "without the fixes θ blew up at no sweep point")
    if any(_diverged(fixes[p]) >= 4 for p in wild):
        return v.Verdict(v.FAILS, text, "the fixes did not stop the blow-up in our runs")
    if all(_diverged(fixes[p]) <= 1 for p in wild):
        return v.Verdict(v.HOLDS, text)
    return v.Verdict(v.INCONCLUSIVE, text, "the seeds split where it blew up")


@rule("NAC-7")
def nac_7(ev: Evidence) -> v.Verdict:
    sweep = sweep_runs(ev, "fixes")
    counts = [_diverged(r) for r in sweep.values()]
    intervals = []
    for runs in sweep.values():
        finished = [r for r in runs if r["reward_after"] is not None]
        change = [r["reward_after"] - r["reward_before"] for r in finished]
        intervals.append(v.mean_interval(change) if len(change) >= 2 else None)
    shown = ", ".join(
        f"α {a:g} ε_A {e:g}: {m:+.5f} [{lo:+.5f}, {hi:+.5f}]"
        for (a, e), (m, lo, hi) in zip(sweep, [i or (np.nan,) * 3 for i in intervals])
    )
    falling = [sum(bool(r.get("falls_after")) for r in runs) for runs in sweep.values()]
    text = (
        f"with the fixes, COP reward change per sweep point: {shown}; diverged {counts}; "
        f"learned policies that fall {falling}"
    )
    known = [i for i in intervals if i is not None]
    apart = any(a[2] < b[1] or b[2] < a[1] for a in known for b in known)
    if max(counts) - min(counts) >= 3 or max(falling) - min(falling) >= 3 or apart:
        return v.Verdict(v.HOLDS, text)
    return v.Verdict(v.FAILS, text, "every sweep point gave the same outcome within its interval")


def scaled(ev: Evidence) -> dict:
    """The fixes runs' θ scaled up at the sweep's α whose learned gaits stand like the
    thesis' (`nac_experiments --scaled`: `nac_scaled.json`; `thesis_point`), with the
    other points' results under "points".

    Raises:
      MissingEvidence: If the file is missing or a point holds fewer than 5 runs.
    """
    path = os.path.join(ev.results, "study", "nac", "nac_scaled.json")
    found = None
    if os.path.isfile(path):
        with open(path, encoding="utf-8") as f:
            found = json.load(f)
    if not found or any(len(p["runs"]) < 5 for p in found.get("points", [{"runs": []}])):
        raise MissingEvidence(
            "NAC θ scaled: python -m baselines.experiments.nac_experiments "
            "--output_dir=results/study/nac --scaled"
        )
    return {**found, **thesis_point(found["points"])}


def thesis_point(points: list[dict]) -> dict:
    """The point (α, its runs) the thesis' claims about its learned θ are judged at: the
    largest α at which at most 1 of 5 learned policies falls in its evaluation (the
    thesis' learned gait did not fall; the largest such α gives learning the most room).
    None standing: the smallest α."""
    standing = [p for p in points if sum(r["learned_falls"] > 0 for r in p["runs"]) <= 1]
    return (
        max(standing, key=lambda p: p["alpha"])
        if standing
        else min(points, key=lambda p: p["alpha"])
    )


# NAC-5/6: θ "large enough to change the gait noticeably" is read as moving the left
# hip-roll rate by more than 20 % of the CPG's own (RMS over a cycle): c* per run.
NOTICEABLE = 0.2


def _c_star(run: dict) -> float | None:
    """The smallest scale whose hip-roll change passes `NOTICEABLE` (None: none does)."""
    return next(
        (p["c"] for p in run["scaled"] if p["c"] * run["hip_roll_change"] > NOTICEABLE), None
    )


def _at(found: dict) -> str:
    falls = [sum(r["learned_falls"] > 0 for r in p["runs"]) for p in found["points"]]
    shown = ", ".join(f"α {p['alpha']:g}: {f}/5" for p, f in zip(found["points"], falls))
    return f"at α {found['alpha']:g} (learned gaits that fall per α: {shown})"


@rule("NAC-4b")
def nac_4b(ev: Evidence) -> v.Verdict:
    found = scaled(ev)
    change = [r["hip_roll_change"] for r in found["runs"]]
    others = "; ".join(
        f"α {p['alpha']:g}: " + ", ".join(f"{r['hip_roll_change']:.2f}" for r in p["runs"])
        for p in found["points"]
    )
    text = (
        f"RMS of the learned term over the CPG's own left hip-roll rate {_at(found)}, per seed: "
        + ", ".join(f"{c:.2f}" for c in change)
        + f" (every α: {others})"
    )
    why = "the learned term moves the hip-roll rate by > 30 %"
    return v.split([c < 0.1 for c in change], [c > 0.3 for c in change], text, why)


def _scaled_text(found: dict, key: str) -> str:
    zero = found["theta_zero"][key]
    rows = []
    for run in found["runs"]:
        points = ", ".join(
            f"{p['c']:g}: {p[key]:+.4f}{' F' * bool(p['falls'])}" for p in run["scaled"]
        )
        rows.append(f"seed {run['seed']} (c* {_c_star(run)}) {points}")
    return f"{_at(found)}, {key} at θ = 0 {zero:+.4f}; scaled θ (F: a fall): " + "; ".join(rows)


@rule("NAC-5a")
def nac_5a(ev: Evidence) -> v.Verdict:
    """The reward half of NAC-5: worse than at θ = 0 at c 20 and 50 (split out of NAC-5's
    criterion after the third reading of 2026-11-28, where a fall at c 50 was part of it)."""
    found = scaled(ev)
    zero = found["theta_zero"]["reward_per_step"]
    flags = []
    for run in found["runs"]:
        at = {p["c"]: p for p in run["scaled"]}
        flags.append(all(at[c]["reward_per_step"] < zero for c in (20.0, 50.0)))
    text = _scaled_text(found, "reward_per_step")
    return v.majority(flags, text + "; worse at c 20 and 50")


@rule("NAC-5b")
def nac_5b(ev: Evidence) -> v.Verdict:
    """The fall half of NAC-5: a fall at c 50 (its criterion's own fall condition, judged
    apart after the third reading of 2026-11-28: the reward per step spreads a fall's
    penalty over the steps before it, so it hides falls); beside, not judged, falls at some
    and at every c ≥ c*."""
    found = scaled(ev)
    at_50, some, every, rows = [], [], [], []
    for run in found["runs"]:
        c_star = _c_star(run)
        after = [p for p in run["scaled"] if c_star is not None and p["c"] >= c_star]
        at_50.append(next(p["falls"] for p in run["scaled"] if p["c"] == 50.0) > 0)
        some.append(any(p["falls"] for p in after))
        every.append(bool(after) and all(p["falls"] for p in after))
        falls = ", ".join(f"{p['c']:g}: {p['falls']}" for p in run["scaled"])
        rows.append(f"seed {run['seed']} (c* {c_star}) {falls}")
    n = len(found["runs"])
    text = (
        f"{_at(found)}, evaluations that fall (initial states 100-104) per scale c: "
        + "; ".join(rows)
        + f"; beside, not judged: a fall at some c ≥ c* {sum(some)} of {n} seeds, at every "
        f"c ≥ c* {sum(every)} of {n}; a fall at c 50"
    )
    return v.majority(at_50, text)


@rule("NAC-6")
def nac_6(ev: Evidence) -> v.Verdict:
    found = scaled(ev)
    zero = found["theta_zero"]["task_reward_per_step"]
    same = []
    for run in found["runs"]:
        c_star = _c_star(run)
        changes = [
            abs(p["task_reward_per_step"] - zero) / abs(zero)
            for p in run["scaled"]
            if c_star is not None and p["c"] >= c_star
        ]
        same.append(bool(changes) and max(changes) <= 0.1)
    text = _scaled_text(found, "task_reward_per_step") + "; within 10 % at every c ≥ c*"
    text += f": {sum(same)} of 5 seeds"
    return v.split(same, [not s for s in same], text, "the reward dropped > 10 %")


# CEM against the NAC (Sec. 6.3 / 7.1.2): judged here, where the NAC's evidence is.
@rule("CEM-14b")
def cem_14b(ev: Evidence) -> v.Verdict:
    hand = chapter6.hand_tuned_trial(ev)["distance_m"]
    d = chapter6.values(ev, "K10_n0.8_e2", chapter6.best)
    gain = v.paired_greater(d, [hand] * len(d), "D − D_hand, K10_n0.8_e2")
    nac = nac_3(ev)
    if gain.verdict != v.HOLDS:
        return v.Verdict(v.FAILS, gain.evidence, "CEM did not beat the hand-tuned gait")
    verdict = v.HOLDS if nac.verdict == v.HOLDS else v.INCONCLUSIVE
    return v.Verdict(verdict, f"{gain.evidence}; NAC-3's rule {nac.verdict}", nac.why)


@rule("CPG-4")
def cpg_4(ev: Evidence) -> v.Verdict:
    half = ev.computed("sole_half_length_m")
    distances = [-r["reward_before"] for r in nac_runs(ev, "darwin_balance", "fixes")]
    shown = ", ".join(f"{d * 100:.1f}" for d in distances)
    text = (
        f"CPG alone: mean COP-to-sole-centre distance per run ({shown}) cm, sole "
        f"half-length {half * 100:.2f} cm"
    )
    return v.majority([d < 0.2 * half for d in distances], text + "; below 20 % of it")


@rule("CPG-1a")
def cpg_1a(ev: Evidence) -> v.Verdict:
    fell = [t["fell"] for t in ev.computed("hand_tuned_trials")]
    return v.majority([not f for f in fell], "hand-tuned gait, 1000 steps: no fall")


def _smallest_d(ev: Evidence) -> tuple[float, dict[int, float]]:
    hand = chapter6.hand_tuned_trial(ev)["distance_m"]
    by_seed: dict[int, float] = {}
    for setting in chapter6.TABLE:
        for r in ev.cem(setting):
            by_seed[r.seed] = min(by_seed.get(r.seed, np.inf), chapter6.best(r))
    return hand, by_seed


@rule("CPG-1b")
def cpg_1b(ev: Evidence) -> v.Verdict:
    """Nearly walks in place: |D_hand| at most a fifth of each seed's smallest D (revised
    after the second reading of 2026-11-27, where a backward D_hand met it by construction).
    Beside, not judged: the smallest D over |D_hand| (the thesis' 19× is a ratio of two
    forward distances, 0.068321 / 0.003596 u.d.; shown after the third reading of
    2026-11-28)."""
    hand, by_seed = _smallest_d(ev)
    flags = [abs(hand) <= d / 5 for d in by_seed.values()]
    smallest = ", ".join(f"{d:.3f}" for d in by_seed.values())
    way = f"{abs(hand) * 100:.2f} cm {'backwards' if hand < 0 else 'forwards'}"
    found = v.majority(
        flags,
        f"the hand-tuned gait walks {way} in 1000 steps; |D_hand| ≤ D/5 against each seed's "
        f"smallest D ({smallest} m)",
    )
    ratio = min(by_seed.values()) / abs(hand)
    return v.Verdict(
        found.verdict,
        f"{found.evidence}; not judged: the smallest D is {ratio:.1f} × |D_hand| (the thesis' "
        "19×, 0.068321 / 0.003596 u.d., divides two forward distances, which a backward "
        "hand-tuned gait does not give: not testable here, as CEM-11b)",
        found.why,
    )


def cpg_1b_signed(ev: Evidence) -> v.Verdict:
    """CPG-1b as first written: D_hand ≤ D/5, a backward D_hand meeting it (`revisions`)."""
    hand, by_seed = _smallest_d(ev)
    flags = [hand <= 0 or hand <= d / 5 for d in by_seed.values()]
    return v.majority(flags, f"D_hand {hand:+.4f} m ≤ smallest D / 5")


@rule("CPG-2")
def cpg_2(ev: Evidence) -> v.Verdict:
    worst = ev.computed("cpg")["phase_shift_rad"]
    return v.Verdict(
        v.HOLDS if worst <= SAME_TARGET else v.FAILS,
        f"max |right(t) − left(t + T/2)| over the hand-tuned and K 50 gaits: {worst:.2e} rad",
    )


@rule("CPG-3")
def cpg_3(ev: Evidence) -> v.Verdict:
    shares = [g["perturbed_broken"] for g in chapter6._around(ev)]
    text = f"share of 1-deg perturbations that fall or halve the distance: {shares}"
    return v.majority([s >= 0.25 for s in shares], text)


@rule("CPG-5")
def cpg_5(ev: Evidence) -> v.Verdict:
    raised = ev.computed("cpg")["range_change_when_raised_rad"]
    joints = {name: np.flatnonzero(np.abs(np.array(c)) > 1e-9) for name, c in raised.items()}
    idle = [name for name, j in joints.items() if not j.size]
    narrowing = [name for name, c in raised.items() if np.any(np.array(c) < -1e-9)]
    text = (
        f"amplitudes raised one at a time: {len(raised) - len(idle)} change their joints' "
        f"swing ranges, {len(idle)} none ({idle or 'none'}); {len(narrowing)} narrow a range "
        f"({narrowing or 'none'}: a joint's primitives add with different phases)"
    )
    if idle:
        return v.Verdict(v.FAILS, text, "an amplitude moves no joint")
    return v.Verdict(v.HOLDS, text)


@rule("CPG-6")
def cpg_6(ev: Evidence) -> v.Verdict:
    ev.cem("K10_n0.8_e2")  # the learned gaits it covers must be there
    worst = ev.computed("cpg")["periodicity_rad"]
    return v.Verdict(
        v.HOLDS if worst <= SAME_TARGET else v.FAILS,
        f"max |z(t + T) − z(t)| after two cycles: {worst:.2e} rad",
    )


def _progress(ev: Evidence, config: str) -> list:
    """The logged windows (`progress.csv`: θ's norm, max |F|) of a NAC configuration's runs."""
    nac_runs(ev, "darwin_balance", config)  # five runs or MissingEvidence
    root = os.path.join(ev.results, *NAC, "darwin_balance")
    return [pd.read_csv(os.path.join(root, f"{config}_seed{s}", "progress.csv")) for s in range(5)]


@rule("NAC-2b")
def nac_2b(ev: Evidence) -> v.Verdict:
    flags, shown = [], []
    for p in _progress(ev, "fixes"):
        norm = p["theta_norm"].to_numpy()
        q = len(norm) // 4
        last = abs(norm[-1] - norm[-q - 1]) / max(abs(norm[-q - 1]), 1e-12)
        w = max(len(norm) // 10, 1)
        steady = min(
            abs(norm[i + w] - norm[i]) / max(abs(norm[i]), 1e-12) for i in range(q, len(norm) - w)
        )
        flags.append(last >= 0.05 and steady < 0.05)
        shown.append(f"{last:.2f}/{steady:.2f}")
    text = f"|θ|'s change over the last quarter / its steadiest tenth, per seed: {shown}"
    return v.majority(flags, text)


def _f_grows(ev: Evidence, config: str) -> tuple[list[bool], list[str]]:
    """Per seed of a NAC configuration: whether max |F|'s mean over the last quarter of
    its windows exceeds the first quarter's, and the two means as text."""
    flags, shown = [], []
    for p in _progress(ev, config):
        f = p["max_abs_F"].to_numpy()
        q = max(len(f) // 4, 1)
        first, last = f[1 : q + 1].mean(), f[-q:].mean()  # window 0 is before any update
        flags.append(last > first)
        shown.append(f"{first:.3g}→{last:.3g}")
    return flags, shown


@rule("NAC-4a")
def nac_4a(ev: Evidence) -> v.Verdict:
    flags, shown = _f_grows(ev, "fixes")
    found = v.majority(flags, f"max |F| per window, first → last quarter: {shown}")
    try:  # beside it, the α at which NAC-4b is judged (a sixth reader's request)
        point = scaled(ev)
        config = point_name("fixes", point["alpha"], point["eps_a"])
        grows, values = _f_grows(ev, config)
    except MissingEvidence:
        return found
    beside = (
        f"; at α {point['alpha']:g} (ε_A {point['eps_a']:g}), where NAC-4b is judged: "
        f"{values}: {sum(grows)} of {len(grows)} seeds"
    )
    return dataclasses.replace(found, evidence=found.evidence + beside)


# CPG-8's three features, judged apart (split after the fourth reading of 2026-11-28): each
# part is the rule first written for all three, on its own raise.
RAISED = {"CPG-8a": ("compass_hip", "step_length_m"), "CPG-8b": ("knee", "swing_height_m")}
RAISED["CPG-8c"] = ("balancing_hip", "sway_m")


def raised_part(ev: Evidence, claim_id: str) -> v.Verdict:
    """One raised amplitude against the hand-tuned gait (`RAISED`): the paired difference of
    its feature, inconclusive where a raised gait fell or a trial has no measure."""
    name, feature = RAISED[claim_id]
    found = ev.computed("raised_amplitudes")
    hand, raised = found["hand_tuned"], found[name]
    fell = sum(t["fell"] for t in raised)
    pairs = [(a[feature], b[feature]) for a, b in zip(raised, hand)]
    pairs = [(a, b) for a, b in pairs if np.isfinite(a) and np.isfinite(b)]
    label = f"{feature}, {name} raised − hand-tuned ({fell} falls)"
    if len(pairs) < len(hand):
        text = f"{label}: {len(hand) - len(pairs)} trials without a measure (no touchdown)"
        why = f"the raised gait fell in {fell} of {len(raised)} trials: a raise the thesis "
        return v.Verdict(v.INCONCLUSIVE, text, why + "does not give (seed L1148; ours: `RAISED`)")
    verdict = v.paired_greater([a for a, _ in pairs], [b for _, b in pairs], label)
    if fell and verdict.verdict == v.HOLDS:
        return v.Verdict(v.INCONCLUSIVE, verdict.evidence, "a raised gait fell")
    return verdict


for _id in RAISED:
    rule(_id)(lambda ev, _id=_id: raised_part(ev, _id))

"""Every number the thesis publishes, with ours beside it.

A published number is one of:
  * a result: ours comes from the same setting, measured the same way, with its interval
    over seeds; distances compare as a reading only (the thesis' u.d. against our metres,
    a Webots robot against a MuJoCo one), so the ratio is labelled so;
  * an input: a setting or a fact of the robot or the model that the benchmark takes as
    given (its place in the code is said), not a result to reproduce;
  * a claim (a published row that states an outcome in words): judged in the catalog,
    under the id that absorbed it.
"""

from __future__ import annotations

import numpy as np

from analysis import published
from analysis.study import chapter4, chapter6
from analysis.study import verdicts as v
from analysis.study.evidence import Evidence, MissingEvidence

FIELDS = (
    "id",
    "quantity",
    "setting",
    "published",
    "unit",
    "source",
    "role",
    "ours",
    "ours_ci95",
    "seeds",
    "comparison",
)
READING = "a reading: u.d. taken as m, a Webots robot against our MuJoCo model"

# Inputs: settings and facts the benchmark takes as given (where they live in the code).
INPUTS = {
    "CR-N01": "the crawler's MDP (baselines/tabular/models.py)",
    "CR-N02": "the crawler's MDP (cpg_suite/crawler.py GRID)",
    "CR-N03": "the crawler's MDP (baselines/tabular/models.py)",
    "CR-N04": "a setting (γ of every tabular run)",
    "CR-N05": "the Tokic reward table (cpg_suite/data/tokic_rewards.json)",
    "CR-N13": "a setting of Fig. 4.4 (30 iterations)",
    "CR-N15": "a setting (approach 1b's exploration moves)",
    "CR-N18": "a setting (the ε schedule)",
    "CR-N19": "a setting (the ε schedule)",
    "CR-N20": "a setting (the ε schedule)",
    "PB-N01": "the pole's state space (cpg_suite/pole.py)",
    "PB-N02": "the pole's state space (cpg_suite/pole.py)",
    "PB-N03": "the pole's start (cpg_suite/pole.py)",
    "PB-N04": "the pole's reward (cpg_suite/pole.py)",
    "PB-N12": "a setting (γ)",
    "PB-N16": "a setting (the force study's horizon)",
    "PB-N17": "a plotting convention (a fall shows as 1.5 rad)",
    "PB-N18": "a setting (the α study's horizon)",
    "DW-N01": "a robot fact (docs/darwin_op_model.md)",
    "DW-N02": "a robot fact (docs/darwin_op_model.md)",
    "DW-N03": "a robot fact (docs/darwin_op_model.md)",
    "DW-N04": "a CPG constant (cpg_suite/cpg.py)",
    "DW-N05": "the hand-tuned amplitudes (cpg_suite/cpg.py PRESETS)",
    "NAC-N01": "a setting of the NAC (baselines/nac.py)",
    "NAC-N02": "a setting of the NAC (baselines/nac.py)",
    "NAC-N03": "a setting of the NAC (baselines/nac.py)",
    "NAC-N04": "a setting of the NAC (baselines/nac.py)",
    "CEM-N04": "a setting (1000-step trials)",
    "CEM-N05": "a setting (K and Σ₀ of CEM)",
}


def _per_seed(values: list[float], fmt: str = "{:.4f}") -> dict:
    mean, low, high = v.mean_interval(values)
    return {
        "ours": fmt.format(mean),
        "ours_ci95": f"[{fmt.format(low)}, {fmt.format(high)}]",
        "seeds": len(values),
    }


def _distance(values: list[float], published_value: float) -> dict:
    row = _per_seed(values)
    ratio = float(np.mean(values)) / published_value
    return {**row, "comparison": f"ratio {ratio:.2f} ({READING})"}


def _table6_3(setting: str, which: str):
    def ours(ev: Evidence) -> dict:
        runs = ev.cem(setting)
        value, rnd, _, _ = published.TABLE6_3[setting]
        if which == "distance":
            row = _distance([chapter6.best(r) for r in runs], value)
            trials = np.mean([chapter6.best_trial(r) for r in runs])
            return {**row, "comparison": f"{row['comparison']}; best single trial {trials:.4f}"}
        rounds = [chapter6.best_round(r) for r in runs]
        row = _per_seed(rounds, "{:.1f}")
        return {**row, "comparison": f"rounds of ours {rounds}; the thesis' one run: {rnd}"}

    return ours


def _runtime(ev: Evidence) -> dict:
    parts = []
    for setting in list(published.TABLE6_3)[:10]:
        runs = ev.cem(setting)
        k = runs[0].population // 10
        parts.append(f"{k * np.median([chapter6.best_round(r) for r in runs]):g}")
    return {"ours": ", ".join(parts), "comparison": "median round of the best × K/10, per row"}


def _hand(ev: Evidence) -> dict:
    d = chapter6.hand_tuned_trial(ev)["distance_m"]
    return {"ours": f"{d:.6f}", "seeds": 1, "comparison": f"ratio {d / 0.003596:.2f} ({READING})"}


def _hand_lateral(ev: Evidence) -> dict:
    t = chapter6.hand_tuned_trial(ev)
    score = t["distance_m"] - abs(t["lateral_m"])
    return {"ours": f"{score:.6f}", "seeds": 1, "comparison": f"distance − |lateral|; {READING}"}


def _k20_to_055(ev: Evidence) -> dict:
    pairs = zip(ev.cem("K20_n0.8_e2"), ev.cem("K10_n0.8_e2"))
    rounds = [chapter6.rounds_to(a, chapter6.best(b)) for a, b in pairs]
    return {
        "ours": ", ".join(f"{r:g}" for r in rounds),
        "seeds": len(rounds),
        "comparison": "rounds for K 20 to reach the same seed's K 10 best (the thesis: "
        "0.55 u.d., its K 10 best, in 8 rounds)",
    }


def _fall_onset(ev: Evidence) -> dict:
    def first(setting):
        out = []
        for r in ev.cem(setting):
            fell = np.flatnonzero(r.progress["mean_fell"].to_numpy())
            out.append(f"{fell[0] + 1}" if fell.size else "none")
        return "/".join(out)

    return {
        "ours": f"elite 3: {first('K10_n0_e3')}; elite 4: {first('K10_n0_e4')}",
        "comparison": "first round whose mean fell, per seed",
    }


def _fall_rounds(ev: Evidence) -> dict:
    falls = [chapter6.mean_falls(r) for r in ev.cem("K10_n0.8_e2")]
    return {
        **_per_seed(falls, "{:.1f}"),
        "comparison": "rounds whose mean fell (the thesis names round 34 as an example)",
    }


def _amplitudes(setting: str):
    def ours(ev: Evidence) -> dict:
        best = np.array([list(r.best_params["amplitudes"].values()) for r in ev.cem(setting)])
        return {
            "ours": "[" + ", ".join(f"{x:.2f}" for x in best.mean(axis=0)) + "]",
            "seeds": len(best),
            "comparison": "mean over seeds of each run's best amplitudes (deg)",
        }

    return ours


def _toy_residual(ev: Evidence) -> dict:
    return {**_per_seed(chapter6.toy(ev, 0.8)), "comparison": "same units (a plane)"}


def _toy_start(ev: Evidence) -> dict:
    cost = ev.computed("toy")["start_cost"]
    return {"ours": f"{cost:.4f}", "comparison": "same units (a plane)"}


def _first_moves(ev: Evidence) -> dict:
    moves = " -> ".join(str(tuple(m)) for m in ev.computed("tokic")["first_moves"])
    return {"ours": moves, "comparison": "see CR-19"}


def _action_values(ev: Evidence) -> dict:
    values = ev.computed("tokic")["action_values_at_1_0_sweep2"]
    return {"ours": ", ".join(f"{q:g}" for q in values), "comparison": "sorted; see CR-19"}


# Published results we set no figure beside, and why.
NO_FIGURE = {
    "CR-N11": "the run it was measured over is not given (CR-2: not testable); the Tokic "
    "table's own cycle earns 53 reward units in 6 moves (computed.json)",
}


def _quiet_spell(ev: Evidence) -> dict:
    steps = chapter4.pole(ev, "alpha0.1")["quietest_window_step"].astype(int).tolist()
    return {
        "ours": ", ".join(str(x) for x in steps),
        "seeds": len(steps),
        "comparison": "α 0.1: the first step of the quietest 1000-step window in 8000-16000, "
        "per seed (see PB-14b)",
    }


OURS = {
    **{
        published._TABLE6_3_IDS[s][i]: _table6_3(s, w)
        for s in published.TABLE6_3
        for i, w in ((0, "distance"), (1, "round"))
    },
    "CEM-N01": _toy_start,
    "CEM-N03": _toy_residual,
    "CEM-N24": _k20_to_055,
    "CEM-N27": _runtime,
    "CEM-N28": _amplitudes("K10_n0.8_e2"),
    "CEM-N29": _amplitudes("K50_n0.8_e2"),
    "CEM-N35": _fall_onset,
    "CEM-N36": _fall_rounds,
    "DW-N06": _hand,
    "DW-N07": _hand_lateral,
    "CR-N08": _action_values,
    "CR-N09": _first_moves,
    "PB-N21": _quiet_spell,
    **chapter4.NUMBERS,
}


def _claim_owner(rows: list[dict]) -> dict[str, str]:
    owner = {}
    for row in rows:
        for i in row["merged"].split():
            owner[i] = row["id"]
    return owner


def table(ev: Evidence, catalog_rows: list[dict]) -> list[dict]:
    """A row per published number, in `published.csv` order."""
    owner = _claim_owner(catalog_rows)
    out = []
    for pid, p in published.NUMBERS.items():
        row = {
            "id": pid,
            "quantity": p["quantity"],
            "setting": p["setting"],
            "published": p["value"],
            "unit": p["unit"],
            "source": p["source"],
        }
        out.append({**row, **_ours(pid, p, ev, owner)})
    return out


def _ours(pid: str, p: dict, ev: Evidence, owner: dict) -> dict:
    if pid in INPUTS:
        return {"role": "input", "comparison": INPUTS[pid]}
    if p["kind"] == "claim":
        return {"role": "claim", "comparison": f"judged as {owner.get(pid, '(not in catalog)')}"}
    if pid in NO_FIGURE:
        return {"role": "result", "comparison": f"no figure of ours: {NO_FIGURE[pid]}"}
    if pid not in OURS:
        return {"role": "result", "comparison": "no figure of ours yet"}
    try:
        return {"role": "result", **OURS[pid](ev)}
    except MissingEvidence as e:
        return {"role": "result", "comparison": f"runs missing: {e}"}

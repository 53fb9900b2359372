r"""Figures of the study's kinds and a markdown report, from run directories.

  python -m analysis.report --runs=DIR --out=DIR

Writes into `--out` (PNG, matplotlib; `pip install 'cpg-suite[plots]'`):
  * `cem_rounds.png` — best and mean-vector distance per round, rounds with falls marked,
    one panel per CEM/CMA-ES configuration (thesis Fig. 6.2-6.6);
  * `joint_trajectories.png` — hip, knee and ankle pitch of both legs over two strides,
    hand-tuned gait vs the best gait found (thesis Fig. 6.9): of the board's runs, the best
    in-sample trial tried again (summary.json's `in_sample`, which verify re-makes); with
    none tried again (a local run verify never read), the training record, marked unchecked;
  * `rms_error.png` — RMS error of the values per move, real-time crawler learners (Fig. 4.6);
  * `pole_angles.png` — pole angle traces: 0.5 N vs 4 N, and the α sweep (Fig. 4.9-4.10);
  * `value_evolution.png` — values of the six cycle states, value vs policy iteration
    (Fig. 4.4), from `fig4_4.csv`;
  * with `--gaits`: `gaits_filmstrip.png` — the hand-tuned and the best gait side by side,
    a quarter stride between snapshots (thesis Fig. 6.8), and a video of each
    (`hand_tuned.mp4`, `gait_best.mp4`; GIF without ffmpeg), rendered headlessly;
and `report.md` embedding the figures and the leaderboards (computed with
`analysis.leaderboard` into the same folder). The study's claims are judged in one place,
`python -m analysis.study` (results/study). Figures whose data are missing are skipped
and listed in the report; malformed run files are skipped, never a crash.
"""

from __future__ import annotations

if __name__ == "__main__":  # this program never renders: no OpenGL backend, no GLFW warning
    from cpg_suite import cli

    cli.without_rendering()

import csv
import dataclasses
import io
import json
import math
import os
import subprocess
import sys
from collections import defaultdict

import numpy as np
from absl import flags

from analysis import leaderboard
from cpg_suite import cli
from cpg_suite.protocol import admission
from cpg_suite.protocol import files as run_files

POLICY_LEARNERS = ("ppo", "ppo_mjx")  # methods whose runs train a policy, not a gait
# s: the most a helper program (a gait's joint targets, its rendering) may take before the
# report gives up on it (a choice: each takes seconds to a minute on 2 cores).
_SUBPROCESS_TIMEOUT_S = 600


def _plt():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def _save(plt, fig, out: str, name: str) -> str:
    """Lays out, writes `out/name` and closes the figure; returns the path."""
    fig.tight_layout()
    path = os.path.join(out, name)
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def _read_csv(path: str) -> list[dict]:
    """A run's CSV table, read as the board reads run files (`run_files.read_text`: a regular
    file of bounded size, never a pipe or a device); [] if it cannot be."""
    try:
        return list(csv.DictReader(io.StringIO(run_files.read_text(path))))
    except (OSError, ValueError, csv.Error):
        return []


def cem_rounds(found: list[dict], out: str) -> str | None:
    """Best and mean-vector distance per round with falls marked, first seed per config."""
    panels = {}
    for run in sorted(found, key=lambda r: (r["method"], r["config"], r["seed"] or 0)):
        if run["method"] in ("cem", "cmaes") and run["task"] == "darwin_walk":
            key = f"{run['method']} {run['config']}"
            if key not in panels:
                rows = _read_csv(os.path.join(run["dir"], "progress.csv"))
                if rows:
                    panels[key] = rows
    if not panels:
        return None
    plt = _plt()
    cols = min(4, len(panels))
    nrows = int(np.ceil(len(panels) / cols))
    fig, axes = plt.subplots(nrows, cols, figsize=(4 * cols, 3 * nrows), squeeze=False)
    for ax, (name, rows) in zip(axes.flat, panels.items()):
        r = np.array([int(x["round"]) for x in rows])
        best = np.array([float(x["best_distance_m"]) for x in rows])
        ax.plot(r, best, label="best sample", color="tab:blue")
        if all(x["mean_distance_m"] != "" for x in rows):  # CMA-ES has no mean sample
            mean = np.array([float(x["mean_distance_m"]) for x in rows])
            fell = np.array([int(x["mean_fell"]) for x in rows]) > 0
            ax.plot(r, mean, label="mean vector", color="tab:orange")
            ax.scatter(
                r[fell], mean[fell], marker="x", color="red", label="mean vector fell", zorder=3
            )
        ax.set_title(name, fontsize=9)
        ax.set_xlabel("round")
        ax.set_ylabel("distance (m)")
    for ax in list(axes.flat)[len(panels) :]:
        ax.axis("off")
    axes.flat[0].legend(fontsize=7)
    return _save(plt, fig, out, "cem_rounds.png")


def _validation_rows(run: dict) -> list[dict]:
    """The progress rows of a run that carry a validation score (with `physics_steps` from
    the summary's physics steps per env step where a row has env steps only: PPO on MJX)."""
    rows = [r for r in _read_csv(os.path.join(run["dir"], "progress.csv")) if r.get("validation_m")]
    summary = run["summary"]
    if summary.get("env_steps") and summary.get("sim_steps"):
        per_env_step = summary["sim_steps"] / summary["env_steps"]
        for r in rows:
            if not (r.get("sim_steps") or r.get("physics_steps")) and r.get("env_steps"):
                r["physics_steps"] = float(r["env_steps"]) * per_env_step
    return rows


def _physics_steps(row: dict) -> float:
    """A progress row's training physics steps (optimizers: `sim_steps`; PPO: `physics_steps`)."""
    return float(row.get("sim_steps") or row["physics_steps"])


def _policy_learner(run: dict) -> bool:
    """Whether a run trained a policy (PPO, PPO on MJX) rather than searched gaits."""
    return run["method"] in POLICY_LEARNERS


def score_vs_budget(found: list[dict], out: str) -> str | None:
    """Validation score of the mean against the simulation budget, one line per
    configuration (the mean over its seeds, round by round); the small Table 6.3 settings
    (fewer than 2,000 training trials) in thin grey lines."""
    groups = defaultdict(list)
    for run in found:
        if not run["task"].startswith("darwin_walk"):
            continue
        rows = _validation_rows(run)
        if rows:
            trials = math.inf if _policy_learner(run) else run["summary"].get("evaluations") or 0
            groups[(run["task"], run["method"], run["config"])].append((rows, trials))
    if not groups:
        return None
    plt = _plt()
    fig, ax = plt.subplots(figsize=(8, 4.5))
    for (task, method, config), seeds in sorted(groups.items()):
        n = min(len(rows) for rows, _ in seeds)
        steps = np.mean([[_physics_steps(r) / 1e6 for r in rows[:n]] for rows, _ in seeds], 0)
        values = np.mean([[float(r["validation_m"]) for r in rows[:n]] for rows, _ in seeds], 0)
        if min(trials for _, trials in seeds) < 2000:
            ax.plot(steps, values, color="0.75", linewidth=0.8)
            continue
        label = f"{method} {config} ({task.replace('darwin_walk', 'walk')}, {len(seeds)} seeds)"
        ax.plot(steps, values, marker="o", markersize=3, label=label)
    ax.set_xlabel("training budget (million physics steps)")
    ax.set_ylabel("validation success-weighted distance (m)")
    ax.set_title("mean over seeds; grey: Table 6.3 settings with K < 50", fontsize=9)
    if ax.get_legend_handles_labels()[1]:
        ax.legend(fontsize=7)
    return _save(plt, fig, out, "score_vs_budget.png")


def learning_curves(found: list[dict], out: str) -> str | None:
    """Deep-RL learning curves: validation score against training physics steps, one panel
    per training tier, a thin line per seed and a thick line for the mean over seeds of
    each configuration (the PPO and PPO-on-MJX action spaces)."""
    groups = defaultdict(list)
    for run in found:
        if not _policy_learner(run):
            continue
        rows = _validation_rows(run)
        if rows:
            groups[(run["task"], f"{run['method']} {run['config']}")].append(rows)
    if not groups:
        return None
    plt = _plt()
    tasks = sorted({task for task, _ in groups})
    fig, axes = plt.subplots(1, len(tasks), figsize=(5 * len(tasks), 4), squeeze=False, sharey=True)
    for ax, task in zip(axes.flat, tasks):
        for k, config in enumerate(sorted(c for t, c in groups if t == task)):
            seeds, color = groups[(task, config)], f"C{k}"
            for rows in seeds:
                steps = [_physics_steps(r) / 1e6 for r in rows]
                values = [float(r["validation_m"]) for r in rows]
                ax.plot(steps, values, color=color, lw=0.6, alpha=0.5)
            n = min(len(rows) for rows in seeds)
            steps = [_physics_steps(r) / 1e6 for r in seeds[0][:n]]
            mean = np.mean([[float(r["validation_m"]) for r in rows[:n]] for rows in seeds], 0)
            label = f"{config} ({len(seeds)} seed{'s' * (len(seeds) > 1)})"
            ax.plot(steps, mean, color=color, lw=2, label=label)
        ax.set_title(task, fontsize=9)
        ax.set_xlabel("training budget (million physics steps)")
        ax.legend(fontsize=7)
    axes.flat[0].set_ylabel("validation success-weighted distance (m)")
    return _save(plt, fig, out, "learning_curves.png")


def _track_configurations(found: list[dict]) -> dict[str, dict[str, np.ndarray]]:
    """Per budget track, each ranked-or-provisional DARwIn configuration's (runs × tiers)
    test scores (a run must have a card with every tier of the current version)."""
    groups = defaultdict(list)
    for run in found:
        test = run["summary"].get("test")
        if isinstance(test, dict) and set(leaderboard.TIERS) <= set(test.get("tiers", {})):
            groups[(run["task"], run["method"], run["config"])].append(run["summary"])
    tracks = defaultdict(dict)
    for (task, method, config), summaries in sorted(groups.items()):
        track = leaderboard.budget_track(summaries)
        if track:
            label = f"{method} {config} ({task}, {len(summaries)} seeds)"
            tracks[track][label] = leaderboard.score_matrix([s["test"] for s in summaries])
    return tracks


def performance_profiles(found: list[dict], out: str) -> str | None:
    """Per budget track, the fraction of runs × tiers whose test score exceeds τ, against τ
    (rliable's performance profile; docs/protocol.md#ranking)."""
    tracks = _track_configurations(found)
    if not tracks:
        return None
    plt = _plt()
    fig, axes = plt.subplots(1, len(tracks), figsize=(6 * len(tracks), 4), squeeze=False)
    for ax, (track, configurations) in zip(axes[0], sorted(tracks.items())):
        top = max(float(np.max(s)) for s in configurations.values())
        taus = np.linspace(0.0, max(top, 1e-3) * 1.05, 200)
        for label, scores in configurations.items():
            ax.plot(taus, [(scores.ravel() > tau).mean() for tau in taus], label=label)
        ax.set_xlabel("τ: test success-weighted distance (m)")
        ax.set_ylabel("fraction of runs × tiers above τ")
        ax.set_title(f"budget track: {track}", fontsize=9)
        ax.legend(fontsize=7)
    return _save(plt, fig, out, "performance_profiles.png")


def tier_scores(darwin: list[dict], out: str) -> str | None:
    """Test score per tier with its interval, one group of bars per scored configuration
    (presets and runs of at least 2,000 training trials; where there are none, as in a
    quick reproduction, the six best-ranked rows of any budget, said in the title)."""
    # The untrained presets and the configurations with the study's largest budget.
    full = [r for r in darwin if r["method"] == "preset" or (r["budget_trials"] or 0) >= 2000]
    title = "presets and runs of at least 2,000 training trials"
    if not full:
        full, title = darwin[:6], "no full-budget runs: the six best-ranked rows of any budget"
    darwin = full
    if not darwin:
        return None
    plt = _plt()
    tiers = leaderboard.TIERS
    fig, ax = plt.subplots(figsize=(13, 5))
    colors = plt.get_cmap("tab20").colors
    width = 0.8 / len(darwin)
    for i, row in enumerate(darwin):
        values = np.array([row[f"{t}_score_m"] or 0.0 for t in tiers])
        low = np.array([row[f"{t}_ci95_low"] or 0.0 for t in tiers])
        high = np.array([row[f"{t}_ci95_high"] or 0.0 for t in tiers])
        x = np.arange(len(tiers)) + i * width
        label = f"{row['method']} {row['config']} ({row['training_task']})"
        errors = [values - low, high - values]
        color = colors[i % len(colors)]
        ax.bar(x, values, width, label=label, color=color, yerr=errors, capsize=2)
    ax.set_xticks(np.arange(len(tiers)) + 0.4 - width / 2)
    ax.set_xticklabels([t.replace("darwin_walk", "walk") for t in tiers])
    ax.set_ylabel("test success-weighted distance (m)")
    ax.set_title(title, fontsize=9)
    ax.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0))
    return _save(plt, fig, out, "tier_scores.png")


# The joint-trajectory figure's window: two strides (1.1 s each) after the start-up.
_TRAJECTORY_WINDOW_S = (8.0, 10.2)


def _joint_targets(params: str, out: str, name: str) -> dict[str, np.ndarray]:
    """A gait's CPG joint targets, written by `python -m cpg_suite.trajectories` (analysis
    reads the file; it does not run the CPG itself)."""
    path = os.path.join(out, f"{name}_joints.csv")
    command = [
        sys.executable,
        "-m",
        "cpg_suite.trajectories",
        f"--params={params}",
        f"--out={path}",
    ]
    done = subprocess.run(
        command, capture_output=True, text=True, check=False, timeout=_SUBPROCESS_TIMEOUT_S
    )
    if done.returncode != 0:
        raise RuntimeError(f"joint targets of {params} failed: {done.stderr.strip()[-500:]}")
    table = np.genfromtxt(path, delimiter=",", names=True)
    os.remove(path)
    return {column: table[column] for column in table.dtype.names}


def joint_trajectories(found: list[dict], out: str) -> str | None:
    """Hip, knee and ankle pitch (deg) of both legs, hand-tuned vs the best gait
    (`_best_gait_file`)."""
    best, distance, checked = _best_gait_file(found)
    if best is None:
        return None
    plt = _plt()
    fig, axes = plt.subplots(3, 1, figsize=(8, 7), sharex=True)
    for label, params, style in (
        ("hand-tuned", "hand_tuned", "--"),
        (_best_label(distance, checked), best, "-"),
    ):
        z = _joint_targets(params, out, "hand_tuned" if params == "hand_tuned" else "best")
        window = (z["t"] >= _TRAJECTORY_WINDOW_S[0]) & (z["t"] <= _TRAJECTORY_WINDOW_S[1])
        for ax, joint, name in zip(
            axes, ("hip_pitch", "knee", "ankle_pitch"), ("hip pitch", "knee", "ankle pitch")
        ):
            t = z["t"][window]
            ax.plot(t, z[f"left_{joint}"][window], style, color="tab:blue", label=f"left, {label}")
            ax.plot(t, z[f"right_{joint}"][window], style, color="tab:red", label=f"right, {label}")
            ax.set_ylabel(f"{name} (deg)")
    axes[0].legend(fontsize=7, ncol=2)
    axes[-1].set_xlabel("time (s)")
    return _save(plt, fig, out, "joint_trajectories.png")


def rms_error(found: list[dict], out: str) -> str | None:
    """Mean RMS error per move of each real-time crawler learner (its default config)."""
    curves = defaultdict(list)
    for run in found:
        if run["task"] == "crawler_walk" and run["config"] == run["method"]:
            rows = _read_csv(os.path.join(run["dir"], "progress.csv"))
            if rows and "rms" in rows[0]:
                curves[run["method"]].append([float(r["rms"]) for r in rows])
    if not curves:
        return None
    plt = _plt()
    fig, ax = plt.subplots(figsize=(7, 4))
    for method, series in sorted(curves.items()):
        n = min(len(s) for s in series)
        ax.plot(
            np.arange(1, n + 1),
            np.mean([s[:n] for s in series], axis=0),
            label=f"{method} ({len(series)} seeds)",
        )
    ax.set_yscale("symlog", linthresh=1e-3)
    ax.set_xlabel("move")
    ax.set_ylabel("RMS error of the values (m)")
    ax.legend(fontsize=8)
    return _save(plt, fig, out, "rms_error.png")


def pole_angles(found: list[dict], out: str) -> str | None:
    """Angle traces of seed 0: the force pair and the α sweep."""
    traces = {}
    for run in found:
        if run["task"] == "pole_balance" and run["seed"] == 0:
            path = os.path.join(run["dir"], "angles.npy")
            if os.path.exists(path):
                try:
                    traces[run["config"]] = np.load(path)
                except (OSError, ValueError):
                    continue
    panels = [
        ("force: 0.5 N vs 4 N (5000 steps)", ["force0.5_short", "force4_short"]),
        ("α sweep (20000 steps)", ["alpha0", "base", "alpha0.1", "alpha0.5", "alpha1"]),
    ]
    panels = [(title, [c for c in configs if c in traces]) for title, configs in panels]
    panels = [p for p in panels if p[1]]
    if not panels:
        return None
    plt = _plt()
    fig, axes = plt.subplots(len(panels), 1, figsize=(9, 3.2 * len(panels)), squeeze=False)
    labels = {
        "base": "α 0.01",
        "alpha0": "α 0",
        "alpha0.1": "α 0.1",
        "alpha0.5": "α 0.5",
        "alpha1": "α 1",
        "force0.5_short": "0.5 N",
        "force4_short": "4 N",
    }
    for ax, (title, configs) in zip(axes[:, 0], panels):
        for config in configs:
            faint = config == "alpha0"  # it never learns: keep it from hiding the others
            ax.plot(
                np.abs(traces[config]),
                linewidth=0.6,
                alpha=0.25 if faint else 0.9,
                label=labels.get(config, config),
            )
        ax.set_title(title, fontsize=9)
        ax.set_ylabel("|angle| (rad)")
        ax.set_ylim(0, 1.7)
        ax.legend(fontsize=7, ncol=5)
    axes[-1, 0].set_xlabel("step (20 ms)")
    return _save(plt, fig, out, "pole_angles.png")


def value_evolution(root: str, out: str) -> str | None:
    """Values of the six cycle states per iteration, value vs policy iteration."""
    rows = []
    for dirpath, _, files in leaderboard.walk_sorted(root):
        if "fig4_4.csv" in files:
            rows = _read_csv(os.path.join(dirpath, "fig4_4.csv"))
            break
    if not rows:
        return None
    plt = _plt()
    fig, axes = plt.subplots(1, 2, figsize=(10, 3.8), sharey=True)
    for ax, method in zip(axes, ("value_iteration", "policy_iteration")):
        series = defaultdict(list)
        for r in rows:
            if r["method"] == method:
                series[r["state"]].append((int(r["iteration"]), float(r["value"])))
        for state, points in series.items():
            points.sort()
            ax.plot([p[0] for p in points], [p[1] for p in points], label=state)
        ax.set_title(method.replace("_", " "), fontsize=9)
        ax.set_xlabel("iteration")
    axes[0].set_ylabel("V(s)")
    axes[0].legend(fontsize=7)
    return _save(plt, fig, out, "value_evolution.png")


def _best_gait_file(runs: list[dict]) -> tuple[str | None, float, bool]:
    """The best open-loop gait among `runs` (CEM and CMA-ES on `darwin_walk`) and its label:
    by its in-sample best tried again (summary.json's `in_sample`, which verify re-makes and
    the board admits only as such), else, where no run has one (a local reproduction that
    verify never read), by its training record, labelled as unchecked.

    Args:
      runs: The runs the figures show (`_figures`: the board's where it admits any).

    Returns:
      `(path of its best_params.json, its distance, m, whether it was tried again)`, or
      `(None, nan, False)` without such a run.
    """
    candidates = []
    for run in runs:
        path = os.path.join(run["dir"], admission.IN_SAMPLE)
        gait = run["method"] in ("cem", "cmaes") and run["task"] == "darwin_walk"
        if gait and os.path.isfile(path):
            tried = (run["summary"].get("in_sample") or {}).get("distance_m")
            recorded = run["summary"].get("best_distance_m")
            candidates.append((path, tried, recorded))
    checked = [(p, d) for p, d, _ in candidates if _finite(d)]
    if checked:
        return (*max(checked, key=lambda c: c[1]), True)  # the first of equals
    unchecked = [(p, d) for p, _, d in candidates if _finite(d)]
    if unchecked:
        return (*max(unchecked, key=lambda c: c[1]), False)
    return None, math.nan, False


def _best_label(distance: float, checked: bool) -> str:
    """How the figures name the best gait (`_best_gait_file`)."""
    return f"best, {distance:.2f} m" + ("" if checked else " (training record, unchecked)")


def _finite(value) -> bool:
    """A JSON number that is finite (not a boolean)."""
    return isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)


def gaits(found: list[dict], out: str) -> str | None:
    """Filmstrips of the hand-tuned and the best gait, one above the other, and videos.

    The simulation and rendering run in their own program, `python -m cpg_suite.explore`
    (analysis only reads files): it writes each gait's video and filmstrip into `out`, and
    this function stacks the two filmstrips into one sheet.
    """
    path, distance, checked = _best_gait_file(found)
    if path is None:
        return None
    from PIL import Image, ImageDraw

    try:
        best = run_files.read_json(path)  # a regular file, strict JSON, as the board reads it
    except (OSError, ValueError) as e:
        raise RuntimeError(f"the best gait's file cannot be read: {e}") from None
    best_params = os.path.join(out, "gait_best.json")
    with open(best_params, "w", encoding="utf-8") as f:
        json.dump(best, f)
    strips = []
    for name, params in (("hand_tuned", "hand_tuned"), ("gait_best", best_params)):
        command = [
            sys.executable,
            "-m",
            "cpg_suite.explore",
            f"--params={params}",
            f"--out={out}",
            "--camera=side",
            "--width=200",
            "--height=248",
            "--strip_start=8.0",
        ]
        done = subprocess.run(
            command,
            capture_output=True,
            text=True,
            check=False,
            env=cli.rendering_child_env(),
            timeout=_SUBPROCESS_TIMEOUT_S,
        )
        if done.returncode != 0:
            raise RuntimeError(f"rendering {params} failed: {done.stderr.strip()[-500:]}")
        strips.append(Image.open(os.path.join(out, f"{name}_filmstrip.png")).convert("RGB"))
    width = max(s.width for s in strips)
    sheet = Image.new("RGB", (width, sum(s.height for s in strips)), (20, 22, 26))
    draw, y = ImageDraw.Draw(sheet), 0
    for strip, label in zip(strips, ("hand-tuned", _best_label(distance, checked))):
        sheet.paste(strip, (0, y))
        draw.rectangle([width - 8 * len(label) - 12, y, width, y + 22], fill=(20, 22, 26))
        draw.text((width - 8 * len(label) - 6, y + 5), label, fill=(250, 200, 120))
        y += strip.height
    target = os.path.join(out, "gaits_filmstrip.png")
    sheet.save(target)
    return target


def _markdown_table(rows: list[dict], fields: list[str]) -> str:
    def cell(v):
        if isinstance(v, float):
            return f"{v:.4g}"
        return str(v).replace("|", "/").replace("\n", " ")

    lines = ["| " + " | ".join(fields) + " |", "|" + "---|" * len(fields)]
    lines += ["| " + " | ".join(cell(r.get(f, "")) for f in fields) + " |" for r in rows]
    return "\n".join(lines)


def _figures(found, board: tuple, runs: str, out: str, with_gaits: bool) -> list[tuple]:
    """The report's figures: `board` holds the runs and the DARwIn-OP rows the test-score
    figures show (the board's), `found` every run the others read."""
    board_runs, darwin = board
    figures = [
        ("Validation score vs simulation budget", score_vs_budget(found, out)),
        ("Test score per tier", tier_scores(darwin, out)),
        ("Performance profiles per budget track", performance_profiles(board_runs, out)),
        ("CEM rounds (thesis Fig. 6.2-6.6)", cem_rounds(found, out)),
        (
            "Joint trajectories, hand-tuned vs best gait (Fig. 6.9)",
            joint_trajectories(board_runs, out),
        ),
        ("RMS error of real-time crawler learners (Fig. 4.6)", rms_error(found, out)),
        ("Pole angle traces (Fig. 4.9-4.10)", pole_angles(found, out)),
        ("Value vs policy iteration on tokic (Fig. 4.4)", value_evolution(runs, out)),
    ]
    curves = learning_curves(found, out)
    if curves:  # only where there are deep-RL runs (a quick reproduction has none)
        figures.insert(2, ("Deep-RL learning curves (PPO)", curves))
    if with_gaits:
        title = "Hand-tuned (top) and best gait (bottom), side view (Fig. 6.8)"
        figures.append((title, gaits(board_runs, out)))
    return figures


def _shown_path(path: str) -> str:
    """`path` relative to the working directory, or only its name if it lies outside: a
    shipped report names no machine's absolute paths."""
    relative = os.path.relpath(path)
    return os.path.basename(os.path.abspath(path)) if relative.startswith("..") else relative


def _report_lines(runs, found, figures, tables, skipped, refused=()) -> list[str]:
    rows, darwin = tables
    lines = ["# cpg_suite report", "", f"Runs: `{_shown_path(runs)}` ({len(found)} runs).", ""]
    for title, path in figures:
        lines += [f"## {title}", ""]
        lines += [f"![{title}]({os.path.basename(path)})" if path else "(no data)", ""]
    lines += [
        "## DARwIn-OP: test scores (held-out tiers)",
        "",
        _markdown_table(darwin, leaderboard.DARWIN_FIELDS) if darwin else "(no admitted runs)",
        "",
    ]
    if refused:
        lines += [
            f"### Not admitted to the board ({len(refused)} runs; darwin_not_admitted.csv)",
            "",
            *([] if darwin else ["The test-score figures above show their cards.", ""]),
            _markdown_table(list(refused), leaderboard.NOT_ADMITTED_FIELDS),
            "",
        ]
    lines += [
        "## Leaderboard (in-sample and per-method metrics)",
        "",
        _markdown_table(rows, leaderboard.LEADERBOARD_FIELDS),
        "",
        "The thesis' claims are judged from the study's shipped runs by "
        "`python -m analysis.study` (results/study/claims.csv).",
        "",
    ]
    if skipped:
        lines += ["## Skipped run files", ""] + [f"- {s}" for s in skipped] + [""]
    return lines


@dataclasses.dataclass(frozen=True)
class ReportSettings:
    """What `python -m analysis.report` reads and writes.

    Attributes:
      runs: The root of the run directories; must be an existing directory.
      out: The folder the figures, report.md and the CSVs go into.
      gaits: Also render the hand-tuned and the best gait (a child process renders).
    """

    runs: str | None = None
    out: str | None = None
    gaits: bool = False

    def __post_init__(self):
        leaderboard.check_runs_dir(self.runs)
        cli.require(bool(self.out), "--out is required: the folder the report goes into")


def write_report(runs: str, out: str, gaits: bool = False) -> str:
    """Writes the figures, `report.md` and the leaderboard CSVs into `out`.

    Figures whose data are missing are skipped and listed in the report; malformed run
    files are skipped and listed too. The inputs are read before anything is written.

    Args:
      runs: The root of the run directories.
      out: The output folder (created if missing).
      gaits: Also render the hand-tuned and the best gait, by running
        `python -m cpg_suite.explore` (which picks its own rendering backend).

    Returns:
      One line saying how many figures were made and where they went.

    Raises:
      ValueError: If `runs` is not a directory.
      OSError: If an output cannot be written.
      ImportError: Without matplotlib (`pip install 'cpg-suite[plots]'`).
      RuntimeError: If rendering the gaits fails.
    """
    leaderboard.check_runs_dir(runs)
    found, skipped = leaderboard.find_runs(runs)
    admitted, refused = leaderboard.admit(found)
    rows = leaderboard.leaderboard_rows(found, admitted)
    darwin = leaderboard.darwin_rows(admitted, leaderboard.admission.BOARD_VERSION)
    history = leaderboard.darwin_tables(found, tuple(leaderboard.history_versions(found)))
    _plt()
    os.makedirs(out, exist_ok=True)
    # The test-score figures show the board's runs; with none admitted (a quick
    # reproduction's cards: 2 seeds, short trials), every card, and the report says so.
    board = (admitted, darwin) if darwin else (found, leaderboard.darwin_rows(found))
    figures = _figures(found, board, runs, out, gaits)
    lines = _report_lines(runs, found, figures, (rows, darwin), skipped, refused)
    with open(os.path.join(out, "report.md"), "w", encoding="utf-8") as f:
        f.write("\n".join(lines))
    for name, table, fields in (
        ("leaderboard.csv", rows, leaderboard.LEADERBOARD_FIELDS),
        ("darwin_leaderboard.csv", darwin, leaderboard.DARWIN_FIELDS),
        ("darwin_not_admitted.csv", refused, leaderboard.NOT_ADMITTED_FIELDS),
        *history,
    ):
        leaderboard.write_csv(os.path.join(out, name), table, fields)
    made = [p for _, p in figures if p]
    return f"{len(made)} figures, report.md, leaderboard CSVs -> {out}"


def check_matplotlib() -> None:
    """Checks that the figures can be drawn.

    Raises:
      cli.UsageError: Without matplotlib, saying how to install it.
    """
    try:
        _plt()
    except ImportError:
        raise cli.UsageError(
            "the report needs matplotlib: pip install 'cpg-suite[plots]'"
        ) from None


def define_flags() -> None:
    """Defines this module's command-line flags (only when it runs as a program)."""
    flags.DEFINE_string(
        "runs", None, "none: required. Root of the run directories (an existing directory)."
    )
    flags.DEFINE_string("out", None, "none: required. Output folder.")
    flags.DEFINE_bool(
        "gaits", False, "Also render the hand-tuned and the best gait (needs EGL or OSMesa)."
    )


def main(argv: list[str]) -> None:
    del argv
    settings = cli.settings_from_flags(ReportSettings)
    check_matplotlib()
    print(write_report(settings.runs, settings.out, settings.gaits))


if __name__ == "__main__":
    define_flags()
    cli.run(main, output_dirs=("out",))

r"""The front page's pictures: the three tasks, and the board leader's gait.

  python -m cpg_suite.pictures --out=results/pictures [--runs=results/protocol/runs]

Writes `tasks.png` (the crawler, the pole and the DARwIn-OP after a reset, side by side)
and `leader_gait.png` (a filmstrip of the first seed of the study track's top row of
`<runs>/../darwin_leaderboard.csv`, walking on the nominal tier, test seed 0 of the
protocol, under the board's benchmark version). `python -m analysis.rebuild` runs this
command after it has rebuilt the board. Rendering needs an OpenGL backend: without a display
and without `MUJOCO_GL` the command uses the first headless one that works (EGL, then
OSMesa) or says in one line that none does.
"""

from __future__ import annotations

if __name__ == "__main__":  # this program renders: a backend that works, chosen before dm_control
    from cpg_suite import cli

    cli.choose_renderer()

import csv
import dataclasses
import glob
import os

import numpy as np
from absl import flags

from cpg_suite import cli

# (task id, camera, label) of the tasks picture.
TASKS = (
    ("crawler_walk", "side", "crawler_walk"),
    ("pole_balance", "fixed", "pole_balance"),
    ("darwin_walk", "three_quarter", "darwin_walk"),
)
TILE = (320, 240)  # width, height of each picture, pixels
STEPS = 300  # control steps of the leader's trial shown (4.8 s)
FRAMES = 8  # snapshots in its filmstrip


@dataclasses.dataclass(frozen=True)
class PictureSettings:
    """Where the pictures go and which runs they show (the command's flags).

    Attributes:
      out: Output folder.
      runs: The shipped runs; the board is `<runs>/../darwin_leaderboard.csv`.
    """

    out: str = os.path.join("results", "pictures")
    runs: str = os.path.join("results", "protocol", "runs")


def tasks_picture(path: str) -> None:
    """Renders each of `TASKS` after a reset, side by side, labelled; writes a PNG.

    Args:
      path: The PNG written.
    """
    from PIL import Image, ImageDraw

    import cpg_suite

    width, height = TILE
    sheet = Image.new("RGB", (width * len(TASKS), height), (20, 22, 26))
    draw = ImageDraw.Draw(sheet)
    for i, (task, camera, label) in enumerate(TASKS):
        env = cpg_suite.load(task, task_kwargs={"random": 0})
        env.reset()
        pixels = env.physics.render(height, width, camera_id=camera)
        sheet.paste(Image.fromarray(pixels), (i * width, 0))
        draw.text((i * width + 8, 6), label, fill=(250, 200, 120))
    sheet.save(path)


def leader(board_csv: str, runs: str) -> tuple[str, str]:
    """The study track's top row of the board: (its label, its first seed's run folder).

    Raises:
      ValueError: If the board has no ranked study row or its runs are not shipped.
    """
    with open(board_csv, encoding="utf-8") as f:
        rows = [r for r in csv.DictReader(f) if r["track"] == "study" and r["rank"] == "1"]
    if not rows:
        raise ValueError(f"{board_csv} has no ranked study row")
    row = rows[0]
    config = row["config"]
    pattern = os.path.join(runs, row["method"], row["training_task"], f"{config}_seed*")
    found = sorted(glob.glob(pattern), key=lambda p: int(p.rsplit("_seed", 1)[1]))
    if not found:
        raise ValueError(f"no shipped run matches {pattern}")
    return f"{row['method']} {config}", found[0]


def gait_frames(run_dir: str, steps: int = STEPS, every: int = 2) -> tuple[np.ndarray, np.ndarray]:
    """A shipped run's gait or policy walking the nominal tier, test seed 0: frames from the
    side camera every `every` control steps, and their times (s).

    Raises:
      OSError, KeyError, ValueError: On a run without a readable policy or gait.
      verify.UntrustedCode: If its policy is code not trusted.
    """
    import cpg_suite
    from cpg_suite import darwin, protocol
    from cpg_suite.protocol import score, verify
    from cpg_suite.runfiles import runs

    config = runs.read_json(os.path.join(run_dir, "config.json"))
    settings = verify.card_settings(config, 1, 1, verify.stored_card(run_dir))
    policy = verify.shipped_policy(run_dir)
    if policy is None:
        if settings.controller != "open_loop":
            raise ValueError(f"{run_dir}: only open-loop gaits and policies are drawn")
        policy = score.OpenLoopPolicy(verify.gait_params(run_dir, settings.controller), steps)
    kwargs = {**settings.task_kwargs(), "random": protocol.TEST.start}
    env = cpg_suite.load("darwin_walk", task_kwargs=kwargs)
    time_step = env.reset()
    policy.reset()
    frames, times = [], []
    for t in range(steps):
        if t % every == 0:
            frames.append(env.physics.render(TILE[1], TILE[0], camera_id="side"))
            times.append(t * darwin.CONTROL_TIMESTEP)
        time_step = env.step(policy(time_step.observation))
        if time_step.last():
            break
    return np.array(frames), np.array(times)


def leader_picture(path: str, board_csv: str, runs: str) -> str:
    """The board leader's filmstrip (`render.filmstrip`); writes a PNG, returns its label."""
    from cpg_suite import render

    label, run_dir = leader(board_csv, runs)
    frames, times = gait_frames(run_dir)
    name = f"{label}, {os.path.basename(run_dir)}"
    render.filmstrip(frames, times, FRAMES, name).save(path)
    return name


def make(settings: PictureSettings) -> list[str]:
    """Writes the pictures into `settings.out`; returns one line per picture."""
    os.makedirs(settings.out, exist_ok=True)
    tasks = os.path.join(settings.out, "tasks.png")
    tasks_picture(tasks)
    gait = os.path.join(settings.out, "leader_gait.png")
    board = os.path.join(os.path.dirname(os.path.normpath(settings.runs)), "darwin_leaderboard.csv")
    name = leader_picture(gait, board, settings.runs)
    return [f"the three tasks -> {tasks}", f"the leader's gait ({name}) -> {gait}"]


def main(argv: list[str]) -> None:
    del argv
    settings = cli.settings_from_flags(PictureSettings)
    cli.check(os.path.isdir(settings.runs), f"--runs={settings.runs}: not a folder of runs")
    print("\n".join(make(settings)))


if __name__ == "__main__":
    d = PictureSettings()
    flags.DEFINE_string("out", d.out, "Output folder.")
    flags.DEFINE_string("runs", d.runs, "The shipped runs (the board beside them).")
    cli.run(main, output_dirs=("out",))

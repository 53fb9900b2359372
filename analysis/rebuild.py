r"""Rebuilds every tracked file under results/ that derives from the shipped runs.

  python -m analysis.rebuild            # write them
  python -m analysis.rebuild --check    # rebuild into a scratch folder and compare

From `results/protocol/runs` (the board's shipped runs): the boards of every benchmark
version and the runs they do not admit (`results/protocol/darwin_leaderboard*.csv`,
`darwin_not_admitted*.csv`), the board's figures (`performance_profiles.png`,
`tier_scores.png`), the README's board table (between its board markers) and every number
the README and docs/ quote from the runs (`analysis.facts`), and the front page's pictures
(`results/pictures/`: `python -m cpg_suite.pictures`, run as a child process; `--nopictures`
skips them where no OpenGL backend works). From the
study's runs and computed evidence: `results/study/` (`analysis.study`). Nothing is trained.
`--check` compares the CSVs, the README table, the quoted numbers and the study's files
byte for byte and
exits 1, naming the files that differ, if any does (the figures are drawn, not compared:
their bytes depend on the matplotlib build).
"""

from __future__ import annotations

if __name__ == "__main__":  # this program never renders a scene: no OpenGL backend
    from cpg_suite import cli

    cli.without_rendering()

import filecmp
import os
import shutil
import subprocess
import sys
import tempfile

from absl import flags

from analysis import board_table, facts, leaderboard, report
from analysis.study import build
from cpg_suite import cli

RUNS = os.path.join("results", "protocol", "runs")
BOARD = os.path.join("results", "protocol")
README = "README.md"
MARKERS = ("<!-- board: made by python -m analysis.rebuild -->", "<!-- /board -->")
FIGURES = ("performance_profiles.png", "tier_scores.png")
PICTURES = os.path.join("results", "pictures")


def board_files(out: str, runs: str = RUNS) -> list[str]:
    """Writes the boards and their not-admitted lists into `out`; returns their names."""
    with tempfile.TemporaryDirectory() as scratch:
        leaderboard.write_tables(runs, os.path.join(scratch, "leaderboard.csv"))
        names = sorted(n for n in os.listdir(scratch) if n.startswith("darwin_"))
        for name in names:
            shutil.copyfile(os.path.join(scratch, name), os.path.join(out, name))
    return names


def board_figures(out: str, runs: str = RUNS) -> None:
    """Draws the board's performance profiles and per-tier scores into `out`."""
    found, _ = leaderboard.find_runs(runs)
    admitted, _ = leaderboard.admit(found)
    report.performance_profiles(admitted, out)
    report.tier_scores(leaderboard.darwin_rows(admitted), out)


def pictures(out: str = PICTURES, runs: str = RUNS) -> str:
    """Renders the front page's pictures with the package's own command, in a child process
    (it chooses its OpenGL backend; this process imports no renderer); returns its report.

    Raises:
      RuntimeError: With the command's last error line if it fails.
    """
    command = [sys.executable, "-m", "cpg_suite.pictures", f"--out={out}", f"--runs={runs}"]
    done = subprocess.run(command, capture_output=True, text=True, timeout=1800)
    if done.returncode != 0:
        lines = done.stderr.strip().splitlines() or ["(no output)"]
        raise RuntimeError(f"python -m cpg_suite.pictures failed: {lines[-1]}")
    return done.stdout.strip()


def readme_with_table(readme: str, table: str) -> str:
    """The README's text with the board table between its markers replaced.

    Raises:
      ValueError: If the markers are missing.
    """
    start, end = readme.find(MARKERS[0]), readme.find(MARKERS[1])
    if start < 0 or end < start:
        raise ValueError(f"{README} lacks the board markers {MARKERS}")
    head = readme[: start + len(MARKERS[0])]
    return f"{head}\n{table}{readme[end:]}"


def rebuild(
    results_board: str = BOARD,
    readme: str = README,
    study: str = build.OUT,
    runs: str = RUNS,
    with_pictures: bool = True,
) -> list[str]:
    """Writes every derived file in place; returns one line per part.

    Raises:
      RuntimeError: If the pictures are asked for and cannot be rendered.
    """
    names = board_files(results_board, runs)
    board_figures(results_board, runs)
    table = board_table.markdown(os.path.join(results_board, "darwin_leaderboard.csv"))
    with open(readme, encoding="utf-8") as f:
        text = readme_with_table(f.read(), table)
    with open(readme, "w", encoding="utf-8") as f:
        f.write(text)
    quoting = []
    for page in facts.pages(os.path.dirname(readme)):
        with open(page, encoding="utf-8") as f:
            text = f.read()
        if facts.PATTERN.search(text):
            quoting.append(page)
            with open(page, "w", encoding="utf-8") as f:
                f.write(facts.fill(text, runs))
    lines = [
        f"{len(names)} board files -> {results_board}",
        f"board table -> {readme}",
        f"quoted numbers -> {', '.join(quoting) or 'no page quotes one'}",
        build.build(study),
    ]
    if with_pictures:
        lines.append(pictures(runs=runs))
    return lines


def check(
    results_board: str = BOARD, readme: str = README, study: str = build.OUT, runs: str = RUNS
) -> list[str]:
    """The tracked derived files that differ from a rebuild (empty: none)."""
    differ = []
    with tempfile.TemporaryDirectory() as scratch:
        for name in board_files(scratch, runs):
            if not filecmp.cmp(
                os.path.join(scratch, name), os.path.join(results_board, name), shallow=False
            ):
                differ.append(os.path.join(results_board, name))
        table = board_table.markdown(os.path.join(scratch, "darwin_leaderboard.csv"))
        with open(readme, encoding="utf-8") as f:
            text = f.read()
        if readme_with_table(text, table) != text:
            differ.append(f"{readme} (board table)")
        for page in facts.pages(os.path.dirname(readme)):
            with open(page, encoding="utf-8") as f:
                text = f.read()
            if facts.fill(text, runs) != text:
                differ.append(f"{page} (quoted numbers)")
        build.build(os.path.join(scratch, "study"))
        for name in ("claims.csv", "numbers.csv", "report.md"):
            if not filecmp.cmp(
                os.path.join(scratch, "study", name), os.path.join(study, name), shallow=False
            ):
                differ.append(os.path.join(study, name))
    return differ


def main(argv: list[str]) -> None:
    del argv
    runs = flags.FLAGS.runs
    cli.check(os.path.isdir(runs), f"--runs={runs}: not a folder of shipped runs")
    if flags.FLAGS.check:
        differ = check(runs=runs)
        if differ:
            sys.stderr.write("error: differ from their rebuild: " + ", ".join(differ) + "\n")
            raise SystemExit(1)
        print("every derived file under results/ and the README's board equal their rebuild")
        return
    try:
        print("\n".join(rebuild(runs=runs, with_pictures=flags.FLAGS.pictures)))
    except RuntimeError as e:
        cli.fail(f"{e} (--nopictures rebuilds the rest)")


if __name__ == "__main__":
    flags.DEFINE_bool("check", False, "Compare with a rebuild instead of writing.")
    flags.DEFINE_string("runs", RUNS, "The board's shipped runs.")
    flags.DEFINE_bool("pictures", True, "Render the front page's pictures (needs OpenGL).")
    cli.run(main)

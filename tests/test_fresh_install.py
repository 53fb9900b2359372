"""The README on the install it gives: `pip install .` (the core, no extras) in a new virtual
environment, then the quick start's main job, the submission block and docs/submit.md's
complete example, headless.

The venv sees nothing of this environment's packages (no `--system-site-packages`); it is
made from a copy of the package's files, so the build leaves nothing in the checkout. Every
command must exit 0 and print nothing on stderr, and print what its comment says.
"""

import csv
import os
import re
import shutil
import subprocess
import sys
import time

import pytest

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
README = os.path.join(ROOT, "README.md")
# What `pip install .` reads: setup.py, the README (its long description) and the packages.
_SOURCES = ("setup.py", "README.md", "LICENSE", "cpg_suite", "baselines", "analysis")
# pip's notes about this machine's own index settings, not about the package.
_PIP_MACHINE_NOTE = re.compile(r"^WARNING: Location '[^']*' is ignored")
# The main job, small: one round of four candidates (the README's takes minutes).
_SMALL_MAIN_JOB = ("--rounds=1", "--population=4", "--validation_seeds=2", "--test_seeds=2")


SUBMIT_PAGE = os.path.join(ROOT, "docs", "submit.md")


def _blocks(language: str, path: str = README) -> list[str]:
    """The fenced code blocks of a page in that language ("" for none given), in order."""
    blocks, body, fence = [], [], None
    with open(path, encoding="utf-8") as f:
        for line in f:
            if line.startswith("```"):
                if fence is None:
                    fence, body = line[3:].strip(), []
                else:
                    if fence == language:
                        blocks.append("".join(body))
                    fence = None
            elif fence is not None:
                body.append(line)
    return blocks


def _commands(block: str) -> list[str]:
    return [line for line in block.splitlines() if line.strip() and not line.startswith("#")]


def _run(args, cwd, env, timeout=900) -> subprocess.CompletedProcess:
    return subprocess.run(args, cwd=cwd, env=env, capture_output=True, text=True, timeout=timeout)


def _clean(done: subprocess.CompletedProcess, what: str) -> str:
    assert done.returncode == 0, f"{what}: exit {done.returncode}\n{done.stderr[-3000:]}"
    assert done.stderr == "", f"{what} printed on stderr:\n{done.stderr[-3000:]}"
    return done.stdout


@pytest.mark.slow  # a new venv, pip install . and a protocol submission: minutes
def test_the_readme_runs_on_the_core_install(tmp_path):
    started = time.monotonic()
    source = tmp_path / "cpg_suite_checkout"
    source.mkdir()
    for name in _SOURCES:
        path = os.path.join(ROOT, name)
        if os.path.isdir(path):
            ignore = shutil.ignore_patterns("__pycache__", "*.egg-info", "build")
            shutil.copytree(path, source / name, ignore=ignore)
        else:
            shutil.copy(path, source / name)
    venv = tmp_path / "venv"
    subprocess.run([sys.executable, "-m", "venv", str(venv)], check=True, timeout=300)
    # A new user's headless shell with the venv active: no display, no rendering variables,
    # nothing of this environment's Python path.
    env = {
        k: v
        for k, v in os.environ.items()
        if k not in ("MUJOCO_GL", "DISPLAY", "PYOPENGL_PLATFORM", "PYTHONPATH", "PYTHONHOME")
    }
    env.update(
        PATH=f"{venv / 'bin'}{os.pathsep}{env.get('PATH', '')}",
        VIRTUAL_ENV=str(venv),
        PIP_DISABLE_PIP_VERSION_CHECK="1",
    )

    # Quick start, command 1: exactly `pip install .`, then the main job (small).
    install, main_job = _commands(_blocks("bash")[0])[0].split(" && ")
    assert install == "pip install ."
    done = _run(install.split(), source, env)
    assert done.returncode == 0, done.stderr[-3000:]
    noise = [line for line in done.stderr.splitlines() if not _PIP_MACHINE_NOTE.match(line)]
    assert noise == [], "\n".join(noise)
    installed = _run(["python", "-m", "pip", "list", "--format=freeze"], tmp_path, env).stdout
    assert not re.search(r"(?im)^(torch|jax|gymnasium|shimmy|ray|stable.baselines3)==", installed)

    work = tmp_path / "newcomer"  # where the user runs things: the installed package only
    work.mkdir()
    assert main_job.startswith("python -m baselines.cem --task=darwin_walk")
    out = _clean(_run([*main_job.split(), *_SMALL_MAIN_JOB], work, env), main_job)
    assert out.splitlines()[0].startswith("round   1 ")
    (run,) = os.listdir(work / "runs" / "cem" / "darwin_walk")
    assert os.path.exists(work / "runs" / "cem" / "darwin_walk" / run / "summary.json")

    # The README's Python blocks: the pole, then the submission.
    pole, submission = _blocks("python")
    (work / "pole.py").write_text(pole)
    out = _clean(_run(["python", "pole.py"], work, env), "the pole block")
    assert re.fullmatch(r"return -?\d+\.\d{4}, fell: (True|False)\n", out)
    (work / "submission.py").write_text(submission)
    out = _clean(_run(["python", "submission.py"], work, env), "the submission block")
    # What its comments say: the card (a line per tier, then all tiers; then the feet's
    # table), then the folder.
    folder = re.search(r"print\(folder\)  # (\S+)", submission).group(1)
    lines = out.splitlines()
    assert lines[-1] == folder
    first_table = lines[2 : next(i for i, x in enumerate(lines) if x.startswith("all ")) + 1]
    tiers = [line.split()[0] for line in first_table]
    assert tiers == [
        "darwin_walk",
        "darwin_walk_randomized",
        "darwin_walk_push",
        "darwin_walk_rough",
        "darwin_walk_contact",
        "all",
    ]
    assert "walks forward" in submission
    all_tiers = float(first_table[-1].split()[1])  # success-weighted distance, all tiers
    assert all_tiers > 0.5, first_table[-1]

    # The commands the README gives after the block: the board, then verify.
    after = _commands_after(submission)
    board_command = next(c for c in after if c.startswith("python -m analysis.leaderboard"))
    out = _clean(_run(board_command.split(), work, env), board_command)
    out_file = re.search(r"--out=(\S+)", board_command).group(1)
    board = os.path.join(os.path.dirname(out_file), "darwin_leaderboard.csv")
    assert f"-> {board} " in out, out  # the summary line names the file that holds the row
    with open(work / board, encoding="utf-8") as f:
        (row,) = list(csv.DictReader(f))
    assert (row["method"], row["config"], row["status"]) == ("my_method", "first", "provisional")
    verify_command = next(c for c in after if c.startswith("python -m cpg_suite.protocol.verify"))
    out = _clean(_run(verify_command.split(), work, env), verify_command)
    lines = out.splitlines()
    assert lines[0].startswith("sample: 20 trials a run, drawn with --entropy=")
    assert lines[-1] == "1 of 1 shipped runs, 20 random trials each, reproduced bit for bit"

    # docs/submit.md's complete example (a search of its own, submitted), then its commands.
    page = tmp_path / "submit_page"
    page.mkdir()
    (example,) = _blocks("python", SUBMIT_PAGE)
    (page / "my_search.py").write_text(example)
    out = _clean(_run(["python", "my_search.py"], page, env), "docs/submit.md's example")
    assert re.fullmatch(
        r"training score -?\d+\.\d{3} m after \d+ trials; submitted "
        r"runs/my_search/darwin_walk/K8_seed0\n",
        out,
    ), out
    commands = [c for c in _blocks("", SUBMIT_PAGE) if "analysis.leaderboard" in c]
    board_line, verify_line = _commands(commands[0])
    _clean(_run(board_line.split(), page, env), board_line)
    out = _clean(_run(verify_line.split(), page, env), verify_line)
    assert out.splitlines()[-1] == (
        "1 of 1 shipped runs reproduced bit for bit on --quick's trials (the first 5 test "
        "seeds a tier), 0 of them on record as re-scored in full"
    )
    print(f"fresh install and the README's blocks: {time.monotonic() - started:.0f} s")


def _commands_after(block: str) -> list[str]:
    """The commands (in backticks) of the paragraph that follows `block` in the README."""
    with open(README, encoding="utf-8") as f:
        text = f.read()
    paragraph = text[text.index(block) + len(block) :].split("\n\n")[1]
    return re.findall(r"`(python -m [^`]+)`", paragraph.replace("\n", " "))

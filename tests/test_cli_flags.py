"""Every flag of every command refuses what it cannot mean, before any work: generated.

The commands are found, not listed: every module that runs through `cli.run(main, ...)`.
Each of its numeric flags is fed NaN, ±inf, 0, −1 and 1e300, and each enum, string and
list flag an unknown value (tests/cli_flag_cases.py runs the cases). A case passes when the
command exits with code 2 after exactly one `error:` line on stderr and has created no
file, or when (command, flag, value) is in `VALID` below — a documented value the command
takes — and the command took it (still running after the alarm, or done, with no
traceback).
"""

from __future__ import annotations

import ast
import concurrent.futures
import json
import os
import subprocess
import sys

import pytest

from cpg_suite import cpg, residual
from cpg_suite.harness import interface
from cpg_suite.protocol import score

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
ALARM_S = 1.0  # a refusal comes within milliseconds of parsing; work runs past this
ANY = "*"  # every command

# Values a command takes, with the reason. Keys: (command or ANY, flag, value).
VALID = {
    (ANY, "seed", "0"): "the first seed",
    (ANY, "run_name", "no_such_value"): "a run folder's name",
    (ANY, "test_seeds", "0"): "documented: no score card (scored later with --resume)",
    (ANY, "fall_penalty", "0"): "falls cost nothing beyond the distance they lose",
    (ANY, "lateral_penalty", "0"): "the default: sideways drift is free",
    (ANY, "validation_every", "0"): "documented: validate only at the end",
    (ANY, "validation_top", "0"): "documented: select among the final mean only",
    ("baselines.cem", "noise", "0"): "CEM without added noise (thesis Table 6.3)",
    ("baselines.nac", "beta", "0"): "β = 0: keep only the newest estimate",
    ("baselines.nac", "gamma", "0"): "γ = 0: the immediate reward",
    ("baselines.nac", "lam", "0"): "LSTD(0)",
    ("baselines.nac", "ridge", "0"): "documented: no ridge",
    ("baselines.ppo", "amplitude_scale", "0"): "no amplitude correction (an ablation)",
    ("baselines.ppo", "rate_scale", "0"): "no phase-rate correction (an ablation)",
    ("baselines.ppo", "ent_coef", "0"): "the default: no entropy bonus",
    ("baselines.ppo", "gae_lambda", "0"): "one-step advantages",
    ("baselines.ppo", "log_std_init", "0"): "an initial σ of 1",
    ("baselines.ppo", "log_std_init", "-1"): "the default: an initial σ of e⁻¹",
    ("baselines.ppo", "supply_cost", "0"): "the default: the task's reward, unshaped",
    ("baselines.ppo_mjx", "entropy_cost", "0"): "the default: no entropy bonus",
    ("baselines.ppo_mjx", "gae_lambda", "0"): "one-step advantages",
    ("benchmarks.bench_mjx", "iterations", "0"): "documented: with --ls_iterations=0, the model's",
    ("benchmarks.bench_mjx", "ls_iterations", "0"): "documented: with --iterations=0, the model's",
    ("benchmarks.bench_mjx", "timestep", "0"): "documented: the physics' own step",
    ("benchmarks.bench_mjx", "ppo_steps", "0"): "documented: no PPO throughput run",
    ("cpg_suite.explore", "strip_start", "0"): "a first snapshot at the start",
    ("cpg_suite.protocol.score", "supply_window", "inf"): "documented: the whole trial",
}


def commands() -> dict[str, tuple[str, ...]]:
    """{module: its output flags}: every module whose `__main__` runs `cli.run`."""
    found = {}
    for folder in ("analysis", "baselines", "benchmarks", "cpg_suite"):
        for dirpath, _, names in os.walk(os.path.join(ROOT, folder)):
            for name in names:
                if name.endswith(".py"):
                    path = os.path.join(dirpath, name)
                    outputs = _cli_run_outputs(path)
                    if outputs is not None:
                        module = os.path.relpath(path, ROOT)[:-3].replace(os.sep, ".")
                        found[module] = outputs
    return dict(sorted(found.items()))


def _cli_run_outputs(path: str) -> tuple[str, ...] | None:
    """The output flags of the module's `cli.run(...)` call (None: it has none)."""
    with open(path, encoding="utf-8") as f:
        tree = ast.parse(f.read())
    for node in ast.walk(tree):
        if isinstance(node, ast.Call) and ast.unparse(node.func) == "cli.run":
            outputs = []
            for keyword in node.keywords:
                if keyword.arg in ("output_dirs", "output_files"):
                    outputs.extend(ast.literal_eval(keyword.value))
            return tuple(outputs)
    return None


def _valid(command: str, outputs: tuple[str, ...], flag: str, value: str) -> str | None:
    if flag in outputs:
        return "a new output path"
    return VALID.get((command, flag, value)) or VALID.get((ANY, flag, value))


def _cases(command: str) -> list[dict]:
    out = subprocess.run(
        [sys.executable, os.path.join(ROOT, "tests", "cli_flag_cases.py"), command, str(ALARM_S)],
        capture_output=True,
        text=True,
        timeout=600,
        cwd=ROOT,
    )
    assert out.returncode == 0, f"{command}: {out.stderr[-1500:]}"
    return [json.loads(line) for line in out.stdout.splitlines() if line.startswith('{"flag"')]


def _problems(command: str, outputs: tuple[str, ...], cases: list[dict]) -> list[str]:
    problems = []
    for case in cases:
        flag, value = case["flag"], case["value"]
        refused = case["code"] == 2 and case["lines"] == 1 and case["last"].startswith("error: ")
        if refused and not case["created"]:
            continue
        where = f"{command} --{flag}={value}"
        if refused:
            problems.append(f"{where}: refused after creating {case['created']}")
        elif _valid(command, outputs, flag, value) is None:
            problems.append(f"{where}: not refused (exit {case['code']}: {case['last'][:120]})")
        elif case["code"] not in (0, -14):
            problems.append(f"{where}: a valid value failed (exit {case['code']}: {case['last']})")
    return problems


@pytest.mark.slow  # about a minute: 32 commands, a thousand cases
@pytest.mark.skipif(sys.platform != "linux", reason="forked cases: Linux")
def test_every_flag_of_every_command_refuses_what_it_cannot_mean():
    found = commands()
    assert len(found) >= 30, sorted(found)
    with concurrent.futures.ThreadPoolExecutor(max_workers=2) as pool:
        results = dict(zip(found, pool.map(_cases, found)))
    problems, tried = [], set()
    for command, cases in results.items():
        assert cases, f"{command}: no flag was tried"
        problems += _problems(command, found[command], cases)
        tried |= {(k, c["flag"], c["value"]) for c in cases for k in (command, ANY)}
    problems += [
        f"{key}: listed as valid, but no command has that flag" for key in VALID if key not in tried
    ]
    assert not problems, f"{len(problems)} cases:\n" + "\n".join(problems)


def test_every_listed_valid_value_is_for_a_command_found():
    found = commands()
    assert all(command in (ANY, *found) for command, _, _ in VALID)


@pytest.mark.parametrize(
    "make, words",
    [
        (lambda: _load(time_limit=float("nan")), "time_limit must be > 0 s or inf"),
        (lambda: _load(time_limit=-1.0), "time_limit must be > 0 s or inf"),
        (lambda: _load(random="x"), "random must be None, an integer ≥ 0 or a RandomState"),
        (lambda: _load(bogus=1), "unknown task_kwargs ['bogus']"),
        (lambda: _load(init_noise=float("nan")), "init_noise"),
        (lambda: score.ScoreSettings(seeds=2.5), "--seeds must be an integer in [1, 50]"),
        (lambda: score.ScoreSettings(steps=0), "--steps must be an integer ≥ 1"),
        (lambda: score.ScoreSettings(threads=float("nan")), "--threads must be an integer ≥ 1"),
        (
            lambda: interface.OptimizerSettings(fall_penalty=float("inf")),
            "--fall_penalty must be a finite number in [0, 1e6], got inf",
        ),
        (
            lambda: interface.OptimizerSettings(population=2.5),
            "--population must be an integer ≥ 2",
        ),
        (lambda: cpg.CPGConfig(crouch=float("nan")), "crouch must be a finite number in [0, 90]"),
        (
            lambda: residual.ModulatedCPG(1, amplitude_scale=float("inf")),
            "--amplitude_scale must be a finite number in [0, 90]",
        ),
    ],
)
def test_library_entry_points_refuse_what_they_cannot_mean(make, words):
    with pytest.raises(ValueError) as raised:
        make()
    assert words in str(raised.value)


def _load(**task_kwargs):
    import cpg_suite

    return cpg_suite.load("darwin_walk", task_kwargs=task_kwargs)

r"""Every hot path's instructions against a raw `mujoco.rollout`'s, counted by callgrind.

  python benchmarks/bench_instructions.py [--paths=env,vector,evaluator,feedback,score]
      [--steps=200] [--tiers=darwin_walk,darwin_balance]

The paths and their raw rollouts are `bench_hot_paths.py`'s (the same code builds them),
each side run once to warm up, then once inside Valgrind's callgrind, which counts the
machine instructions every shared library executes (`valgrind --tool=callgrind`; Valgrind
is a Debian package). A count is the same from run to run on the same binaries, whatever
else the machine is doing: where a timed ratio moves by ±0.07 on a shared 2-core machine,
this one moves by nothing, so a change of a few per cent on a hot path shows.

Printed per path: the instructions per physics step of ours and of the rollout, their
ratio (the rollout's per step over ours: 1 is free, as `bench_hot_paths.py`'s speed ratio),
and where ours go, by library: MuJoCo (`libmujoco`), the C library (`libc`, `libm`: mostly
MuJoCo's `memset` and `sqrt`), the Python interpreter, NumPy, MuJoCo's Python bindings,
the rest; and ours less the rollout's, per control step.

What it is and is not. An instruction is not a nanosecond: the interpreter's and NumPy's
dispatch run fewer instructions per cycle than MuJoCo's arithmetic, so a path's time ratio
sits below its instruction ratio (by 0.03-0.07 on the Intel Xeon of 2026-11-29:
docs/benchmarks.md). Valgrind offers its program a CPU without AVX-512 (it does not
emulate it), so NumPy runs its AVX2 loops here, as on an AVX2-only CPU; MuJoCo's build has
one code path for every x86-64 CPU. The counts are those an AVX2-only CPU executes; how
fast it executes them only such a CPU can tell.
"""

from __future__ import annotations

if __name__ == "__main__":  # this program never renders: no OpenGL backend, no GLFW warning
    from cpg_suite import cli

    cli.without_rendering()

import collections
import dataclasses
import functools
import json
import os
import re
import shutil
import subprocess
import sys
import tempfile

from absl import flags

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))  # as bench_step_profile's

import bench_hot_paths

from cpg_suite import cli

# Where ours' instructions go: the first pattern a library's path matches names its part.
PARTS = (
    ("MuJoCo", r"libmujoco"),
    ("C library", r"/(libc|libm|ld-linux[^/]*)\.so"),
    ("Python", r"libpython|/python3\.\d+$"),
    ("NumPy", r"/numpy/"),
    ("MuJoCo's bindings", r"/mujoco/_\w+\.cpython"),
)
OTHER = "the rest"
# Valgrind's options: counts only inside the marker call (`functools.reduce`, which no
# hot path calls), a dump of them as each call ends; no instrumentation until the
# program turns it on before its first count (imports run at near full speed).
_CALLGRIND = (
    "--tool=callgrind",
    "--instr-atstart=no",
    "--collect-atstart=no",
    "--toggle-collect=functools_reduce",
    "--dump-after=functools_reduce",
)
_UNDER = "CPG_SUITE_CALLGRIND_OUT"  # set for the child only: where its dumps go


def self_costs(dump: str) -> collections.Counter:
    """Instructions executed in each shared library (its own code, not its callees'), from
    a callgrind dump (`--dump-instr=no`, one event: Ir).

    Args:
      dump: The dump's path.

    Returns:
      {library path: instructions}.

    Raises:
      ValueError: If the counts do not add up to the dump's own total.
    """
    names, costs = {}, collections.Counter()
    library, after_call, total = "?", False, None

    def name(spec: str) -> str:  # "(3) /path" defines id 3; "(3)" refers to it
        match = re.match(r"\((\d+)\)\s*(.*)$", spec.strip())
        if not match:
            return spec.strip()
        if match[2]:
            names[match[1]] = match[2]
        return names.get(match[1], "?")

    with open(dump) as f:
        for line in f:
            if line.startswith("ob="):
                library = name(line[3:])
            elif line.startswith("cob="):
                name(line[4:])
            elif line.startswith("calls="):
                after_call = True  # the next cost line is the call's inclusive cost
            elif line.startswith("summary:"):
                total = int(line.split()[1])
            elif line[:1].isdigit() or line[:1] in "+-*":
                if after_call:
                    after_call = False
                    continue
                fields = line.split()
                if len(fields) >= 2:
                    costs[library] += int(fields[1])
    if total is not None and sum(costs.values()) != total:
        raise ValueError(f"{dump}: the libraries' counts add to {sum(costs.values())}, not {total}")
    return costs


def by_part(costs: collections.Counter) -> dict[str, int]:
    """Libraries' counts summed into `PARTS` (and `OTHER`), in that order."""
    parts = dict.fromkeys([p for p, _ in PARTS] + [OTHER], 0)
    for library, n in costs.items():
        part = next((p for p, pattern in PARTS if re.search(pattern, library)), OTHER)
        parts[part] += n
    return parts


class Counts:
    """`bench_hot_paths._paired`'s measure as instructions: each side run once to warm up,
    then once counted (inside the marker call, instrumentation on). Run under callgrind
    with `_CALLGRIND`'s options and dumps to `prefix` (`prefix.1`, `prefix.2`, ...)."""

    def __init__(self, prefix: str):
        self.prefix, self.dumps, self.last = prefix, 0, ()
        self.instrumented = False

    def _instrument(self) -> None:
        """Turns callgrind's instrumentation on for the rest of the run (once: switched off
        and on again, its dumps' totals stop adding up)."""
        command = ["callgrind_control", "-i", "on", str(os.getpid())]
        subprocess.run(command, check=True, capture_output=True, timeout=120)
        self.instrumented = True

    def _counted(self, fn) -> collections.Counter:
        functools.reduce(lambda _acc, _item: fn(), [0], None)
        self.dumps += 1
        return self_costs(f"{self.prefix}.{self.dumps}")

    def paired(self, ours, raw) -> tuple[float, float]:
        """(ours, raw) total instructions; `last` keeps both sides' counts by library."""
        ours(), raw()
        if not self.instrumented:
            self._instrument()
        self.last = (self._counted(ours), self._counted(raw))
        return float(sum(self.last[0].values())), float(sum(self.last[1].values()))


@dataclasses.dataclass(frozen=True)
class InstructionSettings:
    """What the benchmark counts.

    Attributes:
      steps: Control steps per env run and per trial (as `bench_hot_paths.py`'s).
      paths: Which paths (`bench_hot_paths.PATHS`).
      tiers: The DARwIn-OP tiers whose `env.step` is counted.
    """

    steps: int = 200
    paths: tuple[str, ...] = bench_hot_paths.PATHS
    tiers: tuple[str, ...] = ("darwin_walk", "darwin_balance")

    def __post_init__(self):
        cli.require(self.steps >= 1, f"--steps must be ≥ 1, got {self.steps}")
        paths = tuple(p for p in self.paths if p)
        unknown = [p for p in paths if p not in bench_hot_paths.PATHS]
        valid = ", ".join(bench_hot_paths.PATHS)
        cli.require(bool(paths) and not unknown, f"--paths: one or more of {valid}")
        tiers = tuple(t for t in self.tiers if t)
        wrong = [t for t in tiers if t not in bench_hot_paths.DARWIN_TIERS]
        valid = ", ".join(bench_hot_paths.DARWIN_TIERS)
        cli.require(bool(tiers) and not wrong, f"--tiers: one or more of {valid}")
        object.__setattr__(self, "paths", paths)
        object.__setattr__(self, "tiers", tiers)


def _counted_rows(settings: InstructionSettings, prefix: str) -> list[dict]:
    """Each path's counts per physics step, ours and raw, and ours' by part (`measure`'s
    rows; the child's work, under callgrind)."""
    counts, rows = Counts(prefix), []
    for path, ours, raw in bench_hot_paths.ratios(
        settings.paths, settings.steps, 1, 1, counts, settings.tiers
    ):
        mine, theirs = counts.last  # ours and raw: physics steps per instruction
        steps, raw_steps = sum(mine.values()) * ours, sum(theirs.values()) * raw
        rows.append(
            {
                "path": path,
                "ours": 1 / ours,
                "raw": 1 / raw,
                "ratio": ours / raw,
                "parts": {k: n / steps for k, n in by_part(mine).items()},
                "raw_parts": {k: n / raw_steps for k, n in by_part(theirs).items()},
            }
        )
    return rows


def _without_valgrind() -> str:
    """Why this machine cannot count ("" if it can)."""
    missing = [t for t in ("valgrind", "callgrind_control") if shutil.which(t) is None]
    return f"needs Valgrind ({', '.join(missing)} not found): apt install valgrind" * bool(missing)


def measure(settings: InstructionSettings) -> list[dict]:
    """Counts each path under callgrind, in a child process of this program.

    Args:
      settings: What to count.

    Returns:
      A row a path: `path`, `ours` and `raw` (instructions per physics step), `ratio`
      (raw's / ours'), `parts` and `raw_parts` ({`PARTS` name: instructions per physics
      step}).

    Raises:
      RuntimeError: If Valgrind is not installed, or the child fails.
    """
    missing = _without_valgrind()
    if missing:
        raise RuntimeError(missing)
    with tempfile.TemporaryDirectory() as folder:
        prefix = os.path.join(folder, "callgrind")
        command = ["valgrind", *_CALLGRIND, f"--callgrind-out-file={prefix}.%p", "-q"]
        command += [sys.executable, os.path.abspath(__file__), f"--steps={settings.steps}"]
        command += [f"--paths={','.join(settings.paths)}", f"--tiers={','.join(settings.tiers)}"]
        done = subprocess.run(command, env={**os.environ, _UNDER: prefix})
        if done.returncode:
            raise RuntimeError(f"the count under callgrind failed (exit {done.returncode})")
        with open(prefix + ".json") as f:
            return json.load(f)


def main(argv: list[str]) -> None:
    del argv
    s = cli.settings_from_flags(InstructionSettings)
    if os.environ.get(_UNDER):  # the child, under callgrind: its dumps carry its pid (%p)
        rows = _counted_rows(s, f"{os.environ[_UNDER]}.{os.getpid()}")
        with open(os.environ[_UNDER] + ".json", "w") as f:
            json.dump(rows, f)
        return
    missing = _without_valgrind()
    cli.require(not missing, missing)
    print(
        f"instructions per physics step (callgrind, {s.steps} control steps a run; "
        "ratio = raw's / ours', 1 is free)"
    )
    print(f"{'path':40s} {'ours':>9s} {'raw':>9s} {'ratio':>6s}  by part (per physics step)")
    for row in measure(s):
        mine = ", ".join(f"{p} {n:,.0f}" for p, n in row["parts"].items() if n)
        theirs = ", ".join(f"{p} {n:,.0f}" for p, n in row["raw_parts"].items() if n)
        counts = f"{row['ours']:9,.0f} {row['raw']:9,.0f} {row['ratio']:6.3f}"
        print(f"{row['path']:40s} {counts}  ours: {mine}")
        print(f"{'':40s} {'':9s} {'':9s} {'':6s}  raw: {theirs}")


def define_flags() -> None:
    """Defines this script's command-line flags (only when it runs as a program)."""
    d = InstructionSettings()
    flags.DEFINE_integer("steps", d.steps, "Control steps per env run and per trial.")
    flags.DEFINE_list("paths", list(d.paths), "Paths: " + ", ".join(bench_hot_paths.PATHS))
    flags.DEFINE_list("tiers", list(d.tiers), "DARwIn-OP tiers whose env.step is counted.")


if __name__ == "__main__":
    define_flags()
    cli.run(main)

"""The layout holds: the benchmark (`cpg_suite`) imports no contestant, no contestant imports
another, `analysis` imports no simulation code, the protocol imports nothing of the harness,
and no module imports itself in a circle.

Every import counts, the ones inside functions too: a cycle through a deferred import is
still a cycle in what depends on what.
"""

import ast
import os

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
PACKAGES = ("cpg_suite", "baselines", "analysis")
# The contestants: one module or package per method.
METHODS = (
    "baselines.cem",
    "baselines.cmaes",
    "baselines.ppo",
    "baselines.ppo_mjx",
    "baselines.nac",
    "baselines.tabular",
)
# What `analysis` may import of the benchmark: command-line plumbing, statistics and the
# board's admission rules (JSON and CSV only).
ANALYSIS_MAY_IMPORT = (
    "cpg_suite.cli",
    "cpg_suite.protocol.stats",
    "cpg_suite.protocol.aggregate",
    "cpg_suite.protocol.admission",
    "cpg_suite.protocol.files",  # a run's files read strictly: JSON and CSV, no simulation
)
# The protocol package itself (not its submodules): its seeds, tiers and versions, data
# that the board reads by name (one definition of the tiers; admission imports it too).
ANALYSIS_MAY_IMPORT_EXACTLY = ("cpg_suite.protocol",)
SIMULATION = ("mujoco", "dm_control", "dm_env", "gymnasium", "torch", "ray")


def _modules() -> dict[str, str]:
    found = {}
    for package in PACKAGES:
        for dirpath, _, names in os.walk(os.path.join(ROOT, package)):
            for name in names:
                if name.endswith(".py"):
                    rel = os.path.relpath(os.path.join(dirpath, name), ROOT)[:-3]
                    module = rel.replace(os.sep, ".").removesuffix(".__init__")
                    found[module] = os.path.join(dirpath, name)
    return found


def _imports(module: str, path: str, known: dict) -> set[str]:
    """Names of what `module` imports: our modules resolved, third-party as written."""
    with open(path, encoding="utf-8") as f:
        tree = ast.parse(f.read())
    is_package = path.endswith("__init__.py")
    out = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            out.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                parts = module.split(".")[: len(module.split(".")) - node.level + is_package]
                base = ".".join(parts + ([base] if base else []))
            for alias in node.names:
                full = f"{base}.{alias.name}"
                out.add(full if full in known else base)
    return out


def _graph() -> dict[str, set[str]]:
    known = _modules()
    graph = {}
    for module, path in known.items():
        edges = set()
        for name in _imports(module, path, known):
            while name and name not in known and "." in name:
                name = name.rsplit(".", 1)[0]
            if name in known and name != module:
                edges.add(name)
            elif name not in known:
                edges.add(name)  # third-party, kept for the simulation check
        graph[module] = edges
    return graph


def _is_within(name: str, prefix: str) -> bool:
    return name == prefix or name.startswith(prefix + ".")


def test_no_import_cycle():
    graph = _graph()
    state, stack, cycles = {}, [], []

    def visit(node):
        state[node] = "open"
        stack.append(node)
        for nxt in graph.get(node, ()):
            if nxt not in graph:
                continue
            if state.get(nxt) == "open":
                cycles.append(stack[stack.index(nxt) :] + [nxt])
            elif nxt not in state:
                visit(nxt)
        stack.pop()
        state[node] = "done"

    for node in sorted(graph):
        if node not in state:
            visit(node)
    assert not cycles, "import cycles:\n" + "\n".join(" -> ".join(c) for c in cycles)


def test_the_benchmark_imports_no_contestant_and_no_analysis():
    bad = [
        f"{m} imports {n}"
        for m, edges in _graph().items()
        if _is_within(m, "cpg_suite")
        for n in edges
        if _is_within(n, "baselines") or _is_within(n, "analysis")
    ]
    assert not bad, "\n".join(bad)


def test_no_method_imports_another_method():
    graph = _graph()
    bad = []
    for module, edges in graph.items():
        mine = [m for m in METHODS if _is_within(module, m)]
        for name in edges:
            theirs = [m for m in METHODS if _is_within(name, m)]
            if mine and theirs and theirs != mine:
                bad.append(f"{module} imports {name}")
    assert not bad, "\n".join(bad)


def test_analysis_imports_no_simulation_code():
    bad = []
    for module, edges in _graph().items():
        if not _is_within(module, "analysis"):
            continue
        for name in edges:
            ours = _is_within(name, "cpg_suite") or _is_within(name, "baselines")
            allowed = any(_is_within(name, a) for a in ANALYSIS_MAY_IMPORT)
            allowed = allowed or name in ANALYSIS_MAY_IMPORT_EXACTLY
            simulation = any(_is_within(name, s) for s in SIMULATION)
            if (ours and not allowed) or simulation:
                bad.append(f"{module} imports {name}")
    assert not bad, "\n".join(bad)


def _dynamic_imports(path: str) -> set[str]:
    """Modules named by a constant in `importlib.import_module(...)` or `__import__(...)`."""
    with open(path, encoding="utf-8") as f:
        tree = ast.parse(f.read())
    out = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Call) and node.args:
            func = node.func
            name = func.attr if isinstance(func, ast.Attribute) else getattr(func, "id", "")
            first = node.args[0]
            if name in ("import_module", "__import__") and isinstance(first, ast.Constant):
                out.add(str(first.value))
    return out


def test_the_protocol_imports_nothing_of_the_harness():
    """`protocol` (what a run is scored by) imports nothing of `harness` (what trains it),
    and `runfiles` (the run folder's files, which both read and write) imports neither.
    Deferred imports count, and modules named to `importlib` too."""
    graph, known = _graph(), _modules()
    rules = {
        "cpg_suite.protocol": ("cpg_suite.harness",),
        "cpg_suite.runfiles": ("cpg_suite.harness", "cpg_suite.protocol"),
    }
    bad = []
    for module, edges in sorted(graph.items()):
        for package, forbidden in rules.items():
            if _is_within(module, package):
                names = edges | _dynamic_imports(known[module])
                bad += [
                    f"{module} imports {name}"
                    for name in sorted(names)
                    if any(_is_within(name, f) for f in forbidden)
                ]
    assert not bad, "\n".join(bad)
    # The rules see both packages and what they share.
    assert {"cpg_suite.runfiles.runs", "cpg_suite.runfiles.exported"} <= graph[
        "cpg_suite.protocol.verify"
    ]
    assert "cpg_suite.runfiles.sb3_policy" in graph["cpg_suite.protocol.verify"]  # deferred
    assert "cpg_suite.protocol" in graph["cpg_suite.harness.sb3"]  # the intended direction


def test_the_graph_sees_the_packages():
    graph = _graph()
    assert "cpg_suite.runfiles.runs" in graph["baselines.cem"] or any(
        _is_within(n, "cpg_suite.harness") for n in graph["baselines.cem"]
    )
    assert len(graph) > 50


def test_short_public_names_are_the_benchmark_objects():
    import importlib

    import cpg_suite

    for name, target in cpg_suite._PUBLIC.items():
        module, _, attribute = target.partition(":")
        assert getattr(cpg_suite, name) is getattr(importlib.import_module(module), attribute)
        assert name in dir(cpg_suite)


# The modules of the extras that use Gymnasium (gym, rl, mjx); every other module is the
# core's and imports without it.
_GYMNASIUM_MODULES = (
    "cpg_suite.gym",
    "cpg_suite.vector",
    "cpg_suite.harness.learner",
    "cpg_suite.harness.sb3",
    "cpg_suite.runfiles.sb3_policy",
    "cpg_suite.mjx",
    "baselines.ppo",
    "baselines.ppo_mjx",
)


def test_the_core_imports_without_gymnasium():
    """Gymnasium is the gym extra's: every module but those of the extras that use it (the
    tasks, the baselines' main jobs, scoring, verify, submit, the board) imports with it
    blocked, and the Gymnasium interfaces say in one line what to install."""
    import subprocess
    import sys

    code = (
        "import importlib, pkgutil, sys\n"
        "class Block:\n"
        "    def find_spec(self, name, path=None, target=None):\n"
        "        if name.split('.')[0] == 'gymnasium':\n"
        "            raise ImportError('blocked')\n"
        "sys.meta_path.insert(0, Block())\n"
        f"extras = {_GYMNASIUM_MODULES!r}\n"
        "for package in ('cpg_suite', 'baselines', 'analysis'):\n"
        "    path = importlib.import_module(package).__path__\n"
        "    for info in pkgutil.walk_packages(path, package + '.'):\n"
        "        if not info.name.startswith(extras):\n"
        "            importlib.import_module(info.name)\n"
        "for name in ('cpg_suite.gym', 'cpg_suite.vector'):\n"
        "    try:\n"
        "        importlib.import_module(name)\n"
        "    except ImportError as e:\n"
        "        assert \"pip install 'cpg-suite[gym]'\" in str(e), e\n"
        "    else:\n"
        "        raise AssertionError(name + ' imported without Gymnasium')\n"
    )
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=ROOT)
    assert done.returncode == 0, done.stderr[-1000:]

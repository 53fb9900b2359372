"""Runs one command with each bad value of each of its flags; prints a JSON line per case.

    python tests/cli_flag_cases.py MODULE ALARM_S [BASE_ARG ...]

Used by tests/test_cli_flags.py. The command's module is imported once (with what it
imports); then, per case, a forked child changes into an empty folder, runs the module's
`if __name__ == "__main__":` statements (its flags, then `cli.run(main, ...)`) with
`argv = BASE_ARGS + ["--FLAG=VALUE"]`, and is stopped by SIGALRM after ALARM_S seconds if
it is still running (it took the value and started work). A case reports the exit code
(−14 for stopped), the number of stderr lines and the last of them, and every file or
folder the child created in its folder.
"""

from __future__ import annotations

import ast
import importlib
import json
import os
import signal
import sys
import tempfile
import traceback

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
BAD_NUMBERS = ("nan", "inf", "-inf", "0", "-1", "1e300")
UNKNOWN = "no_such_value"
_KINDS = {
    "IntegerParser": "int",
    "FloatParser": "float",
    "EnumParser": "enum",
    "EnumClassParser": "enum",
    "ArgumentParser": "string",
    "ListParser": "list",
    "BooleanParser": "bool",
}


def values_for(kind: str) -> tuple[str, ...]:
    """The bad values a flag of this kind is fed."""
    if kind in ("int", "float"):
        return BAD_NUMBERS
    if kind in ("enum", "string", "list"):
        return (UNKNOWN,)
    return ()  # booleans: every value means something


def _main_statements(path: str) -> tuple:
    """The module's `__main__` statements, compiled: without and with `cli.run(...)`."""
    with open(path, encoding="utf-8") as f:
        tree = ast.parse(f.read())
    body = []
    for node in tree.body:
        test = node.test if isinstance(node, ast.If) else None
        if isinstance(test, ast.Compare) and ast.unparse(test.left) == "__name__":
            body.extend(node.body)

    def runs(statement) -> bool:
        call = statement.value if isinstance(statement, ast.Expr) else None
        return isinstance(call, ast.Call) and ast.unparse(call.func) == "cli.run"

    def compiled(statements):
        return compile(ast.Module(body=statements, type_ignores=[]), path, "exec")

    return compiled([s for s in body if not runs(s)]), compiled(body)


def _flags_defined(module, define_code) -> dict[str, str]:
    """{flag: kind} of the flags the command defines (absl's own left out).

    The definitions run here once, so that whatever they import is loaded before the
    cases fork; then the flags are removed again, for each case to define them afresh.
    """
    from absl import app, flags, logging  # noqa: F401  (absl's own flags: not the command's)

    before = set(flags.FLAGS)
    exec(define_code, module.__dict__)
    added = set(flags.FLAGS) - before
    kinds = {n: _KINDS.get(type(flags.FLAGS[n].parser).__name__, "other") for n in added}
    for name in added:
        delattr(flags.FLAGS, name)
    return kinds


def _case(module, code, argv: list[str], alarm: float) -> dict:
    """Runs the command once in a forked child; what it did."""
    logs, folder = tempfile.mkdtemp(), tempfile.mkdtemp()
    pid = os.fork()
    if pid == 0:
        status = 70
        try:
            os.chdir(folder)
            for fd, name in ((1, "stdout"), (2, "stderr")):
                os.dup2(os.open(os.path.join(logs, name), os.O_WRONLY | os.O_CREAT), fd)
            sys.argv = argv
            signal.setitimer(signal.ITIMER_REAL, alarm)
            exec(code, module.__dict__)
            status = 0
        except SystemExit as e:
            status = e.code if isinstance(e.code, int) else int(e.code is not None)
        except BaseException:
            traceback.print_exc()
        finally:
            sys.stdout.flush()
            sys.stderr.flush()
            os._exit(status)
    _, status = os.waitpid(pid, 0)
    with open(os.path.join(logs, "stderr"), errors="replace") as f:
        err = f.read().splitlines()
    created = sorted(
        os.path.relpath(os.path.join(d, n), folder)
        for d, dirs, files in os.walk(folder)
        for n in dirs + files
    )
    return {
        "code": os.waitstatus_to_exitcode(status),
        "lines": len(err),
        "last": err[-1] if err else "",
        "created": created[:5],
    }


def main(argv: list[str]) -> None:
    name, alarm, base = argv[0], float(argv[1]), argv[2:]
    sys.path.insert(0, ROOT)
    os.environ.setdefault("MUJOCO_GL", "disable")  # what cli.without_rendering() sets
    module = importlib.import_module(name)
    define_code, run_code = _main_statements(module.__file__)
    for flag, kind in sorted(_flags_defined(module, define_code).items()):
        for value in values_for(kind):
            args = [a for a in base if not a.startswith(f"--{flag}=")] + [f"--{flag}={value}"]
            result = _case(module, run_code, [module.__file__, *args], alarm)
            print(json.dumps({"flag": flag, "kind": kind, "value": value, **result}), flush=True)


if __name__ == "__main__":
    main(sys.argv[1:])

"""cpg_suite: dm_control-style tasks from Duarte's study of RL for central pattern generators.

Usage mirrors `dm_control.suite`::

    import cpg_suite
    env = cpg_suite.load('pole_balance')          # or cpg_suite.load('pole', 'balance')
    time_step = env.reset()

Task ids are `<domain>_<task>`; `ALL_TASKS`, `BENCHMARKING` and `TASKS_BY_DOMAIN` hold
`(domain, task)` pairs as in dm_control. A method of your own needs only this package:
`cpg_suite.score_gait` / `score_policy` (the test protocol's score card; `format_card`
prints one), `cpg_suite.submit_gait` with a `Submission` (a gait entered on the board),
`cpg_suite.open_evaluator` (batched trials), `cpg_suite.run_optimizer` with `AskTell`,
`OptimizerSettings` and `RunOptions` (training, validation and test of an ask/tell
optimizer); docs/architecture.md#packages-and-data-flow says where everything lives.

Importing the package changes no process-wide state: no environment variables, random
generators, logging, warning filters or absl flags, and does not load dm_control: the
domains load on first use. Rendering uses whatever backend dm_control's `MUJOCO_GL` selects
when it loads; on a machine without a display set `MUJOCO_GL=egl` (GPU or Mesa EGL) or
`MUJOCO_GL=osmesa` (software) before then. Without a display and without `MUJOCO_GL`,
dm_control's first choice, GLFW, cannot start; the package loads its modules without the
warning that GLFW prints then (`_import`), so a program that never renders prints nothing,
and one that renders still hears why it cannot.
"""

from __future__ import annotations

import collections
import functools
import importlib
import importlib.util
import inspect
import math
import numbers
import os
import sys
import warnings
from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:
    from dm_control.rl import control

__version__ = "0.1.0"

# The domain modules; each registers its tasks in its SUITE. They (and with them dm_control)
# are imported on first use, so that a program can choose MuJoCo's rendering backend after
# `import cpg_suite` (`cpg_suite.cli.without_rendering`).
_DOMAIN_NAMES = ("crawler", "darwin", "pole")
# The task lists, computed from the domains' SUITEs on first access.
_TASK_LISTS = (
    "ALL_TASKS",
    "BENCHMARKING",
    "EXTRA",
    "NO_REWARD_VIZ",
    "REWARD_VIZ",
    "TASKS_BY_DOMAIN",
    "TASK_IDS",
)


def _import(module: str) -> Any:
    """Imports `module`, without GLFW's warning on a machine without a display.

    dm_control chooses its OpenGL backend when it is first imported. With `MUJOCO_GL` unset
    it tries GLFW first, and on a machine without a display GLFW warns "The DISPLAY
    environment variable is missing" (and renders nothing). While this import runs, and only
    then, warnings raised by the `glfw` module are ignored; the warning filters are restored
    afterwards. With a display or `MUJOCO_GL` set, or once the module is loaded, this is a
    plain import: a broken display or an explicit `MUJOCO_GL=glfw` still warns.

    Args:
      module: The module's dotted name.

    Returns:
      The module.
    """
    if (
        module in sys.modules
        or "MUJOCO_GL" in os.environ
        or os.environ.get("DISPLAY")
        or os.environ.get("WAYLAND_DISPLAY")
    ):
        return importlib.import_module(module)
    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", module=r"glfw\Z")
        return importlib.import_module(module)


def _domains() -> dict[str, Any]:
    return {name: _import(f"cpg_suite.{name}") for name in _DOMAIN_NAMES}


def _get_tasks(tag: str | None) -> tuple[tuple[str, str], ...]:
    result = []
    for domain_name, module in sorted(_domains().items()):
        tasks = module.SUITE if tag is None else module.SUITE.tagged(tag)
        result.extend((domain_name, task_name) for task_name in tasks.keys())
    return tuple(result)


def _get_tasks_by_domain(tasks) -> dict[str, tuple[str, ...]]:
    result = collections.defaultdict(list)
    for domain_name, task_name in tasks:
        result[domain_name].append(task_name)
    return {k: tuple(v) for k, v in result.items()}


@functools.cache
def _task_lists() -> dict[str, Any]:
    all_tasks = _get_tasks(tag=None)
    benchmarking = _get_tasks("benchmarking")  # the tasks the study reports numbers on
    no_reward_viz = _get_tasks("no_reward_visualization")
    return {
        "ALL_TASKS": all_tasks,
        "BENCHMARKING": benchmarking,
        "EXTRA": tuple(sorted(set(all_tasks) - set(benchmarking))),
        "NO_REWARD_VIZ": no_reward_viz,
        "REWARD_VIZ": tuple(sorted(set(all_tasks) - set(no_reward_viz))),
        "TASKS_BY_DOMAIN": _get_tasks_by_domain(all_tasks),
        "TASK_IDS": tuple(f"{d}_{t}" for d, t in all_tasks),  # '<domain>_<task>'
    }


# Short, stable names for what a user's own method calls, each `module:attribute` of the
# benchmark (imported on first use): score a gait or a policy on the test protocol, evaluate
# candidates, run an ask/tell optimizer through training, selection and test.
_PUBLIC = {
    "score_gait": "cpg_suite.protocol.score:score_gait",
    "score_policy": "cpg_suite.protocol.score:score_policy",
    "ScoreSettings": "cpg_suite.protocol.score:ScoreSettings",
    "format_card": "cpg_suite.protocol.score:format_card",
    "Submission": "cpg_suite.protocol.submit:Submission",
    "submit_gait": "cpg_suite.protocol.submit:submit_gait",
    "open_evaluator": "cpg_suite.evaluation:open_evaluator",
    "OptimizerSettings": "cpg_suite.harness.interface:OptimizerSettings",
    "RunOptions": "cpg_suite.runfiles.runs:RunOptions",
    "AskTell": "cpg_suite.harness.optimize:AskTell",
    "run_optimizer": "cpg_suite.harness.optimize:run",
}


def __getattr__(name: str) -> Any:
    if name in _TASK_LISTS:
        return _task_lists()[name]
    if name in _PUBLIC:
        module, _, attribute = _PUBLIC[name].partition(":")
        return getattr(_import(module), attribute)
    # A submodule: `cpg_suite.darwin`, and `from cpg_suite import darwin` (which asks for the
    # attribute before it imports the submodule), load through `_import`.
    if not name.startswith("_") and importlib.util.find_spec(f"cpg_suite.{name}") is not None:
        return _import(f"cpg_suite.{name}")
    raise AttributeError(f"module 'cpg_suite' has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_TASK_LISTS) | set(_DOMAIN_NAMES) | set(_PUBLIC))


def split_task_id(task_id: str) -> tuple[str, str]:
    """Splits `'<domain>_<task>'` into `(domain, task)`.

    Raises:
      ValueError: If `task_id` is not a known task id; the message lists the valid ids.
    """
    domain, _, task = str(task_id).partition("_")
    lists = _task_lists()
    if (domain, task) not in lists["ALL_TASKS"]:
        raise ValueError(f"unknown task {task_id!r}; valid tasks: {', '.join(lists['TASK_IDS'])}")
    return domain, task


def _checked_task_kwargs(factory, task_id: str, task_kwargs: dict | None) -> dict:
    """`task_kwargs` as a dict, after the checks every task shares: known names, a seed
    (`random`: None, an integer ≥ 0 or a `numpy.random.RandomState`) and a time limit
    (`time_limit`: > 0 seconds, or inf for none, as in dm_control). The factories check
    their own physical settings.

    Raises:
      ValueError: Naming the keyword and what is valid.
    """
    task_kwargs = dict(task_kwargs or {})
    known = [n for n in inspect.signature(factory).parameters if n != "environment_kwargs"]
    unknown = sorted(set(task_kwargs) - set(known))
    if unknown:
        raise ValueError(f"unknown task_kwargs {unknown} for {task_id}; valid: {', '.join(known)}")
    random = task_kwargs.get("random")
    if not (
        random is None
        or isinstance(random, np.random.RandomState)
        or (isinstance(random, numbers.Integral) and not isinstance(random, bool) and random >= 0)
    ):
        raise ValueError(
            f"task_kwargs random must be None, an integer ≥ 0 or a RandomState, got {random!r}"
        )
    if "time_limit" in task_kwargs:
        limit = task_kwargs["time_limit"]
        if not (
            isinstance(limit, numbers.Real)
            and (limit == float("inf") or (math.isfinite(limit) and limit > 0))
        ):
            raise ValueError(f"task_kwargs time_limit must be > 0 s or inf, got {limit!r}")
    return task_kwargs


def load(
    domain_name: str,
    task_name: str | None = None,
    task_kwargs: dict | None = None,
    environment_kwargs: dict | None = None,
    visualize_reward: bool = False,
) -> control.Environment:
    """Returns a task's environment, like `dm_control.suite.load`.

    `load('pole_balance')` and `load('pole', 'balance')` are the same.

    Args:
      domain_name: A domain name, or a whole task id when `task_name` is omitted.
      task_name: The task within the domain.
      task_kwargs: Keyword arguments for the task factory (e.g. `random`, `time_limit`).
      environment_kwargs: Keyword arguments for `control.Environment`.
      visualize_reward: Colour the model by the current reward when rendering.

    Returns:
      A `dm_control.rl.control.Environment` (a `dm_env.Environment`).

    Raises:
      ValueError: If the task does not exist (the message lists the valid task ids), or a
        task keyword is unknown or out of its range (the message names it).
    """
    if task_name is None:
        domain_name, task_name = split_task_id(domain_name)
    elif (domain_name, task_name) not in _task_lists()["ALL_TASKS"]:
        raise ValueError(
            f"unknown task {domain_name!r}/{task_name!r}; valid tasks: "
            f"{', '.join(_task_lists()['TASK_IDS'])}"
        )
    factory = _domains()[domain_name].SUITE[task_name]
    task_kwargs = _checked_task_kwargs(factory, f"{domain_name}_{task_name}", task_kwargs)
    if environment_kwargs is not None:
        task_kwargs["environment_kwargs"] = environment_kwargs
    env = factory(**task_kwargs)
    env.task.visualize_reward = visualize_reward
    return env

"""cpg_suite: dm_control-style tasks from Duarte's study of RL for central pattern generators.

Usage mirrors `dm_control.suite`::

    import cpg_suite
    env = cpg_suite.load('pole_balance')          # or cpg_suite.load('pole', 'balance')
    time_step = env.reset()

Task ids are `<domain>_<task>`; `ALL_TASKS`, `BENCHMARKING` and `TASKS_BY_DOMAIN` hold
`(domain, task)` pairs as in dm_control.

Importing the package changes no process-wide state: no environment variables, random
generators, logging or absl flags. Rendering uses whatever backend MuJoCo's `MUJOCO_GL`
selects; on a machine without a display set `MUJOCO_GL=egl` (GPU or Mesa EGL) or
`MUJOCO_GL=osmesa` (software) before the first import of dm_control.
"""

from __future__ import annotations

import collections
import inspect

from dm_control.rl import control

# Each domain module registers its tasks in its SUITE.
from cpg_suite import crawler, darwin, pole  # noqa: F401

__version__ = "0.1.0"

_DOMAINS = {
    name: module
    for name, module in locals().items()
    if inspect.ismodule(module) and hasattr(module, "SUITE")
}


def _get_tasks(tag: str | None) -> tuple[tuple[str, str], ...]:
    result = []
    for domain_name in sorted(_DOMAINS):
        suite = _DOMAINS[domain_name].SUITE
        tasks = suite if tag is None else suite.tagged(tag)
        result.extend((domain_name, task_name) for task_name in tasks.keys())
    return tuple(result)


def _get_tasks_by_domain(tasks) -> dict[str, tuple[str, ...]]:
    result = collections.defaultdict(list)
    for domain_name, task_name in tasks:
        result[domain_name].append(task_name)
    return {k: tuple(v) for k, v in result.items()}


# All (domain, task) pairs.
ALL_TASKS = _get_tasks(tag=None)
# The tasks the study reports numbers on.
BENCHMARKING = _get_tasks("benchmarking")
EXTRA = tuple(sorted(set(ALL_TASKS) - set(BENCHMARKING)))
NO_REWARD_VIZ = _get_tasks("no_reward_visualization")
REWARD_VIZ = tuple(sorted(set(ALL_TASKS) - set(NO_REWARD_VIZ)))
TASKS_BY_DOMAIN = _get_tasks_by_domain(ALL_TASKS)
# Task ids: '<domain>_<task>'.
TASK_IDS = tuple(f"{d}_{t}" for d, t in ALL_TASKS)


def split_task_id(task_id: str) -> tuple[str, str]:
    """Splits `'<domain>_<task>'` into `(domain, task)`.

    Raises:
      ValueError: If `task_id` is not a known task id; the message lists the valid ids.
    """
    domain, _, task = str(task_id).partition("_")
    if (domain, task) not in ALL_TASKS:
        raise ValueError(f"unknown task {task_id!r}; valid tasks: {', '.join(TASK_IDS)}")
    return domain, task


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
      ValueError: If the task does not exist; the message lists the valid task ids.
    """
    if task_name is None:
        domain_name, task_name = split_task_id(domain_name)
    elif (domain_name, task_name) not in ALL_TASKS:
        raise ValueError(
            f"unknown task {domain_name!r}/{task_name!r}; valid tasks: {', '.join(TASK_IDS)}"
        )
    task_kwargs = dict(task_kwargs or {})
    if environment_kwargs is not None:
        task_kwargs["environment_kwargs"] = environment_kwargs
    env = _DOMAINS[domain_name].SUITE[task_name](**task_kwargs)
    env.task.visualize_reward = visualize_reward
    return env

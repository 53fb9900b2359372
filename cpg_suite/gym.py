"""Gymnasium registration of every cpg_suite task, through shimmy's dm_control wrapper.

    import gymnasium
    import cpg_suite.gym  # registers cpg_suite/<task_id>-v0
    env = gymnasium.make("cpg_suite/pole_balance-v0")
    observation, info = env.reset(seed=0)

or, without the import, `gymnasium.make("cpg_suite.gym:cpg_suite/pole_balance-v0")`.
The DARwIn-OP walking tiers have a vector entry point: `gymnasium.make_vec(
"cpg_suite/darwin_walk-v0", num_envs=16)` returns `cpg_suite.vector.DarwinVectorEnv`
(the physics of all sub-environments stepped in C threads; `vectorization_mode="sync"`
gives Gymnasium's `SyncVectorEnv` over single environments instead).
Needs the `gym` extra (`pip install 'cpg-suite[gym]'`). Observations are dicts of arrays,
as in dm_env; episodes end as in the task (a fall terminates, the time limit truncates);
`reset(seed=...)` seeds the task's random generator. Keyword arguments of `make` other
than `render_mode` / `render_kwargs` go to the task (e.g. `time_limit`, `force`).
"""

from __future__ import annotations

try:
    import gymnasium
except ImportError as e:  # the core install: one line that says what to install
    raise ImportError(f"cpg_suite.gym needs Gymnasium: pip install 'cpg-suite[gym]' ({e})") from e
from gymnasium.envs.registration import register

import cpg_suite


def make_env(
    task_id: str, render_mode: str | None = None, render_kwargs: dict | None = None, **task_kwargs
) -> gymnasium.Env:
    """A Gymnasium environment of a cpg_suite task.

    Args:
      task_id: The task, e.g. `"darwin_walk"`.
      render_mode: `None`, `"rgb_array"` or `"human"` (shimmy's).
      render_kwargs: Passed to the physics' render (e.g. `camera_id`, `height`, `width`).
      **task_kwargs: Passed to the task factory.

    Returns:
      The shimmy-wrapped environment.
    """
    from shimmy import DmControlCompatibilityV0

    env = cpg_suite.load(task_id, task_kwargs=task_kwargs or None)
    return DmControlCompatibilityV0(env, render_mode=render_mode, render_kwargs=render_kwargs)


ENV_IDS = tuple(f"cpg_suite/{task_id}-v0" for task_id in cpg_suite.TASK_IDS)

for _task_id, _env_id in zip(cpg_suite.TASK_IDS, ENV_IDS):
    if _env_id not in gymnasium.registry:
        register(
            id=_env_id,
            entry_point="cpg_suite.gym:make_env",
            # The walking tiers also vectorize natively (`cpg_suite.vector`).
            vector_entry_point=(
                "cpg_suite.vector:make_vector_env" if _task_id.startswith("darwin_walk") else None
            ),
            kwargs={"task_id": _task_id},
        )

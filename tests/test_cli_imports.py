"""The command-line modules are importable together: no flags, no environment changes.

Each CLI defines its absl flags only when it runs as a program (`define_flags()` under
`if __name__ == "__main__":`), so importing several of them in one process neither raises
`DuplicateFlagError` nor defines a flag, and none of them (nor the rendering library)
touches `os.environ` — `MUJOCO_GL` included — when imported.
"""

import json
import os
import subprocess
import sys

import pytest

_MODULES = (
    "cpg_suite.evaluation.evaluate",
    "baselines.experiments.calibrate_cpg",
    "cpg_suite.explore",
    "baselines.nac",
    "baselines.experiments.nac_experiments",
    "cpg_suite.render",
    "cpg_suite.evaluation.gait",
    "cpg_suite.vector",
    "cpg_suite.residual",
)
_RL = ("torch", "stable_baselines3")  # the rl extra: baselines.ppo imports them

_CODE = r"""
import importlib, json, os
from absl import flags
# Third-party import-time effects are not ours: import them first.
import dm_control.suite, mujoco, pandas, tqdm, gymnasium  # noqa
for name in THIRD_PARTY:
    importlib.import_module(name)
flags_before, environ_before = set(flags.FLAGS), dict(os.environ)
for name in MODULES:
    importlib.import_module(name)
print(json.dumps({
    "new_flags": sorted(set(flags.FLAGS) - flags_before),
    "environ_same": dict(os.environ) == environ_before,
    "mujoco_gl": os.environ.get("MUJOCO_GL"),
}))
"""


@pytest.mark.parametrize("rl", [False, pytest.param(True, marks=pytest.mark.slow)])
def test_cli_modules_import_together_without_flags_or_environment_changes(rl):
    """Without and (the slow tier's rl extra) with baselines.ppo, torch and SB3."""
    for name in _RL if rl else ():
        pytest.importorskip(name)
    env = {k: v for k, v in os.environ.items() if k not in ("MUJOCO_GL", "DISPLAY")}
    modules = _MODULES + (("baselines.ppo",) if rl else ())
    code = f"MODULES = {modules!r}\nTHIRD_PARTY = {_RL if rl else ()!r}\n" + _CODE
    out = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, env=env, timeout=300
    )
    assert out.returncode == 0, out.stderr[-3000:]
    report = json.loads(out.stdout.strip().splitlines()[-1])
    assert report == {"new_flags": [], "environ_same": True, "mujoco_gl": None}


def test_settings_are_checked_by_the_library():
    import pytest

    from baselines import nac
    from baselines.experiments import calibrate_cpg, nac_experiments
    from cpg_suite import render
    from cpg_suite.evaluation import evaluate

    for make, words in [
        (lambda: evaluate.EvaluateSettings(seeds="3-1"), "malformed seeds"),
        (lambda: evaluate.EvaluateSettings(task="pole_balance"), "unknown --task"),
        (lambda: calibrate_cpg.CalibrationSettings(periods="a"), "--periods"),
        (lambda: nac.NACSettings(gamma=1.0), "--gamma"),
        (lambda: nac_experiments.NACExperimentSettings(seeds=1), "--seeds"),
        (lambda: render.RenderSettings(frames=0), "--frames"),
    ]:
        with pytest.raises(ValueError, match=words):
            make()
    assert evaluate.EvaluateSettings(seeds="0,2-3").seed_list() == [0, 2, 3]

"""Typed settings of the tabular CLI and experiment scripts; config.json re-runs the run."""

import dataclasses
import json
import shlex
import shutil
import subprocess
import sys

import pytest

from baselines.experiments import crawler_experiments, pole_claims
from baselines.tabular import runner
from baselines.tabular.settings import DEFAULTS, TabularSettings, default_epsilon


def _python(*args, cwd=None):
    return subprocess.run(
        [sys.executable, *args], capture_output=True, text=True, timeout=300, cwd=cwd
    )


def _without_wall_time(summary: dict) -> dict:
    return {k: v for k, v in summary.items() if k != "wall_s"}


@pytest.mark.parametrize(
    "args",
    [
        ["--model=tokic", "--algo=value_iteration", "--sweeps=3"],
        ["--model=tokic", "--algo=q_learning", "--steps=300", "--epsilon=0.2", "--seed=3"],
    ],
)
def test_recorded_command_reruns_to_the_same_summary(tmp_path, args):
    out = _python("-m", "baselines.tabular", *args, f"--output_dir={tmp_path}")
    assert out.returncode == 0, out.stderr
    (config_path,) = tmp_path.glob("*/tokic/*/config.json")
    run_dir = config_path.parent
    config = json.loads(config_path.read_text())
    first = json.loads((run_dir / "summary.json").read_text())
    command = shlex.split(config["command"])
    assert command[:3] == ["python", "-m", "baselines.tabular"]
    shutil.rmtree(run_dir)
    again = _python(*command[1:], cwd=tmp_path)
    assert again.returncode == 0, again.stderr
    assert _without_wall_time(json.loads((run_dir / "summary.json").read_text())) == (
        _without_wall_time(first)
    )
    rerun = json.loads(config_path.read_text())["settings"]
    assert rerun == {**config["settings"], "run_name": run_dir.name}  # now explicit


def test_config_settings_are_the_settings_dataclass(tmp_path):
    settings = TabularSettings(
        model="tokic", algo="value_iteration", sweeps=1, output_dir=str(tmp_path)
    )
    run_dir, _ = runner.execute(settings)
    config = json.loads((tmp_path / "value_iteration/tokic/seed0/config.json").read_text())
    assert config["settings"] == dataclasses.asdict(settings)
    assert "--run_name=seed0" in config["command"] and "--overwrite" not in config["command"]
    assert run_dir.endswith("seed0")


def test_settings_validate_with_one_line_reasons():
    with pytest.raises(ValueError, match=r"--alpha must be a finite number in \[0, 1\], got 1.5"):
        TabularSettings(task="pole_balance", alpha=1.5)
    with pytest.raises(ValueError, match="exactly one"):
        TabularSettings()
    with pytest.raises(ValueError, match="malformed bins"):
        TabularSettings(task="pole_balance", bins="20x")
    with pytest.raises(dataclasses.FrozenInstanceError):
        TabularSettings(model="tokic").seed = 1  # type: ignore[misc]
    assert set(DEFAULTS) == {f.name for f in dataclasses.fields(TabularSettings)}


def test_default_epsilon_is_the_crawler_schedule_only_on_the_crawler():
    assert default_epsilon(TabularSettings(task="crawler_walk")) == runner.CRAWLER_EPSILON
    assert default_epsilon(TabularSettings(task="pole_balance")) == "0"
    assert default_epsilon(TabularSettings(model="tokic", epsilon="0.1")) == "0.1"


def test_experiment_settings_validate():
    with pytest.raises(ValueError, match="--seeds must be ≥ 2"):
        pole_claims.PoleClaimsSettings(seeds=1)
    with pytest.raises(ValueError, match="--moves must be ≥ 300"):
        crawler_experiments.CrawlerExperimentSettings(moves=10)
    settings = pole_claims.run_settings(pole_claims.CONFIGS[0], 2, "out", 100)
    assert settings.run_name == "base_seed2" and settings.steps == 100


def test_cli_modules_import_together_without_defining_flags():
    code = (
        "from absl import flags;"
        "import baselines.tabular.__main__, baselines.experiments.pole_claims, "
        "baselines.experiments.crawler_experiments;"
        "ours = [m for m in flags.FLAGS.flags_by_module_dict() if 'baselines' in m];"
        "assert not ours, ours"
    )
    out = _python("-c", code)
    assert out.returncode == 0, out.stderr

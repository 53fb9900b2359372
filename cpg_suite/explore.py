r"""Render a CPG gait of the DARwIn-OP headlessly: a video and a filmstrip PNG.

  MUJOCO_GL=egl python -m cpg_suite.explore --task=darwin_walk --params=hand_tuned --out=DIR

Rendering lives in `cpg_suite.render`; without a display and without `MUJOCO_GL` this
command renders with EGL. Writes `DIR/<params>.mp4` (or `.gif` when imageio/ffmpeg are not
installed; the `plots` extra installs them) and `DIR/<params>_filmstrip.png`: `--frames`
snapshots taken evenly
over the trial from the tracking side camera, left to right, each stamped with its time.
`--params` takes a preset (`hand_tuned`, `table6_1`, `table6_2`) or a JSON file of the 11
amplitudes by name.
"""

from __future__ import annotations

import dataclasses
import os
import sys

import numpy as np
from absl import flags

from cpg_suite import cpg, darwin
from cpg_suite.render import filmstrip, render_gait, write_video

DARWIN_TASKS = ("darwin_walk", "darwin_balance")


def define_flags() -> None:
    """Defines this module's command-line flags (only when it runs as a program)."""
    global \
        _TASK, \
        _PARAMS, \
        _OUT, \
        _SEED, \
        _STEPS, \
        _CAMERA, \
        _STRIP_CAMERA, \
        _WIDTH, \
        _HEIGHT, \
        _EVERY, \
        _FRAMES, \
        _STRIP_START, \
        _STRIP_STEP, \
        _FORMAT
    _TASK = flags.DEFINE_string("task", "darwin_walk", f"One of {', '.join(DARWIN_TASKS)}.")
    _PARAMS = flags.DEFINE_string("params", "hand_tuned", "Preset or JSON file of amplitudes.")
    _OUT = flags.DEFINE_string("out", "renders", "Output directory.")
    _SEED = flags.DEFINE_integer("seed", 0, "Initial-state seed.")
    _STEPS = flags.DEFINE_integer("steps", 1000, "Control steps (16 ms each).")
    _CAMERA = flags.DEFINE_string("camera", "side", "Camera of the video.")
    _STRIP_CAMERA = flags.DEFINE_string(
        "strip_camera", "front", "Camera of the filmstrip (the front view shows the feet lift)."
    )
    _WIDTH = flags.DEFINE_integer("width", 480, "Frame width, pixels.")
    _HEIGHT = flags.DEFINE_integer("height", 360, "Frame height, pixels.")
    _EVERY = flags.DEFINE_integer("every", 2, "Render every N control steps (2: 31 fps).")
    _FRAMES = flags.DEFINE_integer("frames", 8, "Snapshots in the filmstrip.")
    _STRIP_START = flags.DEFINE_float("strip_start", 5.0, "Time of the first snapshot, s.")
    _STRIP_STEP = flags.DEFINE_float(
        "strip_step", None, "Time between snapshots, s (default: a quarter of the stride period)."
    )
    _FORMAT = flags.DEFINE_enum("format", "auto", ["auto", "mp4", "gif"], "Video format.")


def _fail(message: str) -> None:
    sys.stderr.write(f"error: {message}\n")
    raise SystemExit(2)


@dataclasses.dataclass(frozen=True)
class RenderSettings:
    """What to render and how (the flags of `python -m cpg_suite.explore`); validated."""

    task: str = "darwin_walk"
    params: str = "hand_tuned"
    out: str = "renders"
    seed: int = 0
    steps: int = 1000
    camera: str = "side"
    strip_camera: str = "front"
    width: int = 480
    height: int = 360
    every: int = 2
    frames: int = 8
    strip_start: float = 5.0
    strip_step: float | None = None
    format: str = "auto"

    def __post_init__(self):
        if self.task not in DARWIN_TASKS:
            raise ValueError(
                f"unknown --task {self.task!r}; explore renders CPG gaits on: "
                f"{', '.join(DARWIN_TASKS)}"
            )
        for name, low in (("steps", 1), ("width", 16), ("height", 16), ("every", 1), ("frames", 1)):
            if getattr(self, name) < low:
                raise ValueError(f"--{name} must be ≥ {low}, got {getattr(self, name)}")
        if self.strip_start < 0 or (self.strip_step is not None and self.strip_step <= 0):
            raise ValueError("--strip_start must be ≥ 0 and --strip_step > 0")

    def amplitudes(self) -> np.ndarray:
        """The gait: a preset or a JSON file of amplitudes (ValueError if neither)."""
        if os.path.isfile(self.params):
            return cpg.load_amplitudes(self.params)
        return cpg.amplitudes_from(self.params)


def _check_cameras(cameras: list[str]) -> None:
    model = darwin.Physics.from_xml_string(*darwin.get_model_and_assets()).model
    known = [model.id2name(i, "camera") for i in range(model.ncam)]
    for camera in cameras:
        if camera not in known:
            _fail(f"unknown camera {camera!r}; valid: {', '.join(known)}")


def render(settings: RenderSettings, amplitudes: np.ndarray) -> tuple[str, str, str]:
    """Renders the gait's video and filmstrip into `settings.out`.

    Returns:
      `(video path, filmstrip path, status)`.
    """
    os.makedirs(settings.out, exist_ok=True)
    name = os.path.splitext(os.path.basename(settings.params))[0]
    cameras = list(dict.fromkeys([settings.camera, settings.strip_camera]))
    frames, times, fell_at = render_gait(
        settings.task,
        amplitudes,
        settings.seed,
        settings.steps,
        cameras,
        settings.width,
        settings.height,
        settings.every,
    )
    fps = 1.0 / (darwin.CONTROL_TIMESTEP * settings.every)
    video = write_video(frames[0], os.path.join(settings.out, name), fps, settings.format)
    strip_path = os.path.join(settings.out, f"{name}_filmstrip.png")
    step = settings.strip_step or cpg.CPGConfig().stride_period / 4
    strip = filmstrip(frames[-1], times, settings.frames, name, settings.strip_start, step)
    strip.save(strip_path)
    status = f"fell at step {fell_at}" if fell_at else "no fall"
    return video, strip_path, f"{len(times)} frames, {status}"


def main(argv):
    if len(argv) > 1:
        _fail(f"unexpected arguments {argv[1:]}; all options are --flags")
    fields = [f.name for f in dataclasses.fields(RenderSettings)]
    try:
        settings = RenderSettings(**{n: flags.FLAGS[n].value for n in fields})
        amplitudes = settings.amplitudes()
    except ValueError as e:
        _fail(
            f"--params: {e}"
            if str(e).startswith(("unknown amplitude", "amplitudes", "expected"))
            else str(e)
        )
    try:
        import PIL  # noqa: F401
    except ImportError:
        _fail("rendering needs Pillow: pip install 'cpg-suite[plots]'")
    _check_cameras([settings.camera, settings.strip_camera])
    video, strip_path, status = render(settings, amplitudes)
    print(f"{video}\n{strip_path}\n{status}")


def _choose_backend() -> None:
    """Renders with EGL when no backend is chosen and there is no display.

    MuJoCo's backend is fixed when dm_control is first imported, which has happened by
    the time this module runs; so the command starts itself again with `MUJOCO_GL=egl`.
    Only this program's process is affected, never a program that imports cpg_suite.
    """
    if "MUJOCO_GL" not in os.environ and not os.environ.get("DISPLAY"):
        env = {**os.environ, "MUJOCO_GL": "egl"}
        os.execve(sys.executable, [sys.executable, "-m", "cpg_suite.explore", *sys.argv[1:]], env)


if __name__ == "__main__":
    _choose_backend()
    define_flags()
    from absl import app

    # Parse errors are one line with exit code 2, as for the baselines.
    def _parse(argv):
        try:
            return flags.FLAGS(argv)
        except flags.Error as e:
            _fail(str(e).splitlines()[0])

    app.run(main, flags_parser=_parse)

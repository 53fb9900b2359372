r"""Render a CPG gait of the DARwIn-OP headlessly: a video and a filmstrip PNG.

  MUJOCO_GL=egl python -m cpg_suite.explore --task=darwin_walk --params=hand_tuned --out=DIR

Writes `DIR/<params>.mp4` (or `.gif` when imageio/ffmpeg are not installed; the `plots`
extra installs them) and `DIR/<params>_filmstrip.png`: `--frames` snapshots taken evenly
over the trial from the tracking side camera, left to right, each stamped with its time.
`--params` takes a preset (`hand_tuned`, `table6_1`, `table6_2`) or a JSON file of the 11
amplitudes by name.
"""

from __future__ import annotations

import os
import sys

import numpy as np
from absl import app, flags

import cpg_suite
from cpg_suite import cpg, darwin

DARWIN_TASKS = ("darwin_walk", "darwin_balance")

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


def render_gait(
    task: str,
    amplitudes: np.ndarray,
    seed: int = 0,
    steps: int = 1000,
    cameras=("side",),
    width: int = 480,
    height: int = 360,
    every: int = 2,
    config: cpg.CPGConfig | None = None,
):
    """Runs an open-loop CPG gait and renders it from one or more cameras.

    Returns:
      `(frames, times, fell_at)`: uint8 frames (cameras, N, H, W, 3), their times in s, and
      the control step of a fall (or None).
    """
    config = config or cpg.CPGConfig()
    env = cpg_suite.load(
        task, task_kwargs={"random": seed, "posture": config.offsets(), "time_limit": float("inf")}
    )
    physics = env.physics
    pattern = cpg.CPG(amplitudes, config)
    dt = env.control_timestep()
    env.reset()
    frames, times, fell_at = [], [], None

    def snap(t):
        frames.append([physics.render(height, width, camera_id=c) for c in cameras])
        times.append(t * dt)

    for t in range(steps):
        if t % every == 0:
            snap(t)
        if env.step(physics.targets_to_action(pattern.step(dt))).last():
            fell_at = t + 1
            snap(t + 1)
            break
    return np.array(frames).swapaxes(0, 1), np.array(times), fell_at


def filmstrip(
    frames: np.ndarray,
    times: np.ndarray,
    count: int,
    label: str = "",
    start: float | None = None,
    step: float | None = None,
):
    """`count` snapshots side by side, stamped with their times.

    Snapshots are taken every `step` seconds from `start` (a quarter stride apart they show
    the feet lifting in turn); when that runs past the end of the recording (a fall), or
    no start is given, they are spread evenly over the whole recording.
    """
    from PIL import Image, ImageDraw

    if start is not None and step is not None and start + (count - 1) * step <= times[-1]:
        wanted = start + step * np.arange(count)
        picks = np.abs(times[None, :] - wanted[:, None]).argmin(axis=1)
    else:
        picks = np.linspace(0, len(frames) - 1, count).round().astype(int)
    h, w = frames.shape[1:3]
    strip = Image.new("RGB", (w * count, h + 24), (20, 22, 26))
    draw = ImageDraw.Draw(strip)
    for i, k in enumerate(picks):
        strip.paste(Image.fromarray(frames[k]), (i * w, 24))
        draw.text((i * w + 6, 5), f"t = {times[k]:.2f} s", fill=(230, 230, 230))
    if label:
        draw.text((strip.width - 8 * len(label) - 6, 5), label, fill=(250, 200, 120))
    return strip


def write_video(frames: np.ndarray, path_stem: str, fps: float, fmt: str = "auto") -> str:
    """Writes an MP4 (imageio + ffmpeg) or, failing that or on request, a GIF (Pillow)."""
    if fmt in ("auto", "mp4"):
        try:
            import imageio.v2 as imageio

            path = path_stem + ".mp4"
            imageio.mimwrite(path, list(frames), fps=fps, macro_block_size=8)
            return path
        except Exception as e:  # imageio raises several kinds here.
            if fmt == "mp4":
                raise RuntimeError(f"cannot write MP4 ({e}); install cpg-suite[plots]") from e
    from PIL import Image

    path = path_stem + ".gif"
    images = [Image.fromarray(f) for f in frames]
    images[0].save(path, save_all=True, append_images=images[1:], duration=int(1000 / fps), loop=0)
    return path


def main(argv):
    if len(argv) > 1:
        _fail(f"unexpected arguments {argv[1:]}; all options are --flags")
    if _TASK.value not in DARWIN_TASKS:
        _fail(
            f"unknown --task {_TASK.value!r}; explore renders CPG gaits on: "
            f"{', '.join(DARWIN_TASKS)}"
        )
    for name, flag, low in (
        ("steps", _STEPS, 1),
        ("width", _WIDTH, 16),
        ("height", _HEIGHT, 16),
        ("every", _EVERY, 1),
        ("frames", _FRAMES, 1),
    ):
        if flag.value < low:
            _fail(f"--{name} must be ≥ {low}, got {flag.value}")
    if _STRIP_START.value < 0 or (_STRIP_STEP.value is not None and _STRIP_STEP.value <= 0):
        _fail("--strip_start must be ≥ 0 and --strip_step > 0")
    try:
        if os.path.isfile(_PARAMS.value):
            amplitudes = cpg.load_amplitudes(_PARAMS.value)
        else:
            amplitudes = cpg.amplitudes_from(_PARAMS.value)
    except ValueError as e:
        _fail(f"--params: {e}")
    try:
        import PIL  # noqa: F401
    except ImportError:
        _fail("rendering needs Pillow: pip install 'cpg-suite[plots]'")
    os.makedirs(_OUT.value, exist_ok=True)
    name = os.path.splitext(os.path.basename(_PARAMS.value))[0]
    cameras = list(dict.fromkeys([_CAMERA.value, _STRIP_CAMERA.value]))
    model = darwin.Physics.from_xml_string(*darwin.get_model_and_assets()).model
    known = [model.id2name(i, "camera") for i in range(model.ncam)]
    for camera in cameras:
        if camera not in known:
            _fail(f"unknown camera {camera!r}; valid: {', '.join(known)}")
    frames, times, fell_at = render_gait(
        _TASK.value,
        amplitudes,
        _SEED.value,
        _STEPS.value,
        cameras,
        _WIDTH.value,
        _HEIGHT.value,
        _EVERY.value,
    )
    video = write_video(
        frames[0], os.path.join(_OUT.value, name), 1.0 / (0.016 * _EVERY.value), _FORMAT.value
    )
    strip_path = os.path.join(_OUT.value, f"{name}_filmstrip.png")
    step = _STRIP_STEP.value or cpg.CPGConfig().stride_period / 4
    filmstrip(frames[-1], times, _FRAMES.value, name, _STRIP_START.value, step).save(strip_path)
    status = f"fell at step {fell_at}" if fell_at else "no fall"
    print(f"{video}\n{strip_path}\n{len(times)} frames, {status}")


if __name__ == "__main__":
    # Parse errors are one line with exit code 2, as for the baselines.
    def _parse(argv):
        try:
            return flags.FLAGS(argv)
        except flags.Error as e:
            _fail(str(e).splitlines()[0])

    app.run(main, flags_parser=_parse)

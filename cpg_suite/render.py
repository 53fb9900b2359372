"""Rendering open-loop CPG gaits of the DARwIn-OP: frames, filmstrips and videos (library).

Rendering needs an OpenGL backend chosen with `MUJOCO_GL` before dm_control is first
imported (`egl` or `osmesa` on a machine without a display); this module never sets it
(`cpg_suite.cli.choose_renderer` does, for the program that renders).
The command line is `python -m cpg_suite.explore`; `RenderSettings` are its flags and
`render_files` what it runs.
"""

from __future__ import annotations

import dataclasses
import os

import numpy as np

import cpg_suite
from cpg_suite import cli, cpg, darwin

# The tasks a CPG gait is rendered on.
RENDER_TASKS = ("darwin_walk", "darwin_balance")


@dataclasses.dataclass(frozen=True)
class RenderSettings:
    """What to render and how (the flags of `python -m cpg_suite.explore`); validated.

    Attributes:
      task: `darwin_walk` or `darwin_balance`.
      params: A preset (`hand_tuned`, `table6_1`, `table6_2`) or a JSON file of amplitudes;
        its base name names the output files.
      out: Output directory.
      seed: Initial-state seed.
      steps: Control steps (16 ms each).
      camera: Camera of the video.
      strip_camera: Camera of the filmstrip.
      width: Frame width, pixels.
      height: Frame height, pixels.
      every: Render every N control steps.
      frames: Snapshots in the filmstrip.
      strip_start: Time of the first snapshot, s.
      strip_step: Time between snapshots, s (None: a quarter of the stride period).
      format: Video format: `auto` (MP4, else GIF), `mp4` or `gif`.
    """

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
        if self.task not in RENDER_TASKS:
            raise ValueError(
                f"unknown --task {self.task!r}; explore renders CPG gaits on: "
                f"{', '.join(RENDER_TASKS)}"
            )
        for name, low in (
            ("seed", 0),
            ("steps", 1),
            ("width", 16),
            ("height", 16),
            ("every", 1),
            ("frames", 1),
        ):
            if getattr(self, name) < low:
                raise ValueError(f"--{name} must be ≥ {low}, got {getattr(self, name)}")
        # Snapshots past the trial's end fall back to frames spread over the whole recording
        # (`filmstrip`); the upper end, an hour, is a choice.
        cli.require_number("strip_start", self.strip_start, 0, 3600.0)
        if self.strip_step is not None:
            cli.require_number("strip_step", self.strip_step, 0, 3600.0, low_open=True)
        if self.format not in ("auto", "mp4", "gif"):
            raise ValueError(f"--format must be auto, mp4 or gif, got {self.format!r}")

    def amplitudes(self) -> np.ndarray:
        """The gait: a preset or a JSON file of amplitudes.

        Returns:
          The 11 amplitudes, degrees.

        Raises:
          ValueError: If `params` is neither a preset nor a valid amplitudes file.
        """
        if os.path.isfile(self.params):
            return cpg.load_amplitudes(self.params)
        return cpg.amplitudes_from(self.params)


def camera_names() -> list[str]:
    """The DARwIn-OP model's cameras, by name."""
    model = darwin.Physics.from_xml_string(*darwin.get_model_and_assets()).model
    return [model.id2name(i, "camera") for i in range(model.ncam)]


def check_cameras(cameras) -> None:
    """Checks that the model has each camera.

    Raises:
      ValueError: Naming the first unknown camera and the valid ones.
    """
    known = camera_names()
    for camera in cameras:
        if camera not in known:
            raise ValueError(f"unknown camera {camera!r}; valid: {', '.join(known)}")


def render_files(
    settings: RenderSettings, amplitudes: np.ndarray | None = None
) -> tuple[str, str, str]:
    """Renders the gait's video and filmstrip into `settings.out`.

    Writes `<out>/<name>.mp4` (or `.gif`) from `settings.camera` and
    `<out>/<name>_filmstrip.png` from `settings.strip_camera`, where `<name>` is the base
    name of `settings.params` without its extension.

    Args:
      settings: What to render and how.
      amplitudes: The gait (None: `settings.amplitudes()`).

    Returns:
      `(video path, filmstrip path, status)`, the status counting frames and telling
      whether and when the robot fell.

    Raises:
      ValueError: If the gait cannot be read.
      RuntimeError: If an MP4 was asked for and cannot be written.
    """
    amplitudes = settings.amplitudes() if amplitudes is None else amplitudes
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

    Args:
      task: A DARwIn-OP task id (`RENDER_TASKS`).
      amplitudes: The 11 amplitudes, degrees.
      seed: The task's random seed (initial-state perturbation).
      steps: Control steps.
      cameras: Camera names; a frame is rendered from each.
      width: Frame width, pixels.
      height: Frame height, pixels.
      every: Render every N control steps (and at a fall).
      config: CPG constants (the task starts in the CPG's standing posture).

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

    Args:
      frames: uint8 frames (N, H, W, 3) of one camera.
      times: Their times, s.
      count: Snapshots in the strip.
      label: Text at the top right (e.g. the gait's name).
      start: Time of the first snapshot, s.
      step: Time between snapshots, s.

    Returns:
      A PIL image: the snapshots left to right under a 24-pixel band of times.
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
    """Writes an MP4 (imageio + ffmpeg) or, failing that or on request, a GIF (Pillow).

    Args:
      frames: uint8 frames (N, H, W, 3).
      path_stem: The path without its extension.
      fps: Frames per second.
      fmt: `auto` (MP4, else GIF), `mp4` or `gif`.

    Returns:
      The path written.

    Raises:
      RuntimeError: If `fmt` is `mp4` and no MP4 can be written.
    """
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

"""Rendering open-loop CPG gaits of the DARwIn-OP: frames, filmstrips and videos (library).

Rendering needs an OpenGL backend chosen with `MUJOCO_GL` before dm_control is first
imported (`egl` or `osmesa` on a machine without a display); this module never sets it.
The command line is `python -m cpg_suite.explore`.
"""

from __future__ import annotations

import numpy as np

import cpg_suite
from cpg_suite import cpg


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

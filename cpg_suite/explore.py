r"""Render a CPG gait of the DARwIn-OP headlessly: a video and a filmstrip PNG.

  python -m cpg_suite.explore --task=darwin_walk --params=hand_tuned --out=DIR

Rendering lives in `cpg_suite.render` (`RenderSettings`, `render_files`); this module is
the command line. Without a display and without `MUJOCO_GL` the command renders with the
first headless backend that works here (EGL, then OSMesa), or says in one line that none
does.
Writes `DIR/<params>.mp4` (or `.gif` when imageio/ffmpeg are not installed; the `plots`
extra installs them) and `DIR/<params>_filmstrip.png`: `--frames` snapshots taken evenly
over the trial from the tracking side camera, left to right, each stamped with its time.
`--params` takes a preset (`hand_tuned`, `table6_1`, `table6_2`) or a JSON file of the 11
amplitudes by name.

Importing this module defines no flags and leaves `os.environ` alone; the rendering
backend is chosen in the `__main__` block, before anything of this module renders.
"""

from __future__ import annotations

if __name__ == "__main__":  # this program renders: a backend that works, chosen before dm_control
    from cpg_suite import cli

    cli.choose_renderer()

import dataclasses
import os

from absl import flags

from cpg_suite import cli


def define_flags() -> None:
    """Defines this module's command-line flags (only when it runs as a program)."""
    from cpg_suite.render import RENDER_TASKS

    flags.DEFINE_string("task", "darwin_walk", f"One of {', '.join(RENDER_TASKS)}.")
    flags.DEFINE_string("params", "hand_tuned", "Preset or JSON file of amplitudes.")
    flags.DEFINE_string("out", "renders", "Output directory.")
    flags.DEFINE_integer("seed", 0, "Initial-state seed.")
    flags.DEFINE_integer("steps", 1000, "Control steps (16 ms each).")
    flags.DEFINE_string("camera", "side", "Camera of the video.")
    flags.DEFINE_string(
        "strip_camera", "front", "Camera of the filmstrip (the front view shows the feet lift)."
    )
    flags.DEFINE_integer("width", 480, "Frame width, pixels.")
    flags.DEFINE_integer("height", 360, "Frame height, pixels.")
    flags.DEFINE_integer("every", 2, "Render every N control steps (2: 31 fps).")
    flags.DEFINE_integer("frames", 8, "Snapshots in the filmstrip.")
    flags.DEFINE_float("strip_start", 5.0, "Time of the first snapshot, s.")
    flags.DEFINE_float(
        "strip_step", None, "Time between snapshots, s (default: a quarter of the stride period)."
    )
    flags.DEFINE_enum("format", "auto", ["auto", "mp4", "gif"], "Video format.")


def main(argv: list[str]) -> None:
    """Renders the gait the flags name; bad input is a `cli.UsageError`."""
    del argv  # `cli.run` rejects positional arguments
    from cpg_suite import render  # loads dm_control, after the backend is chosen

    fields = [f.name for f in dataclasses.fields(render.RenderSettings)]
    try:
        settings = render.RenderSettings(**{n: flags.FLAGS[n].value for n in fields})
        amplitudes = settings.amplitudes()
    except ValueError as e:
        raise cli.UsageError(
            f"--params: {e}"
            if str(e).startswith(("unknown amplitude", "amplitudes", "expected"))
            else str(e)
        ) from None
    try:
        import PIL  # noqa: F401
    except ImportError:
        raise cli.UsageError("rendering needs Pillow: pip install 'cpg-suite[plots]'") from None
    try:
        render.check_cameras([settings.camera, settings.strip_camera])
    except ValueError as e:
        raise cli.UsageError(str(e)) from None
    cli.check(
        os.environ.get("MUJOCO_GL") != "disable",
        "MUJOCO_GL=disable turns rendering off: unset it (a backend is then chosen) or set "
        "MUJOCO_GL=egl or osmesa",
    )
    video, strip_path, status = render.render_files(settings, amplitudes)
    print(f"{video}\n{strip_path}\n{status}")


if __name__ == "__main__":
    define_flags()
    cli.run(main, output_dirs=("out",))

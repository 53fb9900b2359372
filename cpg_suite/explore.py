r"""Render a CPG gait of the DARwIn-OP headlessly: a video and a filmstrip PNG.

  MUJOCO_GL=egl python -m cpg_suite.explore --task=darwin_walk --params=hand_tuned --out=DIR

Rendering lives in `cpg_suite.render` (`RenderSettings`, `render_files`); this module is
the command line. Without a display and without `MUJOCO_GL` the command renders with EGL.
Writes `DIR/<params>.mp4` (or `.gif` when imageio/ffmpeg are not installed; the `plots`
extra installs them) and `DIR/<params>_filmstrip.png`: `--frames` snapshots taken evenly
over the trial from the tracking side camera, left to right, each stamped with its time.
`--params` takes a preset (`hand_tuned`, `table6_1`, `table6_2`) or a JSON file of the 11
amplitudes by name.

Importing this module defines no flags and leaves `os.environ` alone; the rendering
backend is chosen in the `__main__` block, before anything of this module renders.
"""

from __future__ import annotations

import dataclasses
import os
import sys

from absl import flags

# Modules whose import fixes MuJoCo's rendering backend from `MUJOCO_GL`.
_BACKEND_MODULES = ("mujoco", "dm_control._render")


def define_flags() -> None:
    """Defines this module's command-line flags (only when it runs as a program)."""
    from cpg_suite.render import RENDER_TASKS  # after the backend is chosen

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


def _fail(message: str) -> None:
    # cpg_suite does not import baselines: the same one-line error as `baselines.cli.fail`.
    sys.stderr.write(f"error: {message}\n")
    raise SystemExit(2)


def main(argv):
    # Imported here, after the `__main__` block has chosen the rendering backend.
    from cpg_suite import render

    if len(argv) > 1:
        _fail(f"unexpected arguments {argv[1:]}; all options are --flags")
    fields = [f.name for f in dataclasses.fields(render.RenderSettings)]
    try:
        settings = render.RenderSettings(**{n: flags.FLAGS[n].value for n in fields})
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
    try:
        render.check_cameras([settings.camera, settings.strip_camera])
    except ValueError as e:
        _fail(str(e))
    video, strip_path, status = render.render_files(settings, amplitudes)
    print(f"{video}\n{strip_path}\n{status}")


def _choose_backend() -> None:
    """Renders with EGL when no backend is chosen and there is no display.

    Only this program's process is affected, never a program that imports cpg_suite.
    MuJoCo's backend is fixed when mujoco or dm_control's renderer is first imported: if
    neither has been yet, `MUJOCO_GL=egl` is set here; otherwise (`python -m` imports the
    `cpg_suite` package, and with it dm_control, before this module runs) the command
    starts itself again with `MUJOCO_GL=egl`.
    """
    if "MUJOCO_GL" in os.environ or os.environ.get("DISPLAY"):
        return
    if not any(name in sys.modules for name in _BACKEND_MODULES):
        os.environ["MUJOCO_GL"] = "egl"
        return
    env = {**os.environ, "MUJOCO_GL": "egl"}
    os.execve(sys.executable, [sys.executable, "-m", "cpg_suite.explore", *sys.argv[1:]], env)


def _parse_flags(argv: list[str]) -> list[str]:
    # Parse errors are one line with exit code 2, as for the baselines.
    try:
        return flags.FLAGS(argv)
    except flags.Error as e:
        _fail(str(e).splitlines()[0])
        raise  # unreachable


if __name__ == "__main__":
    _choose_backend()
    define_flags()
    from absl import app

    app.run(main, flags_parser=_parse_flags)

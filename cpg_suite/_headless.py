"""dm_control's modules that load its renderer, imported without GLFW's warning.

`dm_control.mujoco` (and `dm_control.suite.base`, which imports it) choose an OpenGL
backend when first imported; with `MUJOCO_GL` unset on a machine without a display, GLFW
warns "The DISPLAY environment variable is missing". The package's modules take them from
here, so that whichever module a program imports first, the import is quiet
(`cpg_suite._import`: the warning is ignored while the import runs, and only then).
"""

import cpg_suite

mujoco = cpg_suite._import("dm_control.mujoco")
suite_base = cpg_suite._import("dm_control.suite.base")

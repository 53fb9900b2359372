"""DARwIn-OP domain: the humanoid of the study, walking or balancing on a CPG (thesis Ch. 5-6).

Model (`xml/darwin.xml`) from docs/darwin_op_model.md: 20 joints with the Webots axes, ranges,
masses, centres of mass and inertias (total 2.925 kg); box feet 0.105 × 0.066 m; torso IMU
(accelerometer, gyro, orientation) and a touch sensor under each sole. Decisions:

* **Torso centre of mass**: the Webots value (−0.050, 0, −0.080) m, not the CAD-derived
  (−0.019, −0.003, −0.039) (docs/darwin_op_model.md#masses). The study's numbers come from
  the Webots model, so we keep its mass distribution; the whole-robot centre of mass then sits 13 mm
  behind the foot centres, inside the 105 mm long support.
* **Servos** (MX-28, docs/darwin_op_model.md#servos-dynamixel-mx-28): MuJoCo position
  actuators with kp = 40 N·m/rad and a torque limit of 2.5 N·m (stall torque at 12 V);
  joint damping 0.43 N·m·s/rad, the slope of the MX-28 torque-speed line (2.5 N·m stall /
  5.76 rad/s no-load), i.e. the back-EMF braking of the motor; armature 0.005 kg·m² (a
  coreless rotor of about 1.3e-7 kg·m² reflected through the 193:1 gearbox). The sources
  give no SI stiffness; kp was chosen with `python -m baselines.experiments.calibrate_cpg`.
* **Contacts**: soft-ish rubber soles (friction 1.0, solref 0.008 s); the feet collide with
  each other and with the floor, every other robot geom only with the floor.
* **Timing**: physics step 2 ms (implicit-fast integrator), control step 16 ms (the Webots
  DARwIn-OP worlds' basic time step), 1000 control steps = 16 s per episode.
* **Pose**: arms hang 10° out from the body with the elbows bent 30°, head level; the
  task holds them with their servos (not part of the action). The legs start in the CPG's
  standing posture (its offsets O), feet flat on the floor, each leg joint perturbed by
  U(−0.01, 0.01) rad from the task's random generator.
* **Fall**: the torso origin (shoulder axis) below 0.22 m (0.34 m standing) or the torso
  tilted more than 50° from upright.

Tasks (`tasks`): `walk` and `balance` (the study's), and the test tiers `walk_randomized`,
`walk_push`, `walk_rough` and `walk_contact`; control step 16 ms, 1000 steps, action = the
12 leg joint targets in [−1, 1]. `cpg_suite.load("darwin_walk")` loads them as dm_control's
suite does.

The package, laid out as a dm_control domain with its parts apart:

* `tasks`: the suite (`SUITE`), the tasks' environments and `CPGTask`;
* `physics`: `Physics`, the named accessors the tasks read on every control step;
* `robot`: the model's MJCF and assets, the names of its parts, the fall test;
* `recording`: what a physics records after each physics step, and the supply current;
* `checks`: the model's checks at load and the state's after every step;
* `pose`: the standing pose; `contacts`: the feet's loads, centres of pressure and the
  balance reward; `perturb`: the test tiers' and the servos' physical parameters.

The domain's public names are this package's (`darwin.Physics`, `darwin.walk`,
`darwin.CONTROL_TIMESTEP`, `darwin.has_fallen`, ...), defined in the modules above.
"""

from cpg_suite.darwin.physics import Physics
from cpg_suite.darwin.pose import ARM_POSE
from cpg_suite.darwin.robot import (
    ARM_JOINTS,
    FLOOR_GEOM,
    FOOT_GEOMS,
    GROUND_GEOMS,
    get_model_and_assets,
    has_fallen,
    torso_upright,
)
from cpg_suite.darwin.tasks import (
    CONTROL_TIMESTEP,
    DEFAULT_TIME_LIMIT,
    INIT_NOISE,
    OBJECTIVES,
    OBSERVATION_KEYS,
    SUITE,
    CPGTask,
    balance,
    physics_steps_per_control_step,
    walk,
    walk_contact,
    walk_push,
    walk_randomized,
    walk_rough,
)

__all__ = [
    "ARM_JOINTS",
    "ARM_POSE",
    "CONTROL_TIMESTEP",
    "DEFAULT_TIME_LIMIT",
    "FLOOR_GEOM",
    "FOOT_GEOMS",
    "GROUND_GEOMS",
    "INIT_NOISE",
    "OBJECTIVES",
    "OBSERVATION_KEYS",
    "SUITE",
    "CPGTask",
    "Physics",
    "balance",
    "get_model_and_assets",
    "has_fallen",
    "physics_steps_per_control_step",
    "torso_upright",
    "walk",
    "walk_contact",
    "walk_push",
    "walk_randomized",
    "walk_rough",
]

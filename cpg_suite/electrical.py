"""The DARwIn-OP's servos and supply as electrical loads (docs/darwin_op_model.md#electrical-model).

Each servo is a Dynamixel MX-28: a DC motor behind a 193:1 gearbox, driven by a PWM bridge
from the robot's supply. In the MJCF model (`xml/darwin.xml`) the position actuator's force
f, clamped at the stall torque, is the torque the commanded voltage would give at standstill,
and the joint damping b (stall torque / no-load speed) is the motor's back-EMF braking. So,
per servo and physics step, with the datasheet's line at 12 V:

* commanded voltage   V_cmd = f·R / k_t                      (f = ±2.5 N·m ⇒ V_cmd = ±12 V)
* motor current       I = (f − b·q̇) / k_t                     (the joint's net motor torque / k_t)
* input power         P = V_cmd·I = I²R + k_e·q̇·I,  k_e = b·R / k_t
* copper loss         I²R;  the motor's mechanical power k_e·q̇·I, of which the joint gets
                      k_t·I·q̇ = (f − b·q̇)·q̇ and the gearbox the rest (k_t/k_e = 0.86)
* supply current      max(0, P) / V_supply + standby current

The bridge does not return power to the battery: a servo that brakes draws its standby
current and no less. The robot's supply current is the sum over all 20 servos (the arms and
head hold their pose and draw too), plus the CM-730 board and the on-board PC.

The supply's limit (`SupplyLimit`): the LiPo's continuous rating and the CM-730's fuse are
10 A. When the supply current averaged over the last `window` seconds exceeds it, the servos
brown out and the episode ends like a fall. Before the episode starts, the robot stood
powered and idle: the window's part before t = 0 counts `IDLE_CURRENT`.

Every path (the CPU task, the batched evaluators, the vector env, the scorer, the MJX env)
computes the same per-step currents with `supply_current` and the same window with
`SupplyMonitor` (`SupplyMonitor.update` accumulates the currents strictly in order, so a
trial's verdict does not depend on how its steps are chunked).
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

# Dynamixel MX-28 at 12 V (ROBOTIS e-Manual, MX-28; docs/darwin_op_model.md#servos-dynamixel-mx-28).
SUPPLY_VOLTAGE = (
    12.0  # V: the datasheet's voltage, the robot's supply (a choice: the LiPo is 11.1 V nominal)
)
STALL_TORQUE = 2.5  # N·m
STALL_CURRENT = 1.4  # A
NO_LOAD_SPEED = 55.0 * 2.0 * math.pi / 60.0  # rad/s: 55 rpm (5.76 rad/s)
STANDBY_CURRENT = 0.1  # A per servo, output off
TORQUE_CONSTANT = STALL_TORQUE / STALL_CURRENT  # k_t, N·m/A: 1.786
RESISTANCE = SUPPLY_VOLTAGE / STALL_CURRENT  # R, Ω: all of the stall voltage across the winding
STALL_COPPER_LOSS = STALL_CURRENT**2 * RESISTANCE  # W: 16.8, the most a servo draws
N_SERVOS = 20

# The rest of the robot (ROBOTIS e-Manual, ROBOTIS OP: specifications and CM-730).
BOARD_CURRENT = 0.15  # A: the CM-730 sub-controller
PC_POWER = 6.0  # W: the on-board PC draws 5-7 W; the middle (a choice)
IDLE_CURRENT = N_SERVOS * STANDBY_CURRENT + BOARD_CURRENT + PC_POWER / SUPPLY_VOLTAGE  # A: 2.65

# The supply's limit (ROBOTIS OP: 11.1 V 1000 mAh 10C LiPo, 10 A continuous; 10 A fuse).
SUPPLY_LIMIT = 10.0  # A
SUPPLY_WINDOW = 1.0  # s: the averaging window (a choice; results/protocol shows 0.25 s and ∞)

# Why a trial ended early (the card's failure causes).
CAUSES = ("fall", "brownout")


@dataclasses.dataclass(frozen=True)
class SupplyLimit:
    """The supply's limit: mean current over the last `window` seconds above `current`.

    Attributes:
      current: The limit, A.
      window: The averaging window, s; `math.inf` averages over the whole trial so far.
    """

    current: float = SUPPLY_LIMIT
    window: float = SUPPLY_WINDOW

    def __post_init__(self):
        if not (math.isfinite(self.current) and self.current > 0):
            raise ValueError(f"supply limit must be a positive number of A, got {self.current!r}")
        if not (self.window > 0):  # inf allowed: the whole trial
            raise ValueError(f"supply window must be > 0 s (or inf), got {self.window!r}")

    def window_steps(self, timestep: float) -> int | None:
        """The window in physics steps of `timestep` s (None: the whole trial).

        Raises:
          ValueError: If the window is shorter than one physics step.
        """
        if math.isinf(self.window):
            return None
        steps = int(round(self.window / timestep))
        if steps < 1:
            raise ValueError(f"supply window {self.window} s is under one physics step")
        return steps


DEFAULT_SUPPLY = SupplyLimit()  # the DARwIn-OP tasks' limit: 10 A over the last second


def motor_current(force, velocity, damping):
    """The motor's current, A: its net torque at the joint over k_t.

    Args:
      force: Actuator forces f (the commanded torque), N·m (any shape).
      velocity: Joint velocities q̇ of the same shape, rad/s.
      damping: The joints' damping b (back-EMF braking), N·m·s/rad, broadcastable.

    Returns:
      I = (f − b·q̇) / k_t, the shape of `force`.
    """
    return (force - damping * velocity) / TORQUE_CONSTANT


def input_power(force, velocity, damping):
    """Electrical power into each motor at its commanded voltage, W (negative: braking).

    Args: as for `motor_current`.

    Returns:
      P = V_cmd·I = (f·R/k_t)·(f − b·q̇)/k_t, which equals I²R + k_e·q̇·I.
    """
    return (force * (RESISTANCE / TORQUE_CONSTANT)) * motor_current(force, velocity, damping)


def copper_loss(force, velocity, damping):
    """The winding's resistive loss I²R, W."""
    current = motor_current(force, velocity, damping)
    return current * current * RESISTANCE


def motor_power(force, velocity, damping):
    """The motor's mechanical power k_e·q̇·I, W (k_e = b·R/k_t; input power − copper loss)."""
    return (
        (damping * (RESISTANCE / TORQUE_CONSTANT))
        * velocity
        * motor_current(force, velocity, damping)
    )


def supply_current(force, velocity, damping, xp=np):
    """The robot's supply current, A: all servos (no regeneration) plus the idle draw.

    Args:
      force: (..., N_SERVOS) actuator forces, N·m, in the model's actuator order.
      velocity: (..., N_SERVOS) the actuated joints' velocities, rad/s.
      damping: (N_SERVOS,) or broadcastable joint damping, N·m·s/rad.
      xp: The array module: `numpy`, or `jax.numpy` for traced arrays (`cpg_suite.mjx`).

    Returns:
      (...,) Σ max(0, P) / V_supply + `IDLE_CURRENT`.
    """
    power = xp.maximum(input_power(force, velocity, damping), 0.0)
    return xp.sum(power, axis=-1) / SUPPLY_VOLTAGE + IDLE_CURRENT


class SupplyMeter:
    """`supply_current` for NumPy arrays of a fixed shape, in buffers kept between calls.

    The same operations in the same order as `supply_current` (`motor_current`, then
    `input_power`, the floor at 0, the sum over the servos), so the same bits
    (`tests/test_electrical.py`), without allocating: the per-control-step hot path of the
    CPU tasks (`darwin.recording.supply_currents`).
    """

    def __init__(self, steps: int | tuple[int, ...], servos: int = N_SERVOS):
        """Args:
        steps: Physics steps per call (rows of `force` and `velocity`), or the shape of
          the leading axes (e.g. robots × physics steps).
        servos: Servos per step.
        """
        shape = (steps,) if isinstance(steps, int) else tuple(steps)
        self._current = np.zeros((*shape, servos))
        self._power = np.zeros((*shape, servos))
        self._total = np.zeros(shape)
        self._braking: np.ndarray | None = None  # `power_sums`' b·q̇ of every joint
        # The constants as 0-d arrays: NumPy converts a Python float on every call, which
        # costs more than the operation on these small arrays; the values are the same.
        self._constants = tuple(
            np.array(c, dtype=np.float64)
            for c in (
                TORQUE_CONSTANT,
                RESISTANCE / TORQUE_CONSTANT,
                0.0,
                SUPPLY_VOLTAGE,
                IDLE_CURRENT,
            )
        )

    def __call__(self, force: np.ndarray, velocity: np.ndarray, damping: np.ndarray) -> np.ndarray:
        """The supply current after each step, A, as `supply_current(force, velocity,
        damping)`; a buffer the next call overwrites.

        Args:
          force, velocity: (*steps, servos) float64 arrays; damping: broadcastable to them
            ((servos,), or (robots, 1, servos) for robots × steps).
        """
        torque_constant, volts_per_newton_metre, zero, supply_voltage, idle = self._constants
        current = np.multiply(damping, velocity, out=self._current)
        np.subtract(force, current, out=current)
        np.divide(current, torque_constant, out=current)  # `motor_current`
        power = np.multiply(force, volts_per_newton_metre, out=self._power)
        np.multiply(power, current, out=power)  # `input_power`
        np.maximum(power, zero, out=power)
        total = np.add.reduce(power, axis=-1, out=self._total)  # `np.sum`'s reduction
        np.divide(total, supply_voltage, out=total)
        return np.add(total, idle, out=total)

    def power_sums(
        self, force: np.ndarray, qvel: np.ndarray, dof_damping: np.ndarray, servo_index: np.ndarray
    ) -> np.ndarray:
        """Σ max(0, P) over the servos after each step: `supply_current` before its division
        by the supply voltage and its idle draw (`currents` or `SupplyMonitor.update_sums`
        add those), from every joint's velocity, in fewer NumPy calls than `__call__`.

        The same operations on the same numbers in the same order, so the same bits: the
        back-EMF torque b·q̇ of every joint (IEEE products commute: `damping * velocity`'s
        bits), taken at the servos' joints, then as `__call__` (`tests/test_electrical.py`).
        A buffer the next call overwrites.

        Args:
          force: (*steps, servos) actuator forces, N·m, in the model's actuator order.
          qvel: (*steps, nv) every joint's velocity after each step, rad/s.
          dof_damping: (nv,) every joint's damping, N·m·s/rad (the model's `dof_damping`),
            or broadcastable to `qvel` ((robots, 1, nv) for robots × steps).
          servo_index: The servos' entries of `qvel.ravel()`, row by row (`servo_index`
            of the steps of all leading axes).
        """
        torque_constant, volts_per_newton_metre, zero, _, _ = self._constants
        braking = self._braking
        if braking is None or braking.shape != qvel.shape:
            braking = self._braking = np.empty(qvel.shape)
        np.multiply(qvel, dof_damping, out=braking)
        current = self._current
        braking.reshape(-1).take(servo_index, None, current.reshape(-1), "wrap")
        np.subtract(force, current, out=current)
        np.divide(current, torque_constant, out=current)  # `motor_current`
        power = np.multiply(force, volts_per_newton_metre, out=self._power)
        np.multiply(power, current, out=power)  # `input_power`
        np.maximum(power, zero, out=power)
        return np.add.reduce(power, axis=-1, out=self._total)  # `np.sum`'s reduction

    def currents(self, sums: np.ndarray) -> np.ndarray:
        """The supply currents, A, from `power_sums`' sums (in place)."""
        _, _, _, supply_voltage, idle = self._constants
        np.divide(sums, supply_voltage, out=sums)
        return np.add(sums, idle, out=sums)


def servo_index(steps: int, servo_dofs: np.ndarray, nv: int) -> np.ndarray:
    """`SupplyMeter.power_sums`' index: the servos' joints' entries of a (steps, nv) array's
    `ravel()`, row by row.

    Args:
      steps: Physics steps (rows).
      servo_dofs: (servos,) each servo's joint address in `qvel`, in actuator order.
      nv: Joint velocities per step.
    """
    return (np.arange(steps)[:, None] * nv + np.asarray(servo_dofs)[None, :]).reshape(-1)


# From this many steps in one update, the monitor's sums run in NumPy (`_add_many`): below,
# Python floats cost less than NumPy's calls.
_IN_NUMPY_FROM = 64


class SupplyMonitor:
    """One trial's supply current, step by step: its running total and the limit's verdict.

    The running total T_k = T_{k−1} + i_k is accumulated strictly in order, so feeding the
    steps one control step or one segment at a time gives the same numbers. The mean over
    the window ending at step k is (T_k − T_{k−w}) / w, with T_j = j·`IDLE_CURRENT` for
    j < 0 (the idle robot before the start); over the whole trial it is T_k / k. Plain
    Python floats (IEEE doubles, as NumPy's): for the 8 steps of a control step they cost a
    fraction of NumPy's calls.
    """

    def __init__(self, limit: SupplyLimit, timestep: float, enforce: bool = True):
        """Args:
        limit: The supply's limit and window.
        timestep: The physics step, s.
        enforce: Whether the limit browns the servos out (False: measure only).
        """
        self.limit, self.enforce = limit, bool(enforce)
        self.timestep = float(timestep)
        self.window = limit.window_steps(self.timestep)
        self.reset()

    def reset(self) -> None:
        """Starts a new trial (t = 0)."""
        self.steps = 0
        self.total = 0.0  # T_k, A·steps
        self.worst = -math.inf  # the largest window mean so far, A
        # The ring of T_{k+1−w}, …, T_k: before the start, the idle robot's.
        w = self.window or 0
        self._ring = [float(j) * IDLE_CURRENT for j in range(1 - w, 1)]
        self.browned_out = 0  # 1-based physics step of the brown-out, 0: none

    def update(self, currents) -> int:
        """Adds the next physics steps' supply currents.

        Args:
          currents: (n,) supply currents of the next n physics steps, A (an array, or a
            list of Python floats).

        Returns:
          The 1-based index (among these n) of the first step whose window mean exceeds the
          limit, or 0. After a brown-out the monitor keeps measuring but reports no other.
        """
        if type(currents) is list and all(type(c) is float for c in currents):
            return self._add(currents)  # Python floats, as `tolist` gives them
        values = np.asarray(currents, dtype=np.float64)
        if len(values) >= _IN_NUMPY_FROM:
            return self._add_many(values)
        return self._add(values.tolist())

    def update_sums(self, sums: np.ndarray) -> int:
        """`update` with the currents' `SupplyMeter.power_sums` (Σ max(0, P) per step):
        each current is `sum / SUPPLY_VOLTAGE + IDLE_CURRENT` in Python floats, the IEEE
        operations `supply_current` takes, so the same bits.

        Args:
          sums: (n,) float64 sums of the next n physics steps, W.

        Returns:
          As `update`.
        """
        return self._add([s / SUPPLY_VOLTAGE + IDLE_CURRENT for s in sums.tolist()])

    def update_floats(self, currents: list[float]) -> int:
        """`update` of a list of Python floats (as `tolist` gives them), unchecked: the
        batched paths' (the vector env's and the closed-loop evaluator's) per-robot call.

        Args:
          currents: The next n physics steps' supply currents, A, each a Python float.

        Returns:
          As `update`.
        """
        return self._add(currents)

    def _add(self, values: list[float]) -> int:
        """`update` of Python floats."""
        if len(values) >= _IN_NUMPY_FROM:
            return self._add_many(np.array(values, dtype=np.float64))
        total, worst, k = self.total, self.worst, self.steps
        limit = self.limit.current if self.enforce and not self.browned_out else math.inf
        ring, w, first = self._ring, self.window, 0
        if w is None:
            for i, current in enumerate(values, 1):
                total = total + current
                mean = total / (k + i)
                if mean > worst:
                    worst = mean
                if mean > limit and not first:
                    first = i
        else:
            position = k % w  # ring[position] holds T_{k+i−w} at the i-th value
            for i, current in enumerate(values, 1):
                total = total + current
                mean = (total - ring[position]) / w
                ring[position] = total
                position += 1
                if position == w:
                    position = 0
                if mean > worst:
                    worst = mean
                if mean > limit and not first:
                    first = i
        if first:
            self.browned_out = k + first
        self.total, self.worst, self.steps = total, worst, k + len(values)
        return first

    def _add_many(self, values: np.ndarray) -> int:
        """`_add` over many steps in NumPy, with the same bits: the running totals are one
        `np.add.accumulate` (strictly in order, as the loop adds), each window's mean the
        same subtraction and division, the worst the largest mean that is a number."""
        k, n, w = self.steps, len(values), self.window
        totals = np.add.accumulate(np.concatenate([[self.total], values]))[1:]
        if w is None:
            means = totals / np.arange(k + 1, k + n + 1, dtype=np.float64)
        else:
            position = k % w
            before = np.array(self._ring[position:] + self._ring[:position])  # T_{k+1−w..k}
            earlier = np.concatenate([before, totals])
            means = (totals - earlier[:n]) / float(w)
            latest = earlier[-w:].tolist()  # T_{k+n+1−w..k+n}, ring[(k + n) % w] the first
            end = (k + n) % w
            self._ring = latest[w - end :] + latest[: w - end]
        numbers = means[~np.isnan(means)]
        if len(numbers):  # the first of the largest, as the loop keeps it (−0 before +0)
            largest = float(numbers[np.argmax(numbers)])
            if largest > self.worst:
                self.worst = largest
        first = 0
        if self.enforce and not self.browned_out:
            over = np.flatnonzero(means > self.limit.current)
            first = int(over[0]) + 1 if len(over) else 0
        if first:
            self.browned_out = k + first
        self.total, self.steps = float(totals[-1]), k + n
        return first

    def mean(self) -> float:
        """The trial's mean supply current so far, A (0 before the first step)."""
        return self.total / self.steps if self.steps else 0.0

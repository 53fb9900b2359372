"""Controllers exported as data: an MLP run with NumPy in the CPU task (no training
library), or an open-loop table of actions.

The format of `selected_policy.npz` (written by `NumpyPolicy.save`; `baselines.ppo_mjx`
exports Brax's PPO to it, `python -m cpg_suite.harness.sb3 --export` Stable-Baselines3's):
`mean`, `std` (observation normalization), `kernel_<i>`, `bias_<i>` (the dense layers, input
first), `action_space` ("joints" or "cpg") and `head` (`HEADS`; files without it are
"tanh_normal"). Optional, for what other learners compute (absent: Brax's PPO):

* `activation` between the layers (`ACTIVATIONS`; "swish" without it);
* `var`, `epsilon`, `clip_obs` in place of `std`: SB3's `VecNormalize`, the observation
  clip((x − mean)/√(var + epsilon), −clip_obs, clip_obs);
* `input_dtype` (`INPUT_DTYPES`; "float64" without it): "float32" rounds the normalized
  observation to float32 before the first layer (what SB3 hands torch);
* `action_low`, `action_high`: the box the "normal" head clips the action to (−1, 1
  without them);
* `amplitude_scale`, `rate_scale`: the `cpg` action space's corrections per unit action
  (`residual.ModulatedCPG`; its defaults without them).

The format of `selected_actions.npy` (written by `ActionTable.save`): one float64 array of
shape (control steps, 12), row t the task's action at control step t of a trial (0-based,
from the reset), each value in the action spec's [−1, 1]; a NumPy `.npy` file without
pickled objects.

`cpg_suite.protocol.verify` re-scores shipped runs of both formats; neither runs code when
it is loaded. Both are read by `load_npy` and `load_npz`, never by NumPy's loader: each
array's `.npy` header is checked before anything is allocated (`read_npy`: plain numbers
or text, never objects; exactly as many data bytes as its shape and type say), so a file
whose header lies about its size is refused in one line instead of allocating what it
claims.
"""

from __future__ import annotations

import io
import math
import os
import re
import zipfile
import zlib
from typing import BinaryIO

import numpy as np

import cpg_suite
from cpg_suite import cpg, darwin, portable, residual
from cpg_suite.runfiles import runs

FILE = "selected_policy.npz"
ACTIONS_FILE = "selected_actions.npy"
N_ACTIONS = len(cpg.LEG_JOINTS)  # the tasks' action: the 12 leg joint targets in [−1, 1]
ACTION_SPACES = residual.ACTION_SPACES
# How the last layer's output becomes the deterministic action: "tanh_normal", the first
# half (a tanh-Gaussian's mean) through tanh; "normal", all of it (a Gaussian's mean,
# whose standard deviation is a parameter apart) clipped to [−1, 1] as the tasks clip it
# (or to the policy's action box, `action_low` and `action_high`).
HEADS = ("tanh_normal", "normal")
INPUT_DTYPES = ("float64", "float32")
# The normalizer's arrays, SB3's VecNormalize: `var`, `epsilon`, `clip_obs` (instead of `std`).
VEC_NORMALIZE = ("var", "epsilon", "clip_obs")


_ROWS = 8  # observations per pass through the network (`mlp`)

# The kinds of value (`numpy.dtype.kind`) an array of a run's file may hold: booleans,
# integers, floats and fixed-width text (a policy's head, activation, action space). Never
# Python objects (pickles), records, raw bytes or complex numbers.
ARRAY_KINDS = "biufU"
_HEADER_READERS = {
    (1, 0): np.lib.format.read_array_header_1_0,
    (2, 0): np.lib.format.read_array_header_2_0,
}


def one_line(text: object, limit: int = 160) -> str:
    """`text` (an error's words) on one line, at most `limit` characters, without memory
    addresses (NumPy's words may quote `<ast.Name object at 0x...>`): a refusal quoting
    them reads the same on every run.

    Args:
      text: The text, or an error.
      limit: The most characters kept.

    Returns:
      The line.
    """
    text = re.sub(r" at 0x[0-9a-fA-F]+", "", " ".join(str(text).split()))
    return text if len(text) <= limit else text[: limit - 3] + "..."


def read_npy(stream: BinaryIO, size: int, name: str) -> np.ndarray:
    """One `.npy` array from a stream, its header checked before its data is read: format
    1.0 or 2.0, values of `ARRAY_KINDS` (no pickled objects), a shape whose values take
    exactly the bytes that follow the header (neither more, which a lying header claims
    to allocate them, nor fewer). Nothing is unpickled and nothing larger than `size` is
    allocated.

    Args:
      stream: A binary stream at the start of the `.npy` data (a file, a zip member).
      size: The bytes the stream holds in all, header included (a file's size, a zip
        member's `file_size`).
      name: The file's name, for the refusal.

    Returns:
      The array, in C or Fortran order as its header says.

    Raises:
      ValueError: With a one-line reason naming the file, if it is not such an array.
    """
    try:
        version = np.lib.format.read_magic(stream)
        reader = _HEADER_READERS.get(version)
        if reader is None:
            raise ValueError(f"format {version[0]}.{version[1]}, not 1.0 or 2.0")
        shape, fortran_order, dtype = reader(stream)
    except (ValueError, TypeError, SyntaxError, OverflowError) as e:
        raise ValueError(f"{name} is not a NumPy .npy array ({one_line(e)})") from None
    if dtype.hasobject:
        raise ValueError(
            f"{name} holds Python objects (pickles): arrays are read with allow_pickle=False, "
            "numbers or text only"
        )
    if dtype.kind not in ARRAY_KINDS or dtype.fields is not None or dtype.itemsize == 0:
        raise ValueError(
            f"{name} holds {dtype} values: an array holds booleans, integers, floats or text"
        )
    if any(n < 0 for n in shape):
        raise ValueError(f"{name}'s header gives the shape {shape}, with a negative length")
    if math.prod(shape) > MAX_VALUES:
        raise ValueError(
            f"{name}'s header gives the shape {shape}, over the {MAX_VALUES} values a run's "
            "arrays may hold"
        )
    claimed = math.prod(shape) * dtype.itemsize
    present = size - stream.tell()
    if claimed != present:
        raise ValueError(
            f"{name}'s header says {shape} {dtype} values ({claimed} bytes), but {present} "
            "bytes follow it: the data must be exactly what the header says"
        )
    data = stream.read(claimed)
    if len(data) != claimed:
        raise ValueError(f"{name} is cut short: {len(data)} of its {claimed} data bytes")
    array = np.frombuffer(bytearray(data), dtype=dtype)
    if fortran_order:
        return array.reshape(shape[::-1]).transpose()
    return array.reshape(shape)


# The most values a run's arrays may hold, in one `.npy` or all of an archive's: the
# largest shipped policy holds 80,000 and an action table 12,000; a 97 KB archive of one
# 8000 × 8000 boolean array, widened to float64 by the policy and the copy check, cost
# 1.2 GB (an outside attack of 2026-11-29). A choice: 2**21, 26 times the largest.
MAX_VALUES = 2**21


def load_npy(path: str) -> np.ndarray:
    """A `.npy` file's array, read by `read_npy` (its header checked first; no pickles).

    Args:
      path: The file.

    Returns:
      The array.

    Raises:
      OSError: If it cannot be read.
      ValueError: With a one-line reason, if it is not a plain `.npy` array of its size.
    """
    with open(path, "rb") as f:
        return read_npy(f, os.fstat(f.fileno()).st_size, os.path.basename(path))


def load_npz(path: str) -> dict[str, np.ndarray]:
    """A `.npz` archive's arrays by name (a member `<name>.npy` is `<name>`, as NumPy
    names it), each read by `read_npy` against the member's own size: no member larger
    than its header says, none that is not a `.npy` array, no name twice.

    Args:
      path: The archive.

    Returns:
      {name: array}, in the archive's order.

    Raises:
      OSError: If it cannot be read.
      ValueError: With a one-line reason, if it is not such an archive.
    """
    base = os.path.basename(path)
    arrays, values = {}, 0
    try:
        with zipfile.ZipFile(path) as archive:
            for info in archive.infolist():
                member = info.filename
                if not member.endswith(".npy"):
                    raise ValueError(f"{base} holds {member!r}, not a .npy array")
                key = member[: -len(".npy")]
                if key in arrays:
                    raise ValueError(f"{base} holds {member!r} twice")
                shown = member if member.isprintable() else repr(member)
                with archive.open(info) as stream:
                    arrays[key] = read_npy(stream, info.file_size, f"{base}:{shown}")
                values += arrays[key].size
                if values > MAX_VALUES:
                    raise ValueError(
                        f"{base} holds over the {MAX_VALUES} values a run's arrays may hold"
                    )
    except (zipfile.BadZipFile, zipfile.LargeZipFile, zlib.error, EOFError) as e:
        raise ValueError(f"{base} is not a readable .npz archive ({one_line(e)})") from None
    except (NotImplementedError, RuntimeError) as e:  # a compression or encryption
        raise ValueError(f"{base}: a member NumPy cannot read ({one_line(e)})") from None
    return arrays


def mlp(x: np.ndarray, layers, activation) -> np.ndarray:
    """A dense network's output for (N, D) float64 inputs, the same bits on any CPU.

    The rows go through the layers `_ROWS` at a time: `portable.pairwise_matmul` sums each
    row's products in a fixed order (BLAS picks its kernel per CPU, and the last bits with
    it, and with them whole trials), so a row's arithmetic is its own, and a few rows'
    (rows, inputs, outputs) products stay in the CPU's cache (8 rows: half the time of 50).

    Args:
      x: (N, D) inputs.
      layers: (kernel (D_in, D_out), bias (D_out,)) per layer, float64, input first.
      activation: Applied between layers (not after the last).

    Returns:
      (N, D_last) outputs.
    """
    if len(x) > _ROWS:
        return np.concatenate(
            [mlp(x[i : i + _ROWS], layers, activation) for i in range(0, len(x), _ROWS)]
        )
    for i, (kernel, bias) in enumerate(layers):
        x = portable.pairwise_matmul(x, kernel) + bias
        if i < len(layers) - 1:
            x = activation(x)
    return x


def _swish(x: np.ndarray) -> np.ndarray:
    return x * portable.expit(x)  # without exp's overflow


# Between the layers: Brax's PPO networks' swish, SB3's `MlpPolicy`'s tanh (both portable).
ACTIVATIONS = {"swish": _swish, "tanh": portable.tanh}


class NumpyPolicy:
    """A policy trained elsewhere (Brax's PPO on MJX, Stable-Baselines3's PPO), run in the
    CPU task with NumPy.

    The deterministic action of a Gaussian MLP policy: the observation vector
    (`darwin.OBSERVATION_KEYS` in order, plus the CPG phase for `cpg`: the MJX env's) is
    normalized by running statistics (Brax's, or SB3's `VecNormalize`: clipped, rounded
    to float32), passed through the MLP (`ACTIVATIONS` between layers) and its output made
    an action by the policy's head (`HEADS`). For the `cpg` action space the policy steps
    its own CPG row (`reset()` before each episode), as the MJX env does. The layers
    multiply with `portable.pairwise_matmul`, not BLAS, whose kernel is chosen per CPU and
    changes the last bits, and with them whole trials.
    """

    def __init__(self, arrays: dict[str, np.ndarray], action_space: str):
        """Args:
          arrays: `mean`, `std` (or `VEC_NORMALIZE`'s) and `kernel_<i>`, `bias_<i>` for each
            layer; optionally `head` (default "tanh_normal"), `activation`, `input_dtype`,
            `action_low`, `action_high`, `amplitude_scale`, `rate_scale` (the module's
            docstring).
          action_space: "joints" or "cpg".

        Raises:
          ValueError: On an unknown action space, head, activation or input type, missing
            layers or normalizer, or a CPG scale out of range.
        """
        if action_space not in ACTION_SPACES:
            raise ValueError(f"action_space must be one of {ACTION_SPACES}, got {action_space!r}")
        self.action_space = action_space
        self.head = str(arrays.get("head", HEADS[0]))
        if self.head not in HEADS:
            raise ValueError(f"head must be one of {HEADS}, got {self.head!r}")
        self.activation = str(arrays.get("activation", "swish"))
        if self.activation not in ACTIVATIONS:
            raise ValueError(
                f"activation must be one of {tuple(ACTIVATIONS)}, got {self.activation!r}"
            )
        self.input_dtype = str(arrays.get("input_dtype", INPUT_DTYPES[0]))
        if self.input_dtype not in INPUT_DTYPES:
            raise ValueError(f"input_dtype must be one of {INPUT_DTYPES}, got {self.input_dtype!r}")
        self.mean = np.asarray(arrays["mean"], np.float64)
        self.var = self.epsilon = self.clip_obs = None
        if "std" in arrays:
            self.std = np.asarray(arrays["std"], np.float64)
        elif all(k in arrays for k in VEC_NORMALIZE):
            self.var = np.asarray(arrays["var"], np.float64)
            self.epsilon, self.clip_obs = float(arrays["epsilon"]), float(arrays["clip_obs"])
            self.std = np.sqrt(self.var + self.epsilon)  # as VecNormalize divides
        else:
            raise ValueError(f"the policy has no normalizer (std, or {', '.join(VEC_NORMALIZE)})")
        n = sum(1 for k in arrays if k.startswith("kernel_"))
        if n == 0:
            raise ValueError("the policy has no layers (kernel_0 ...)")
        self.layers = [
            (np.asarray(arrays[f"kernel_{i}"], np.float64), np.asarray(arrays[f"bias_{i}"]))
            for i in range(n)
        ]
        _check_layers(self.mean, self.std, self.layers)
        self.box = None  # the "normal" head's: [−1, 1]
        if "action_low" in arrays or "action_high" in arrays:  # both, or a KeyError
            self.box = tuple(
                np.asarray(arrays[k], np.float64) for k in ("action_low", "action_high")
            )
        self.scales = {
            k: float(arrays[k]) for k in ("amplitude_scale", "rate_scale") if k in arrays
        }
        self.cpg, self._physics, self._rows = None, None, None
        if action_space == "cpg":
            self.cpg = residual.ModulatedCPG(1, **self.scales)
            self._physics = cpg_suite.load("darwin_walk").physics  # its joint ranges

    @classmethod
    def load(cls, path: str) -> NumpyPolicy:
        """A policy saved by `save`, read by `load_npz` (headers checked, no pickles).

        Args:
          path: Its `.npz` file.

        Returns:
          The policy.

        Raises:
          OSError: If the file cannot be read.
          ValueError: If it is not a policy's archive (`load_npz`, `__init__`).
          KeyError: If a layer's bias or a normalizer's array is missing.
        """
        arrays = load_npz(path)
        if "action_space" not in arrays:
            raise ValueError(f"{os.path.basename(path)} names no action_space")
        return cls(arrays, str(arrays.pop("action_space")))

    def arrays(self) -> dict[str, np.ndarray]:
        """The policy as the arrays of its file (`NumpyPolicy(arrays, action_space)` again)."""
        arrays = {"mean": self.mean}
        if self.var is None:
            arrays["std"] = self.std
        else:
            arrays.update(var=self.var, epsilon=np.float64(self.epsilon))
            arrays["clip_obs"] = np.float64(self.clip_obs)
        arrays["head"] = np.array(self.head)
        if self.activation != "swish":
            arrays["activation"] = np.array(self.activation)
        if self.input_dtype != INPUT_DTYPES[0]:
            arrays["input_dtype"] = np.array(self.input_dtype)
        if self.box is not None:
            arrays["action_low"], arrays["action_high"] = self.box
        arrays.update({k: np.float64(v) for k, v in self.scales.items()})
        for i, (kernel, bias) in enumerate(self.layers):
            arrays[f"kernel_{i}"], arrays[f"bias_{i}"] = kernel, bias
        return arrays

    def save(self, path: str) -> None:
        """Writes the policy to `path` (.npz), atomically."""
        buffer = io.BytesIO()
        np.savez(buffer, **self.arrays(), action_space=np.array(self.action_space))
        runs.write_bytes(path, buffer.getvalue())

    def reset(self) -> None:
        """Restarts the policy's CPG (before each episode)."""
        if self.cpg is not None:
            self.cpg.reset()

    def outputs(self, features: np.ndarray) -> np.ndarray:
        """The network's output for (N, D) flat observations, before the head makes it an
        action (`act`): the normalized observations through the MLP, row by row."""
        x = (np.asarray(features, np.float64) - self.mean) / self.std
        if self.clip_obs is not None:
            x = np.clip(x, -self.clip_obs, self.clip_obs)
        if self.input_dtype == "float32":
            x = x.astype(np.float32).astype(np.float64)
        return mlp(x, self.layers, ACTIVATIONS[self.activation])

    def act(self, features: np.ndarray) -> np.ndarray:
        """Actions in [−1, 1] for (N, D) flat observations (`outputs`, then the head)."""
        x = self.outputs(features)
        if self.head == "normal":
            return np.clip(x, *(self.box or (-1.0, 1.0)))
        return portable.tanh(x[..., : x.shape[-1] // 2])

    def reset_batch(self, rows: int) -> None:
        """Starts `rows` trials stepped together (`act_batch`; `score.batched_policy_trials`)."""
        self._rows = residual.ModulatedCPG(rows, **self.scales) if self.cpg is not None else None

    def act_batch(self, observations: dict) -> np.ndarray:
        """(n, 12) actions for n trials' observations ((n, ...) arrays), each row what
        `__call__` gives that trial: the policy's arithmetic is row by row (element-wise,
        `portable.pairwise_matmul`), and so is its CPG's."""
        action = self.act(
            residual.batch_features(observations, darwin.OBSERVATION_KEYS, self._rows)
        )
        if self._rows is None:
            return action
        return residual.joint_actions(action, self._rows, self._physics, darwin.CONTROL_TIMESTEP)

    def __call__(self, observation: dict) -> np.ndarray:
        parts = [np.ravel(observation[k]) for k in darwin.OBSERVATION_KEYS]
        if self.cpg is not None:
            parts.append(self.cpg.phase_features()[0])
        action = self.act(np.concatenate(parts)[None])
        if self.cpg is None:
            return action[0]
        return residual.joint_actions(action, self.cpg, self._physics, darwin.CONTROL_TIMESTEP)[0]


def _check_layers(mean: np.ndarray, std: np.ndarray, layers: list) -> None:
    """That a policy's arrays fit together: a normalizer of one vector (mean and std alike),
    each layer a matrix whose rows are the last one's outputs (the first's, the normalizer's
    length) and a bias of its columns.

    Raises:
      ValueError: Naming the first array that does not fit (outside attack of 2026-11-29:
        a 0-d mean or a kernel of 0 columns was admitted, then could not be scored).
    """
    if mean.ndim != 1 or mean.shape != std.shape or not mean.size:
        raise ValueError(
            f"the policy's normalizer has mean {mean.shape} and std {std.shape}: one vector each"
        )
    width = mean.shape[0]
    for i, (kernel, bias) in enumerate(layers):
        if kernel.ndim != 2 or kernel.shape[0] != width or not kernel.shape[1]:
            raise ValueError(
                f"the policy's kernel_{i} is {kernel.shape}, not ({width}, n > 0): it must take "
                "the previous layer's outputs"
            )
        if bias.shape != (kernel.shape[1],):
            raise ValueError(f"the policy's bias_{i} is {bias.shape}, not ({kernel.shape[1]},)")
        width = kernel.shape[1]


class ActionTable:
    """A time-indexed open-loop controller as data: the action of every control step.

    Row t of the table is the action at control step t of a trial (0-based, counted from
    `reset()`, which the scorer calls before each trial), whatever the observation: the
    same table plays on every tier and seed. A trial longer than the table is an error.
    The action is the task's own (`darwin.CPGTask`'s spec: 12 leg joint targets in
    [−1, 1], in the order `cpg.LEG_JOINTS`).
    """

    def __init__(self, actions):
        """Args:
          actions: (control steps, 12) real actions in [−1, 1] (stored as float64).

        Raises:
          ValueError: On another shape, or a value that is not finite or not in [−1, 1].
        """
        try:
            table = np.array(actions, dtype=np.float64)
        except (TypeError, ValueError) as e:
            raise ValueError(f"the actions are not a numeric table: {e}") from None
        if table.ndim != 2 or table.shape[1] != N_ACTIONS or len(table) == 0:
            raise ValueError(
                f"the actions must be a (control steps, {N_ACTIONS}) table, got shape {table.shape}"
            )
        if not np.all(np.isfinite(table)):
            raise ValueError("the actions hold a value that is not finite")
        if np.any(np.abs(table) > 1.0):
            raise ValueError("the actions must lie in the task's action space [-1, 1]")
        table.flags.writeable = False
        self.actions = table
        self._t, self._rows = 0, 1

    @classmethod
    def load(cls, path: str) -> ActionTable:
        """A table saved by `save`: a float64 `.npy` array, read by `load_npy` (its header
        checked first, no pickles).

        Args:
          path: Its `.npy` file.

        Returns:
          The table.

        Raises:
          OSError: If the file cannot be read.
          ValueError: If it is no `.npy` array of float64 actions (`load_npy`'s and
            `__init__`'s checks), or holds pickled objects.
        """
        table = load_npy(path)
        if table.dtype != np.float64:
            raise ValueError(f"{path} holds {table.dtype} values, not float64")
        return cls(table)

    @classmethod
    def from_gait(cls, amplitudes, steps: int = 1000) -> ActionTable:
        """The actions of an open-loop CPG gait (`score.OpenLoopPolicy`'s), as a table.

        Args:
          amplitudes: The 11 CPG amplitudes, degrees.
          steps: Control steps (rows).
        """
        env = cpg_suite.load("darwin_walk")
        targets = cpg.trajectories(
            np.asarray(amplitudes, np.float64), steps, env.control_timestep()
        )
        return cls(env.physics.targets_to_action(targets[0]))

    def save(self, path: str) -> None:
        """Writes the table to `path` (.npy, no pickle), atomically."""
        buffer = io.BytesIO()
        np.save(buffer, self.actions, allow_pickle=False)
        runs.write_bytes(path, buffer.getvalue())

    def reset(self) -> None:
        """Starts the table again (before each trial)."""
        self._t = 0

    def _next(self) -> np.ndarray:
        if self._t >= len(self.actions):
            raise ValueError(
                f"the action table has {len(self.actions)} rows: control step {self._t} is "
                "past its end"
            )
        self._t += 1
        return self.actions[self._t - 1]

    def __call__(self, observation: dict) -> np.ndarray:
        """The action of the next control step (the observation is not used)."""
        del observation
        return self._next().copy()

    def reset_batch(self, rows: int) -> None:
        """Starts `rows` trials stepped together (`score.batched_policy_trials`)."""
        self._rows = rows
        self._t = 0

    def act_batch(self, observations: dict) -> np.ndarray:
        """(n, 12) actions for n trials stepped together: the next row for each."""
        del observations
        return np.tile(self._next(), (self._rows, 1))

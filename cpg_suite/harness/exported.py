"""Policies exported as arrays: an MLP run with NumPy in the CPU task, no training library.

The format of `selected_policy.npz` (written by `NumpyPolicy.save`; `baselines.ppo_mjx`
exports Brax's PPO to it): `mean`, `std` (observation normalization), `kernel_<i>`,
`bias_<i>` (the dense layers, input first), `action_space` ("joints" or "cpg") and `head`
(`HEADS`; files without it are "tanh_normal").
`cpg_suite.protocol.verify` re-scores shipped runs of this format.
"""

from __future__ import annotations

import io

import numpy as np

import cpg_suite
from cpg_suite import darwin, portable, residual
from cpg_suite.harness import runs

FILE = "selected_policy.npz"
ACTION_SPACES = residual.ACTION_SPACES
# How the last layer's output becomes the deterministic action: "tanh_normal", the first
# half (a tanh-Gaussian's mean) through tanh; "normal", all of it (a Gaussian's mean,
# whose standard deviation is a parameter apart) clipped to [−1, 1] as the tasks clip it.
HEADS = ("tanh_normal", "normal")


_ROWS = 8  # observations per pass through the network (`NumpyPolicy.act`)


class NumpyPolicy:
    """A policy trained elsewhere (e.g. Brax's PPO on MJX), run in the CPU task with NumPy.

    The deterministic action of a Gaussian MLP policy: the observation vector
    (`darwin.OBSERVATION_KEYS` in order, plus the CPG phase for `cpg`: the MJX env's) is
    normalized by running statistics, passed through the MLP (swish between layers) and
    its output made an action by the policy's head (`HEADS`). For the `cpg` action space
    the policy steps its own CPG row (`reset()` before each episode), as the MJX env does.
    The layers multiply with `portable.pairwise_matmul`, not BLAS, whose kernel is chosen
    per CPU and changes the last bits, and with them whole trials.
    """

    def __init__(self, arrays: dict[str, np.ndarray], action_space: str):
        """Args:
          arrays: `mean`, `std` and `kernel_<i>`, `bias_<i>` for each layer; `head`
            (default "tanh_normal").
          action_space: "joints" or "cpg".

        Raises:
          ValueError: On an unknown action space or head, or missing layers.
        """
        if action_space not in ACTION_SPACES:
            raise ValueError(f"action_space must be one of {ACTION_SPACES}, got {action_space!r}")
        self.action_space = action_space
        self.head = str(arrays.get("head", HEADS[0]))
        if self.head not in HEADS:
            raise ValueError(f"head must be one of {HEADS}, got {self.head!r}")
        self.mean = np.asarray(arrays["mean"], np.float64)
        self.std = np.asarray(arrays["std"], np.float64)
        n = sum(1 for k in arrays if k.startswith("kernel_"))
        if n == 0:
            raise ValueError("the policy has no layers (kernel_0 ...)")
        self.layers = [
            (np.asarray(arrays[f"kernel_{i}"], np.float64), np.asarray(arrays[f"bias_{i}"]))
            for i in range(n)
        ]
        self.cpg, self._physics, self._rows = None, None, None
        if action_space == "cpg":
            self.cpg = residual.ModulatedCPG(1)
            self._physics = cpg_suite.load("darwin_walk").physics  # its joint ranges

    @classmethod
    def load(cls, path: str) -> NumpyPolicy:
        """A policy saved by `save`."""
        with np.load(path) as data:
            arrays = {k: data[k] for k in data.files}
        return cls(arrays, str(arrays.pop("action_space")))

    def arrays(self) -> dict[str, np.ndarray]:
        """The policy as the arrays of its file (`NumpyPolicy(arrays, action_space)` again)."""
        arrays = {"mean": self.mean, "std": self.std, "head": np.array(self.head)}
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

    def act(self, features: np.ndarray) -> np.ndarray:
        """Actions in [−1, 1] for (N, D) flat observations.

        The rows go through the network `_ROWS` at a time: each row's arithmetic is its own,
        and `pairwise_matmul`'s (rows, inputs, outputs) products of a few rows stay in the
        CPU's cache (8 rows: half the time of 50 at once).
        """
        features = np.asarray(features, np.float64)
        if len(features) > _ROWS:
            chunks = [self.act(features[i : i + _ROWS]) for i in range(0, len(features), _ROWS)]
            return np.concatenate(chunks)
        x = (features - self.mean) / self.std
        for i, (kernel, bias) in enumerate(self.layers):
            x = portable.pairwise_matmul(x, kernel) + bias  # the same bits on any CPU
            if i < len(self.layers) - 1:
                x = x * portable.expit(x)  # swish, without exp's overflow
        if self.head == "normal":
            return np.clip(x, -1.0, 1.0)
        return portable.tanh(x[..., : x.shape[-1] // 2])

    def reset_batch(self, rows: int) -> None:
        """Starts `rows` trials stepped together (`act_batch`; `score.batched_policy_trials`)."""
        self._rows = residual.ModulatedCPG(rows) if self.cpg is not None else None

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

"""A policy that is code runs in a process of its own and sees its observations only.

`verify --trust_code` and `submit --code` run a run's `policy_code.py`; in the scorer's own
process, that code could walk its caller's frames to the physics, the tier and the seed.
`IsolatedPolicy` runs it elsewhere:

* a child Python process (the same interpreter and `cpg_suite`, an empty temporary working
  folder, no file descriptors but its two pipes and stderr, an environment holding only
  what fixes its arithmetic) executes the file and calls `make_policy()` once;
* for each trial (`reset()`, or `reset_batch(n)` for a batch of trials) it forks a trial
  process from that state, which answers the trial's observations with actions and ends
  with it: nothing a trial keeps in its own memory reaches the next (state shared before
  the fork can: below);
* the scorer sends each observation as arrays of bytes and reads the action back as
  float64 values (`_send`, `_receive`); nothing else crosses, and the trials (and tiers)
  run in an order drawn afresh at each scoring (`trial_order`), so that a policy counting
  its trials learns nothing of their order (it can still recognise a trial: below).

A policy that computes in its own process sees only the observations; its actions come
back as the same float64 values, so an honest policy's card is the same, bit for bit
(`tests/test_sandbox.py`).

The boundary holds against Python: frames, globals, the objects of the scorer's process,
counters. The policy may read files (no seed or state of a trial is written to one), but
writes none: its process and all it starts have a file size limit of 0 (so it cannot
rewrite its run's card, trials or the ledger after `verify` checked them), and `close`
ends its whole process group. `verify` also compares a run's files before and after its
check and records the digest it checked. The scorer makes itself non-dumpable before the
policy starts (`keep_memory_private`), so that an unprivileged policy cannot read or
rewrite its memory through `/proc` even where the kernel's ptrace rules would let it (no
Yama). It is not an operating-system sandbox: a process running as root may read any
memory and raise its limits; a process that leaves its group (`setsid`) outlives
`close`; and a policy can carry state from one trial to the next (memory shared before
the fork, a helper process, names made in the file system) and, above all, tell a public
test trial from its first observation and replay it in its own simulator — which is why
the board lists a policy that is code without ranking it (`admission.unvetted_code`,
docs/protocol.md#data-and-code). Run `verify` as an unprivileged user, or in a
container, where that matters.
"""

from __future__ import annotations

import collections
import ctypes
import hashlib
import importlib.util
import json
import os
import resource
import select
import signal
import struct
import subprocess
import sys
import tempfile
import threading
import time
from collections.abc import Callable

import numpy as np

_BEGIN, _BATCH, _ACT, _END, _OK, _FAIL = b"B", b"N", b"A", b"E", b"K", b"F"
_HEADER = struct.Struct("<cI")  # kind, payload length
# What the child inherits of the environment: what decides its arithmetic and threads.
_ENVIRONMENT = (
    "PATH",
    "NPY_DISABLE_CPU_FEATURES",
    "OPENBLAS_CORETYPE",
    "OPENBLAS_L2_SIZE",
    "ATEN_CPU_CAPABILITY",
    "MKL_CBWR",
)
_THREADS = {"OMP_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1", "MKL_NUM_THREADS": "1"}
# How long the scorer waits for the policy's process, s (choices: generous for honest code,
# so that a policy that sleeps or loops cannot hold `verify`, `submit` or CI for ever).
# Start-up: Python, NumPy and `cpg_suite` load, then the file and its `make_policy()` (an
# import of torch and a small network took under 10 s on the 2-core development machine).
STARTUP_SECONDS = 120.0
# Any other answer: a trial's start (a fork) or the actions for one control step, of one
# trial or a tier's 50 at once (a batched MLP's forward pass: milliseconds).
ANSWER_SECONDS = 30.0
# All its answers over one trial together (a choice), the scorer's physics not counted: a
# batch of n trials stepped together gets n times as much. An honest policy answering each
# of a trial's 1000 control steps in a millisecond (a small MLP in NumPy or torch) needs
# about 1 s; 60 s is 60 ms a step on average. Without it a policy answering each step just
# inside `ANSWER_SECONDS` would hold one trial for 8 hours, a run of 200 for weeks.
TRIAL_SECONDS = 60.0
_ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
_BOOT = (
    "import sys; sys.path.insert(0, {root!r}); "
    "from cpg_suite.protocol import sandbox; sandbox.serve({path!r})"
)


class PolicyFailed(RuntimeError):
    """The policy's process ended or answered with something other than an action."""


def _read_exactly(fd: int, n: int, deadline: float | None = None) -> bytes:
    """n bytes from fd; by `deadline` (`time.monotonic`; None: no limit), else TimeoutError."""
    chunks, left = [], n
    while left:
        if deadline is not None and not select.select([fd], [], [], _left(deadline))[0]:
            raise TimeoutError
        chunk = os.read(fd, left)
        if not chunk:
            raise EOFError("the other end closed")
        chunks.append(chunk)
        left -= len(chunk)
    return b"".join(chunks)


def _send(fd: int, kind: bytes, payload: bytes = b"", deadline: float | None = None) -> None:
    """Writes a message to fd. On a non-blocking fd (the scorer's end of the pipe to the
    policy) it waits for room only until `deadline`: a child that stops reading cannot
    block the scorer on a full pipe.

    Raises:
      TimeoutError: If the deadline passes first.
    """
    data = memoryview(_HEADER.pack(kind, len(payload)) + payload)
    while data:
        try:
            data = data[os.write(fd, data) :]
        except BlockingIOError:
            wait = None if deadline is None else _left(deadline)
            if wait == 0.0 or not select.select([], [fd], [], wait)[1]:
                raise TimeoutError from None


def _left(deadline: float) -> float:
    return max(0.0, deadline - time.monotonic())


def _receive(fd: int, deadline: float | None = None) -> tuple[bytes, bytes]:
    kind, length = _HEADER.unpack(_read_exactly(fd, _HEADER.size, deadline))
    return kind, _read_exactly(fd, length, deadline)


_HEADERS: dict = {}  # the JSON header of each layout of arrays sent (a cache)
_LAYOUTS: dict = {}  # the layout of each header received (a cache)


def encode_arrays(arrays: dict) -> bytes:
    """Named arrays as bytes: a JSON header (names, dtypes, shapes), then their data."""
    values = {k: np.ascontiguousarray(v) for k, v in arrays.items()}
    layout = tuple((k, v.dtype.str, v.shape) for k, v in values.items())
    header = _HEADERS.get(layout)
    if header is None:
        header = json.dumps([[k, d, list(shape)] for k, d, shape in layout]).encode()
        header = _HEADERS.setdefault(layout, struct.pack("<I", len(header)) + header)
    return header + b"".join(v.tobytes() for v in values.values())


def decode_arrays(payload: bytes) -> dict:
    """The named arrays of `encode_arrays`, as writable copies in their order.

    Raises:
      ValueError: On arrays of Python objects (nothing is unpickled).
    """
    (size,) = struct.unpack_from("<I", payload)
    header = payload[: 4 + size]
    layout = _LAYOUTS.get(header)
    if layout is None:
        layout = []
        for name, dtype, shape in json.loads(header[4:]):
            dtype = np.dtype(dtype)
            if dtype.hasobject:
                raise ValueError("arrays of Python objects do not cross")
            layout.append((name, dtype, tuple(shape), int(np.prod(shape, dtype=np.int64))))
        layout = _LAYOUTS.setdefault(header, layout)
    offset, arrays = 4 + size, {}
    for name, dtype, shape, count in layout:
        arrays[name] = np.frombuffer(payload, dtype, count, offset).reshape(shape).copy()
        offset += count * dtype.itemsize
    return arrays


class IsolatedPolicy:
    """A `policy_code.py` run in its own process (see the module's docstring).

    Called with an observation (a mapping of arrays) it returns the action as float64
    values; `reset()` starts a trial. If the code's policy has `reset_batch(n)` and
    `act_batch(observations)`, so does this (`score.batched_policy_trials`).

    Args:
      path: The policy's Python file (relative to the working folder, or absolute).
      startup_seconds: How long its process may take to run the file and `make_policy()`.
      answer_seconds: How long it may take for any later answer (a trial's start, the
        actions of a control step).
      trial_seconds: How long all its answers over one trial may take together (n times
        as long for a batch of n trials), the scorer's own work between them not counted.

    Raises:
      PolicyFailed: If the file is not a readable regular file, cannot be run, its
        `make_policy()` fails (with the last line the child printed on stderr), or it does
        not answer in time (or stops reading what it is sent).
    """

    def __init__(
        self,
        path: str,
        startup_seconds: float = STARTUP_SECONDS,
        answer_seconds: float = ANSWER_SECONDS,
        trial_seconds: float = TRIAL_SECONDS,
    ):
        path = os.path.abspath(path)  # the child runs in a folder of its own
        if not os.path.isfile(path) or not os.access(path, os.R_OK):
            raise PolicyFailed(f"the policy's file {path!r} is not a readable file")
        self._answer_seconds, self._trial_seconds = answer_seconds, trial_seconds
        self._budget = self._left = float("inf")  # a trial's (`_begin`); none at start-up
        self._closed = False
        keep_memory_private()
        self._folder = tempfile.TemporaryDirectory(prefix="policy-")
        environment = {k: os.environ[k] for k in _ENVIRONMENT if k in os.environ}
        self._process = subprocess.Popen(
            [sys.executable, "-B", "-E", "-s", "-c", _BOOT.format(root=_ROOT, path=path)],
            stdin=subprocess.PIPE,
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,  # drained by a thread: the child may write no file
            cwd=self._folder.name,
            env={**environment, **_THREADS},
            start_new_session=True,  # its process group: `close` ends every process in it
        )
        self._said = collections.deque(maxlen=64)  # the last chunks of its stderr
        self._drain = threading.Thread(  # not a method: the thread holds no `self`
            target=_read_stderr, args=(self._process.stderr.fileno(), self._said), daemon=True
        )
        self._drain.start()
        self._to, self._from = self._process.stdin.fileno(), self._process.stdout.fileno()
        os.set_blocking(self._to, False)  # `_send` waits for room until a deadline
        self._in_trial = False
        kind, payload = self._ask(None, b"", startup_seconds, "to start")
        self.batched = payload == b"batch"
        if self.batched:
            self.reset_batch, self.act_batch = self._reset_batch, self._act_batch

    def _ask(
        self,
        kind: bytes | None,
        payload: bytes = b"",
        seconds: float | None = None,
        what: str = "to answer",
    ) -> tuple[bytes, bytes]:
        """Sends a message (unless kind is None) and returns the policy's answer, within
        `seconds` (the answer deadline) and what is left of the trial's budget.

        Raises:
          PolicyFailed: If it is late, fails, or answers something else than `_OK`.
        """
        start = time.monotonic()
        if seconds is None:
            seconds = max(0.0, min(self._answer_seconds, self._left))
            if self._left < self._answer_seconds:
                what = f"to answer (its {self._budget:g} s of answers for the trial spent)"
        try:
            if kind is not None:
                _send(self._to, kind, payload, start + seconds)
            kind, payload = _receive(self._from, start + seconds)
        except TimeoutError:
            self.close()
            late = f"the policy's process took more than {seconds:g} s {what}"
            raise PolicyFailed(late) from None
        except (EOFError, OSError):
            kind, payload = _FAIL, b""
        finally:
            self._left -= time.monotonic() - start
        if kind != _OK:
            self.close()
            lines = b"".join(self._said).decode(errors="replace").strip().splitlines()
            said = payload.decode(errors="replace") or (lines[-1] if lines else "no answer")
            raise PolicyFailed(f"the policy's process failed: {said}")
        return kind, payload

    def _begin(self, kind: bytes, payload: bytes = b"", trials: int = 1) -> None:
        if self._in_trial:  # its answer runs no policy code: the plain deadline
            self._ask(_END, b"", self._answer_seconds)
        self._budget = self._left = self._trial_seconds * trials
        self._ask(kind, payload)
        self._in_trial = True

    def reset(self) -> None:
        """Starts a trial: a fresh trial process from the policy as `make_policy()` made it."""
        self._begin(_BEGIN)

    def __call__(self, observation) -> np.ndarray:
        if not self._in_trial:
            self.reset()
        return self._action(encode_arrays(dict(observation)), 1)[0]

    def _reset_batch(self, rows: int) -> None:
        self._begin(_BATCH, struct.pack("<I", rows), rows)

    def _act_batch(self, observations: dict) -> np.ndarray:
        return self._action(encode_arrays(dict(observations)), None)

    def _action(self, observations: bytes, rows: int | None) -> np.ndarray:
        _, payload = self._ask(_ACT, observations)
        action = decode_arrays(payload)["action"]
        if action.dtype != np.float64 or action.ndim != 2 or (rows and action.shape[0] != rows):
            raise PolicyFailed(f"the policy answered a {action.dtype} {action.shape} array")
        return action

    def trial_order(self, n: int) -> np.ndarray:
        """The order the scorer runs n trials (or tiers) in: drawn afresh each time."""
        return np.random.default_rng().permutation(n)

    def close(self) -> None:
        """Ends the policy's process and every process of its group (its trials, and what
        it started without leaving the group). Once: its process id may be reused after."""
        if self._closed:
            return
        self._closed = True
        try:
            os.killpg(self._process.pid, signal.SIGKILL)
        except (ProcessLookupError, PermissionError):
            pass
        self._process.wait()
        self._drain.join(timeout=5)
        streams = [self._process.stdin, self._process.stdout]
        if not self._drain.is_alive():  # else a process outside the group holds its stderr:
            streams.append(self._process.stderr)  # left open (closing it under a blocked
        for stream in streams:  # reader would let the descriptor be reused under it)
            stream.close()
        self._folder.cleanup()

    def __del__(self):
        try:
            self.close()
        except Exception:
            pass


_PR_SET_DUMPABLE = 4  # prctl(2), linux/prctl.h


def _read_stderr(fd: int, said: collections.deque) -> None:
    # `os.read` on the descriptor: a process that left the group may hold the pipe open
    # for ever, and this thread then never returns; it holds no lock `close` needs, and no
    # reference to its `IsolatedPolicy` (which `__del__` then closes when it is dropped).
    try:
        for chunk in iter(lambda: os.read(fd, 4096), b""):
            said.append(chunk)
    except OSError:
        pass


def keep_memory_private() -> None:
    """Makes the scorer's process non-dumpable (`prctl(PR_SET_DUMPABLE, 0)`) before a
    policy's code starts: a process of the same user without CAP_SYS_PTRACE then cannot
    open its `/proc/<pid>/mem`, `environ`, `maps` or `fd`, which a kernel without Yama
    (ptrace_scope absent or 0) otherwise lets a child do: a policy rewrote its scorer's
    memory so (outside review, 2026-11-28; `tests/test_sandbox.py`). This lasts for the
    process (it is not undone when the policy closes: its process may outlive `close`),
    and is done only where code is trusted to run; it does nothing where prctl is not
    (not Linux), and nothing against root.
    """
    try:
        libc = ctypes.CDLL(None, use_errno=True)
        prctl = libc.prctl
    except (OSError, AttributeError):
        return
    if prctl(_PR_SET_DUMPABLE, 0, 0, 0, 0) != 0:
        raise OSError(ctypes.get_errno(), "prctl(PR_SET_DUMPABLE, 0) failed")


def dumpable() -> bool | None:
    """Whether this process is dumpable (`prctl(PR_GET_DUMPABLE)`; None where prctl is not)."""
    try:
        return bool(ctypes.CDLL(None).prctl(_PR_SET_DUMPABLE - 1, 0, 0, 0, 0))
    except (OSError, AttributeError):
        return None


def _act(policy, observations: dict, batched: bool) -> np.ndarray:
    if batched:
        action = policy.act_batch(observations)
    else:
        action = policy(observations)
    return np.atleast_2d(np.asarray(action, dtype=np.float64))


def _trial(policy, kind: bytes, payload: bytes) -> None:
    """A trial process: resets the policy, then answers observations until the trial ends."""
    batched = kind == _BATCH
    try:
        if batched:
            policy.reset_batch(struct.unpack("<I", payload)[0])
        elif hasattr(policy, "reset"):
            policy.reset()
        _send(1, _OK)
        while True:
            kind, payload = _receive(0)
            if kind != _ACT:
                _send(1, _OK)
                break
            action = _act(policy, decode_arrays(payload), batched)
            _send(1, _OK, encode_arrays({"action": action}))
    except BaseException as e:
        _send(1, _FAIL, f"{type(e).__name__}: {e}".encode()[:4000])
    finally:
        os._exit(0)


def load_policy_code(path: str) -> Callable[[dict], np.ndarray]:
    """Executes a policy's Python file and returns its `make_policy()`: code runs here.

    The file is executed as a module of its own (importable by name only while it runs);
    it may import what is installed (NumPy, `cpg_suite`). `serve` calls it in the policy's
    own process; nothing in the scorer's process calls it.

    Args:
      path: The file (`policy_code.py`).

    Returns:
      The policy: a callable from the task's observation to a (12,) action, with `reset()`
      called before each trial if it has one.

    Raises:
      ValueError: If the file defines no `make_policy()` or it returns no callable.
      Exception: Whatever the file raises.
    """
    with open(path, "rb") as f:
        name = f"_policy_code_{hashlib.sha256(f.read()).hexdigest()[:16]}"
    spec = importlib.util.spec_from_file_location(name, path)
    if spec is None or spec.loader is None:
        raise ValueError(f"{path} cannot be loaded as Python")
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module  # while it runs: what dataclasses and pickle look up
    try:
        spec.loader.exec_module(module)
    finally:
        sys.modules.pop(name, None)
    make = getattr(module, "make_policy", None)
    if not callable(make):
        raise ValueError(f"{path} defines no make_policy()")
    policy = make()
    if not callable(policy):
        raise ValueError(f"{path}: make_policy() returned {type(policy).__name__}, not a policy")
    return policy


def _write_nothing() -> None:
    """From here on this process and its children write no byte to any file (a file size
    limit of 0, which an unprivileged process cannot raise again; writing fails instead of
    ending the process): the policy cannot change a run's files, the ledger or its card.
    Pipes are no files: the answers still go out."""
    signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
    resource.setrlimit(resource.RLIMIT_FSIZE, (0, 0))
    resource.setrlimit(resource.RLIMIT_CORE, (0, 0))


def serve(path: str) -> None:
    """The policy's process (`IsolatedPolicy`): runs the file, then forks one trial process
    per trial and waits for it; nothing it runs writes to a file (`_write_nothing`)."""
    _write_nothing()
    try:
        policy = load_policy_code(path)
    except BaseException as e:
        _send(1, _FAIL, f"{type(e).__name__}: {e}".encode()[:4000])
        return
    batched = hasattr(policy, "reset_batch") and hasattr(policy, "act_batch")
    _send(1, _OK, b"batch" if batched else b"")
    while True:
        try:
            kind, payload = _receive(0)
        except EOFError:
            return
        if kind not in (_BEGIN, _BATCH):
            _send(1, _FAIL, b"no trial started")
            continue
        pid = os.fork()
        if pid == 0:
            _trial(policy, kind, payload)
        os.waitpid(pid, 0)

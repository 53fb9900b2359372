"""Run directories (docs/architecture.md#run-directories): layout, atomic writes, progress files.

Layout: `<output_dir>/<method>/<task>/<run_name>/` holding `config.json`, `progress.csv`,
`summary.json` and method-specific files. Every file except the append-only progress file
is written to a temporary file and moved into place with `os.replace`, so a killed run never
leaves a half-written file behind.
"""

from __future__ import annotations

import csv
import dataclasses
import io
import json
import os
import platform
import secrets
import shlex
import subprocess
import time

import numpy as np

from cpg_suite import cli


@dataclasses.dataclass(frozen=True)
class RunOptions:
    """Where a run is stored and how it is executed; none of it changes the results.

    Attributes:
      output_dir: Root of the output tree.
      run_name: Run directory name (None: the method's default from its settings).
      threads: Evaluator threads (results are identical for any number).
      resume: Continue runs from their checkpoints (a finished run is returned as is).
      overwrite: Replace existing run directories.
      backend: Where candidates are evaluated: "local" threads or "ray" actors (results
        are identical).
      ray_address: The Ray cluster for backend "ray" (host:port, "auto", or None for a
        private local instance).
    """

    output_dir: str = "runs"
    run_name: str | None = None
    threads: int = 2
    resume: bool = False
    overwrite: bool = False
    backend: str = "local"
    ray_address: str | None = None

    def __post_init__(self):
        cli.require_backend(self.backend, self.ray_address)
        if self.threads < 1:
            raise ValueError(f"--threads must be ≥ 1, got {self.threads}")
        if self.resume and self.overwrite:
            raise ValueError("--resume and --overwrite exclude each other")


class RunDirectoryExists(Exception):
    """The run directory already holds a run and neither overwrite nor resume was asked."""


def run_directory(
    output_dir: str,
    method: str,
    task: str,
    run_name: str,
    *,
    overwrite: bool = False,
    resume: bool = False,
) -> str:
    """Creates (or reopens) `<output_dir>/<method>/<task>/<run_name>/`.

    Args:
      output_dir: Root of the output tree.
      method: Method name, e.g. `q_learning`.
      task: Task id or model name, e.g. `pole_balance`.
      run_name: Name of this run.
      overwrite: Empty an existing run directory first.
      resume: Reuse an existing run directory as it is.

    Returns:
      The path of the run directory.

    Raises:
      RunDirectoryExists: If the directory holds files and neither flag is set.
    """
    path = os.path.join(output_dir, method, task, run_name)
    if os.path.isdir(path) and os.listdir(path):
        if overwrite:
            for name in os.listdir(path):
                full = os.path.join(path, name)
                if os.path.isfile(full) or os.path.islink(full):
                    os.remove(full)
        elif not resume:
            raise RunDirectoryExists(
                f"run directory {path} already exists; pass --overwrite to replace it"
            )
    os.makedirs(path, exist_ok=True)
    return path


def _atomic_write_bytes(path: str, data: bytes) -> None:
    """Writes a temporary file beside `path`, then renames it there. The file gets the
    user's umask, as `open` would give it (mode 0666 less the umask; `tempfile.mkstemp`'s
    0600 would hide a shared run from its group)."""
    directory = os.path.dirname(os.path.abspath(path))
    tmp = os.path.join(directory, f".tmp-{secrets.token_hex(8)}")
    fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o666)
    try:
        with os.fdopen(fd, "wb") as f:
            f.write(data)
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.remove(tmp)
        raise


def write_bytes(path: str, data: bytes) -> None:
    """Writes `data` to `path` atomically (a reader sees the old file or the new one)."""
    _atomic_write_bytes(path, data)


def to_jsonable(obj):
    """`obj` with NumPy arrays and scalars turned into lists and Python numbers."""
    if isinstance(obj, dict):
        return {str(k): to_jsonable(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [to_jsonable(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return to_jsonable(obj.tolist())
    if isinstance(obj, np.bool_):
        return bool(obj)
    if isinstance(obj, np.integer):
        return int(obj)
    if isinstance(obj, np.floating):
        return float(obj)
    return obj


def write_json(path: str, obj) -> None:
    """Writes `obj` as indented JSON, atomically (numpy values are converted)."""
    text = json.dumps(to_jsonable(obj), indent=2, sort_keys=False) + "\n"
    _atomic_write_bytes(path, text.encode("utf-8"))


def write_text(path: str, text: str) -> None:
    """Writes text atomically."""
    _atomic_write_bytes(path, text.encode("utf-8"))


def write_matrix_csv(path: str, matrix: np.ndarray, fmt: str = "%.6f") -> None:
    """Writes a 2-D array as CSV without a header, atomically."""
    buf = io.StringIO()
    np.savetxt(buf, np.atleast_2d(matrix), fmt=fmt, delimiter=",")
    write_text(path, buf.getvalue())


def write_rows_csv(path: str, rows: list[dict]) -> None:
    """Writes a list of dicts as a CSV with a header (keys of the first row), atomically."""
    buf = io.StringIO()
    if rows:
        writer = csv.DictWriter(buf, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)
    write_text(path, buf.getvalue())


def save_npy(path: str, array: np.ndarray) -> None:
    """Saves a numpy array atomically."""
    buf = io.BytesIO()
    np.save(buf, np.asarray(array))
    _atomic_write_bytes(path, buf.getvalue())


def read_json(path: str):
    with open(path, encoding="utf-8") as f:
        return json.load(f)


class ProgressCSV:
    """Append-only CSV, one row per round or episode, flushed after every row."""

    def __init__(self, path: str, fieldnames: list[str], truncate: bool = True):
        """Args:
        path: The CSV file.
        fieldnames: Its columns.
        truncate: Start the file afresh (else append; a file written with other columns
          keeps its own, the new ones left out, so a resumed run's rows stay aligned).
        """
        self.path = path
        self.fieldnames = list(fieldnames)
        exists = os.path.exists(path) and os.path.getsize(path) > 0
        if exists and not truncate:
            with open(path, newline="", encoding="utf-8") as f:
                self.fieldnames = next(csv.reader(f))
        self._file = open(
            path, "w" if truncate or not exists else "a", newline="", encoding="utf-8"
        )
        self._writer = csv.DictWriter(self._file, fieldnames=self.fieldnames)
        if truncate or not exists:
            self._writer.writeheader()
            self._file.flush()

    def append(self, row: dict) -> None:
        self._writer.writerow({k: to_jsonable(row.get(k, "")) for k in self.fieldnames})
        self._file.flush()

    def close(self) -> None:
        self._file.close()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()


def _git_commit() -> str | None:
    here = os.path.dirname(os.path.abspath(__file__))
    try:
        out = subprocess.run(
            ["git", "-C", here, "rev-parse", "HEAD"],
            capture_output=True,
            text=True,
            timeout=5,
            check=False,
        )
    except (OSError, subprocess.SubprocessError):
        return None
    return out.stdout.strip() or None if out.returncode == 0 else None


def environment_record() -> dict:
    """Versions of the package and its engines, the git commit if any, and the host."""
    import dm_control
    import mujoco

    import cpg_suite

    try:
        from importlib.metadata import version

        dm_control_version = version("dm-control")
    except Exception:
        dm_control_version = getattr(dm_control, "__version__", None)
    return {
        "cpg_suite_version": cpg_suite.__version__,
        "mujoco_version": mujoco.__version__,
        "dm_control_version": dm_control_version,
        "numpy_version": np.__version__,
        "python_version": platform.python_version(),
        "git_commit": _git_commit(),
        "started_utc": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()),
    }


def _flag_text(name: str, value) -> str | None:
    if value is None:
        return None
    if isinstance(value, bool):
        return f"--{name}" if value else f"--no{name}"
    if isinstance(value, (list, tuple)):
        return f"--{name}={','.join(str(v) for v in value)}"
    return f"--{name}={value}"


def command_line(module: str, settings: dict) -> str:
    """The shell command that runs `python -m module` with these settings as flags.

    Args:
      module: The CLI module, e.g. `baselines.cem`.
      settings: Flag values by flag name (None values are left out).

    Returns:
      One line, each value quoted for a POSIX shell.
    """
    parts = [_flag_text(name, value) for name, value in settings.items()]
    return shlex.join(["python", "-m", module] + [p for p in parts if p is not None])


def write_config(
    run_dir: str, settings, command: str | None = None, extra: dict | None = None
) -> None:
    """Writes `config.json`: every setting, the command that re-runs the run, the versions.

    Args:
      run_dir: The run directory.
      settings: A settings dataclass or a dict of settings.
      command: The command line that re-runs exactly this run (see `command_line`).
      extra: More top-level entries (e.g. the environment an earlier call trained in).
    """
    if dataclasses.is_dataclass(settings):
        settings = dataclasses.asdict(settings)
    config = {"settings": settings, "command": command, "environment": environment_record()}
    write_json(os.path.join(run_dir, "config.json"), {**config, **(extra or {})})

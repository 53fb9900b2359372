"""Small linear algebra whose results are the same bits on every x86-64 CPU.

NumPy's `@`, `dot`, `linalg.eigh` and `multivariate_normal(method="eigh")` go through
BLAS/LAPACK (OpenBLAS in the wheels), which picks its kernel per CPU: Haswell, SkylakeX and
Sandybridge kernels block and fuse the sums differently, so the last bit of a sample
differs between machines, and a walking robot's contact dynamics turn that bit into metres
within a few hundred steps. The optimizers draw their candidates with the functions below
instead. They use only element-wise IEEE operations (`+`, `-`, `*`, `/`, `sqrt`), each of
which is correctly rounded whatever SIMD width NumPy's loops use, in a fixed order of
summation. The matrices are tiny (11 × 11), so the Python loops cost microseconds.
"""

from __future__ import annotations

import numpy as np


def _matrices(a: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """`a` and `b` as float64 matrices that can be multiplied (ValueError if not)."""
    a, b = np.asarray(a, dtype=np.float64), np.asarray(b, dtype=np.float64)
    if a.ndim != 2 or b.ndim != 2 or a.shape[1] != b.shape[0]:
        raise ValueError(f"cannot multiply shapes {a.shape} and {b.shape}")
    return a, b


def matmul(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """`a @ b` for 2-D arrays, summing over the inner index in increasing order.

    Args:
      a: (r, n) array.
      b: (n, c) array.

    Returns:
      (r, c) array.

    Raises:
      ValueError: If the inner dimensions differ.
    """
    a, b = _matrices(a, b)
    out = np.zeros((a.shape[0], b.shape[1]))
    for j in range(a.shape[1]):
        out += a[:, j, None] * b[None, j, :]
    return out


def pairwise_matmul(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """`a @ b` for 2-D arrays, summing the inner products in a fixed binary tree.

    The products `a[i, j] * b[j, k]` are added in halves (j with j + n/2, the count
    padded to even with a zero, until one is left): the same order on every CPU, like
    `matmul`, but in log2(n) whole-array additions, fast enough for a policy network's
    256-wide layers at every control step. Its last bits differ from `matmul`'s.

    Args:
      a: (r, n) array.
      b: (n, c) array.

    Returns:
      (r, c) array.

    Raises:
      ValueError: If the inner dimensions differ.
    """
    a, b = _matrices(a, b)
    terms = a[:, :, None] * b[None, :, :]
    while terms.shape[1] > 1:
        if terms.shape[1] % 2:
            terms = np.concatenate([terms, np.zeros_like(terms[:, :1])], axis=1)
        half = terms.shape[1] // 2
        terms = terms[:, :half] + terms[:, half:]
    return terms[:, 0, :]


def weighted_sum(weights: np.ndarray, rows: np.ndarray) -> np.ndarray:
    """Σᵢ wᵢ rowsᵢ, summed in row order.

    Args:
      weights: (m,) weights.
      rows: (m, n) vectors.

    Returns:
      (n,) vector.
    """
    out = np.zeros(np.shape(rows)[1])
    for w, row in zip(np.asarray(weights, dtype=np.float64), np.asarray(rows, dtype=np.float64)):
        out += w * row
    return out


def weighted_outer_sum(weights: np.ndarray, rows: np.ndarray) -> np.ndarray:
    """Σᵢ wᵢ rowsᵢ rowsᵢᵀ, summed in row order.

    Args:
      weights: (m,) weights.
      rows: (m, n) vectors.

    Returns:
      (n, n) symmetric matrix.
    """
    rows = np.asarray(rows, dtype=np.float64)
    out = np.zeros((rows.shape[1], rows.shape[1]))
    for w, row in zip(np.asarray(weights, dtype=np.float64), rows):
        out += w * (row[:, None] * row[None, :])
    return out


def norm(v: np.ndarray) -> float:
    """Euclidean norm, summed in index order."""
    total = 0.0
    for x in np.asarray(v, dtype=np.float64).ravel():
        total += float(x) * float(x)
    return float(np.sqrt(total))


def cholesky_psd(s: np.ndarray, rel_tol: float = 1e-12) -> np.ndarray:
    """Lower-triangular L with L Lᵀ = S for a symmetric positive semi-definite S.

    A pivot below `rel_tol` times the largest diagonal entry is treated as 0 and its column
    left empty, so rank-deficient covariances (CEM without noise) sample in their subspace
    and the zero matrix gives L = 0.

    Args:
      s: (n, n) symmetric positive semi-definite matrix.
      rel_tol: Relative pivot tolerance.

    Returns:
      (n, n) lower-triangular factor.

    Raises:
      ValueError: If `s` is not square or not finite.
    """
    s = np.asarray(s, dtype=np.float64)
    if s.ndim != 2 or s.shape[0] != s.shape[1] or not np.all(np.isfinite(s)):
        raise ValueError(f"need a finite square matrix, got shape {s.shape}")
    n = s.shape[0]
    floor = rel_tol * max(float(np.max(np.diag(s), initial=0.0)), 0.0)
    low = np.zeros((n, n))
    for j in range(n):
        pivot = float(s[j, j])
        for k in range(j):
            pivot -= float(low[j, k]) * float(low[j, k])
        if pivot <= floor:
            continue
        low[j, j] = np.sqrt(pivot)
        for i in range(j + 1, n):
            value = float(s[i, j])
            for k in range(j):
                value -= float(low[i, k]) * float(low[j, k])
            low[i, j] = value / low[j, j]
    return low


def symmetric_eig(s: np.ndarray, sweeps: int = 30) -> tuple[np.ndarray, np.ndarray]:
    """Eigenvalues and eigenvectors of a symmetric matrix by cyclic Jacobi rotations.

    Args:
      s: (n, n) symmetric matrix.
      sweeps: Most sweeps over the off-diagonal entries (n = 11 converges in under 10).

    Returns:
      `(values, vectors)`: (n,) eigenvalues and (n, n) orthonormal eigenvectors as columns,
      `s ≈ vectors @ diag(values) @ vectors.T`.

    Raises:
      ValueError: If `s` is not square or not finite.
    """
    a = np.array(s, dtype=np.float64)
    if a.ndim != 2 or a.shape[0] != a.shape[1] or not np.all(np.isfinite(a)):
        raise ValueError(f"need a finite square matrix, got shape {a.shape}")
    n = a.shape[0]
    v = np.eye(n)
    for _ in range(sweeps):
        off = 0.0
        for p in range(n - 1):
            for q in range(p + 1, n):
                off += float(a[p, q]) * float(a[p, q])
        if off == 0.0:
            break
        for p in range(n - 1):
            for q in range(p + 1, n):
                _rotate(a, v, p, q)
    return np.diag(a).copy(), v


def _rotate(a: np.ndarray, v: np.ndarray, p: int, q: int) -> None:
    """One Jacobi rotation zeroing a[p, q] (Golub & Van Loan, Alg. 8.5.1), in place."""
    apq = float(a[p, q])
    if apq == 0.0:
        return
    theta = (float(a[q, q]) - float(a[p, p])) / (2.0 * apq)
    t = (1.0 if theta >= 0 else -1.0) / (abs(theta) + float(np.sqrt(theta * theta + 1.0)))
    c = 1.0 / float(np.sqrt(t * t + 1.0))
    s = t * c
    col_p, col_q = a[:, p].copy(), a[:, q].copy()
    a[:, p], a[:, q] = c * col_p - s * col_q, s * col_p + c * col_q
    row_p, row_q = a[p, :].copy(), a[q, :].copy()
    a[p, :], a[q, :] = c * row_p - s * row_q, s * row_p + c * row_q
    vec_p, vec_q = v[:, p].copy(), v[:, q].copy()
    v[:, p], v[:, q] = c * vec_p - s * vec_q, s * vec_p + c * vec_q

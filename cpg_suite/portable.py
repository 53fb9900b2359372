"""Small linear algebra and elementary functions whose results are the same bits on every
x86-64 CPU.

NumPy's `@`, `dot`, `linalg.eigh` and `multivariate_normal(method="eigh")` go through
BLAS/LAPACK (OpenBLAS in the wheels), which picks its kernel per CPU: Haswell, SkylakeX and
Sandybridge kernels block and fuse the sums differently, so the last bit of a sample
differs between machines, and a walking robot's contact dynamics turn that bit into metres
within a few hundred steps. The optimizers draw their candidates with the functions below
instead. They use only element-wise IEEE operations (`+`, `-`, `*`, `/`, `sqrt`), each of
which is correctly rounded whatever SIMD width NumPy's loops use, in a fixed order of
summation. The matrices are tiny (11 × 11), so the Python loops cost microseconds.

The elementary functions at the end of the module (sin, cos, exp, expm1, tanh, the
logistic function, atan2, hypot) replace NumPy's, whose loops are chosen per CPU too
(docs/decisions.md#same-bits-on-every-cpu).
"""

from __future__ import annotations

import math

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
    256-wide layers at every control step. Its last bits differ from `matmul`'s. The
    products are laid out (n, r, c), so that each addition reads two contiguous blocks and
    writes in place.

    Args:
      a: (r, n) array.
      b: (n, c) array.

    Returns:
      (r, c) array.

    Raises:
      ValueError: If the inner dimensions differ.
    """
    a, b = _matrices(a, b)
    terms = a.T[:, :, None] * b[:, None, :]  # (n, r, c): each half one contiguous block
    n = len(terms)
    while n > 1:
        half = (n + 1) // 2
        if n % 2:
            terms[n // 2] += 0.0  # its partner is the padding zero (-0.0 becomes +0.0)
        np.add(terms[: n // 2], terms[half:n], out=terms[: n // 2])
        n = half
    return terms[0]


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


# Elementary functions. NumPy sends float64 `exp`, `log` and `tanh` to SIMD code chosen by
# the CPU (its AVX-512 `exp` and AVX2 `tanh` differ from its baseline loops in the last bit),
# and its other functions to the C library, whose versions and CPU variants differ too. The
# functions below are FreeBSD's msun algorithms (the fdlibm lineage, Sun Microsystems 1993,
# freely usable), rewritten for arrays with the same element-wise IEEE operations as the
# rest of this module, each branch computed for every element and selected with `np.where`.
# Their errors are below one unit in the last place (tests/test_portable.py measures them
# against 60-digit references); their last bits are those of the arithmetic written here,
# on every CPU.

# π/2 in four pieces (msun e_rem_pio2.c): 33 + 33 + 33 leading bits and the rest, so that
# n·piece is exact for |n| < 2**20.
_INV_PIO2 = 6.36619772367581382433e-01
_PIO2_1 = 1.57079632673412561417e00
_PIO2_2 = 6.07710050630396597660e-11
_PIO2_2T = 2.02226624879595063154e-21
_PIO2_3 = 2.02226624871116645580e-21
_PIO2_3T = 8.47842766036889956997e-32
_SIN_SIGNS = np.array([1.0, 1.0, -1.0, -1.0])  # sin(r + qπ/2) = sin r, cos r, −sin r, −cos r
_COS_SIGNS = np.array([1.0, -1.0, -1.0, 1.0])  # cos(r + qπ/2) = cos r, −sin r, −cos r, sin r
TRIG_LIMIT = 2.0**19 * math.pi  # |x| above this: the reduction would lose exactness.
# sin(x)/x − 1 and cos(x) − 1 + x²/2 on |x| ≤ π/4 (msun k_sin.c, k_cos.c).
_SIN = (
    -1.66666666666666324348e-01,
    8.33333333332248946124e-03,
    -1.98412698298579493134e-04,
    2.75573137070700676789e-06,
    -2.50507602534068634195e-08,
    1.58969099521155010221e-10,
)
_COS = (
    4.16666666666666019037e-02,
    -1.38888888888741095749e-03,
    2.48015872894767294178e-05,
    -2.75573143513906633035e-07,
    2.08757232129817482790e-09,
    -1.13596475577881948265e-11,
)
# exp and expm1 (msun e_exp.c, s_expm1.c): ln 2 in two pieces, the remez coefficients.
_LN2_HI = 6.93147180369123816490e-01
_LN2_LO = 1.90821492927058770002e-10
_INV_LN2 = 1.44269504088896338700e00
_EXP = (
    1.66666666666666019037e-01,
    -2.77777777770155933842e-03,
    6.61375632143793436117e-05,
    -1.65339022054652515390e-06,
    4.13813679705723846039e-08,
)
_EXPM1 = (
    -3.33333333333331316428e-02,
    1.58730158725481460165e-03,
    -7.93650757867487942473e-05,
    4.00821782732936239552e-06,
    -2.01099218183624371326e-07,
)
EXP_MAX = 7.09782712893383973096e02  # exp overflows above this
EXP_MIN = -7.45133219101941108420e02  # and is 0 below this
# atan (msun s_atan.c): atan of the interval ends 0.5, 1, 1.5 and ∞ in two pieces, and the
# odd polynomial's coefficients.
_ATAN_HI = (
    4.63647609000806093515e-01,
    7.85398163397448278999e-01,
    9.82793723247329054082e-01,
    1.57079632679489655800e00,
)
_ATAN_LO = (
    2.26987774529616870924e-17,
    3.06161699786838301793e-17,
    1.39033110312309984516e-17,
    6.12323399573676603587e-17,
)
_ATAN = (
    3.33333333333329318027e-01,
    -1.99999999998764832476e-01,
    1.42857142725034663711e-01,
    -1.11111104054623557880e-01,
    9.09088713343650656196e-02,
    -7.69187620504482999495e-02,
    6.66107313738753120669e-02,
    -5.83357013379057348645e-02,
    4.97687799461593236017e-02,
    -3.65315727442169155270e-02,
    1.62858201153657823623e-02,
)
_PI_HI = 3.1415926535897931160e00  # fl(π)
_PI_LO = 1.2246467991473531772e-16  # π − fl(π)


def _constant(value: float) -> np.ndarray:
    """`value` as a read-only 0-d float64 array."""
    out = np.array(value, dtype=np.float64)
    out.flags.writeable = False
    return out


# The elementary functions' constants as 0-d float64 arrays: NumPy converts a Python float
# operand on every call, which on the small arrays these functions see costs as much as the
# operation itself. The values are the same float64 numbers, so the results are the same
# bits (tests/test_portable.py); the public limits stay Python floats.
(_INV_PIO2, _PIO2_1, _PIO2_2, _PIO2_3, _PIO2_3T) = map(
    _constant, (_INV_PIO2, _PIO2_1, _PIO2_2, _PIO2_3, _PIO2_3T)
)
_LN2_HI, _LN2_LO, _INV_LN2, _PI_HI, _PI_LO = map(
    _constant, (_LN2_HI, _LN2_LO, _INV_LN2, _PI_HI, _PI_LO)
)
_SIN, _COS, _EXP, _EXPM1, _ATAN, _ATAN_HI, _ATAN_LO = (
    tuple(map(_constant, c)) for c in (_SIN, _COS, _EXP, _EXPM1, _ATAN, _ATAN_HI, _ATAN_LO)
)
_TRIG_LIMIT, _EXP_MIN, _EXP_MAX = map(_constant, (TRIG_LIMIT, EXP_MIN, EXP_MAX))
_ZERO, _HALF, _ONE, _TWO, _INF = map(_constant, (0.0, 0.5, 1.0, 2.0, math.inf))
_ONE_INT, _THREE = np.array(1, dtype=np.int64), np.array(3, dtype=np.int64)
_HALF_PI_HI = _constant(0.5 * float(_PI_HI))  # 0.5·fl(π), exact
_ONE_HALF, _MINUS_ONE = _constant(1.5), _constant(-1.0)
_ATAN_BOUNDS = np.array([0.4375, 0.6875, 1.1875, 2.4375])  # `_atan_reduced`'s intervals
# atan of each interval's reference point in two pieces, by interval + 1 (none below 7/16).
_ATAN_HI_TABLE = np.array([0.0, *map(float, _ATAN_HI)])
_ATAN_LO_TABLE = np.array([0.0, *map(float, _ATAN_LO)])


def _floats(x) -> np.ndarray:
    return np.asarray(x, dtype=np.float64)


def _poly(z: np.ndarray, coefficients: tuple[float, ...]) -> np.ndarray:
    """c₀ + z (c₁ + z (c₂ + …)), Horner's rule in that order."""
    out = z * coefficients[-1] + coefficients[-2]
    for c in coefficients[-3::-1]:
        out = out * z + c
    return out


def _two_diff(a: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """a − b as the rounded difference and its exact error (Knuth's TwoSum)."""
    s = a - b
    bb = s - a
    return s, (a - (s - bb)) - (b + bb)


def _reduce_pio2(x: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """x = n π/2 + (hi + lo), |hi + lo| ≤ π/4, |lo| ≤ ulp(hi)/2 (msun e_rem_pio2.c's
    three rounds, each round's rounding error carried)."""
    if not (np.abs(x) <= _TRIG_LIMIT).all():
        bad = x[~(np.abs(x) <= TRIG_LIMIT)].ravel()[0]
        raise ValueError(f"sin and cos need finite angles with |x| ≤ 2**19 π, got {bad}")
    n = np.rint(x * _INV_PIO2)
    r = x - n * _PIO2_1  # exact: n·_PIO2_1 has at most 53 bits, and r is its neighbour
    r, e2 = _two_diff(r, n * _PIO2_2)
    r, e3 = _two_diff(r, n * _PIO2_3)
    tail = (e2 + e3) - n * _PIO2_3T
    hi = r + tail
    return n, hi, tail - (hi - r)


def _kernel_sin(x: np.ndarray, y: np.ndarray, z: np.ndarray) -> np.ndarray:
    """sin(x + y) for |x + y| ≤ π/4, |y| ≤ ulp(x)/2, z = x² (msun k_sin.c)."""
    v = z * x
    r = _poly(z, _SIN[1:])
    return x - ((z * (_HALF * y - v * r) - y) - v * _SIN[0])


def _kernel_cos(x: np.ndarray, y: np.ndarray, z: np.ndarray) -> np.ndarray:
    """cos(x + y) for |x + y| ≤ π/4, |y| ≤ ulp(x)/2, z = x² (msun k_cos.c)."""
    r = z * _poly(z, _COS)
    hz = _HALF * z
    w = _ONE - hz
    return w + (((_ONE - w) - hz) + (z * r - x * y))


def sincos(x) -> tuple[np.ndarray, np.ndarray]:
    """(sin x, cos x), element-wise, with one argument reduction.

    Args:
      x: Angles, rad, finite with |x| ≤ `TRIG_LIMIT` (2**19 π).

    Returns:
      Two float64 arrays of x's shape.

    Raises:
      ValueError: If an angle is not finite or beyond `TRIG_LIMIT`.
    """
    x = _floats(x)
    n, hi, lo = _reduce_pio2(x)
    z = hi * hi
    s, c = _kernel_sin(hi, lo, z), _kernel_cos(hi, lo, z)
    quadrant = n.astype(np.int64) & _THREE  # x = n π/2 + r: sin x = ±sin r or ±cos r
    odd = (quadrant & _ONE_INT).astype(bool)
    sin_x = np.where(odd, c, s) * _SIN_SIGNS[quadrant]
    cos_x = np.where(odd, s, c) * _COS_SIGNS[quadrant]
    return sin_x, cos_x


def sin(x) -> np.ndarray:
    """sin x, element-wise (as `sincos`)."""
    return sincos(x)[0]


def cos(x) -> np.ndarray:
    """cos x, element-wise (as `sincos`)."""
    return sincos(x)[1]


def _reduce_ln2(x: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """x = k ln 2 + (hi − lo), |hi − lo| ≤ ln 2 / 2 (k = x / ln 2 rounded to even)."""
    k = np.rint(x * _INV_LN2)
    return k, x - k * _LN2_HI, k * _LN2_LO


def exp(x) -> np.ndarray:
    """eˣ, element-wise (msun e_exp.c): inf above `EXP_MAX`, 0 below `EXP_MIN`, NaN kept.

    Args:
      x: float64 array (or anything that converts to one).

    Returns:
      A float64 array of x's shape.
    """
    x = _floats(x)
    inside = (x >= _EXP_MIN) & (x <= _EXP_MAX)
    if inside.all():
        return _exp(x)
    out = _exp(np.where(inside, x, 0.0))
    return np.where(inside, out, np.where(x > 0.0, np.inf, np.where(x < 0.0, 0.0, x)))


def _exp(x: np.ndarray) -> np.ndarray:
    """eˣ for EXP_MIN ≤ x ≤ EXP_MAX."""
    k, hi, lo = _reduce_ln2(x)
    r = hi - lo
    t = r * r
    c = r - t * _poly(t, _EXP)
    y = _ONE - ((lo - (r * c) / (_TWO - c)) - hi)
    return np.ldexp(y, k.astype(np.int64))


def expm1(x) -> np.ndarray:
    """eˣ − 1, element-wise, accurate near 0 (msun s_expm1.c); −1 below −56 ln 2.

    Args:
      x: float64 array with x ≤ `EXP_MAX` (larger values give inf).

    Returns:
      A float64 array of x's shape.
    """
    x = _floats(x)
    with np.errstate(over="ignore", invalid="ignore"):
        return _expm1(x)


def _expm1(x: np.ndarray) -> np.ndarray:
    clipped = np.clip(np.nan_to_num(x), -40.0, EXP_MAX)
    k, hi, lo = _reduce_ln2(clipped)
    small = np.abs(clipped) <= 0.5 * _LN2_HI  # k = 0: no reduction
    k = np.where(small, 0.0, k)
    hi, lo = np.where(small, clipped, hi), np.where(small, 0.0, lo)
    r = hi - lo
    c = (hi - r) - lo
    hfx = 0.5 * r
    hxs = r * hfx
    r1 = 1.0 + hxs * _poly(hxs, _EXPM1)
    t = 3.0 - r1 * hfx
    e = hxs * ((r1 - t) / (6.0 - r * t))
    unreduced = r - (r * e - hxs)
    e = (r * (e - c) - c) - hxs
    ki = k.astype(np.int64)
    two_k = np.ldexp(1.0, ki)
    out = np.where(
        k == -1.0,
        0.5 * (r - e) - 0.5,
        np.where(r < -0.25, -2.0 * (e - (r + 0.5)), 1.0 + 2.0 * (r - e)),
    )
    wide = np.ldexp(1.0 - (e - r), ki) - 1.0  # k ≤ −2 or k > 56
    below_20 = ((1.0 - np.ldexp(1.0, -ki)) - (e - r)) * two_k  # 2 ≤ k < 20
    above_20 = ((r - (e + np.ldexp(1.0, -ki))) + 1.0) * two_k  # 20 ≤ k ≤ 56
    out = np.where(k == 1.0, out, np.where(k == -1.0, out, 0.0))
    out = np.where((k <= -2.0) | (k > 56.0), wide, out)
    out = np.where((k >= 2.0) & (k < 20.0), below_20, out)
    out = np.where((k >= 20.0) & (k <= 56.0), above_20, out)
    out = np.where(k == 0.0, unreduced, out)
    out = np.where(x > EXP_MAX, np.inf, np.where(x < -40.0, -1.0, out))
    return np.where(np.isnan(x), x, out)


def tanh(x) -> np.ndarray:
    """tanh x, element-wise (msun s_tanh.c): ±1 beyond |x| = 22.

    Args:
      x: float64 array.

    Returns:
      A float64 array of x's shape.
    """
    x = _floats(x)
    a = np.minimum(np.abs(x), 22.0)
    large = a >= 1.0  # 1 - 2 / (e^2a + 1); else -t / (t + 2) with t = e^-2a - 1
    t = expm1(np.where(large, a + a, -(a + a)))  # one expm1 for both: element-wise
    out = np.where(large, 1.0 - 2.0 / (t + 2.0), -t / (t + 2.0))
    out = np.where(a >= 22.0, 1.0, out)
    return np.where(np.isnan(x), x, np.copysign(out, x))


def expit(x) -> np.ndarray:
    """The logistic function 1 / (1 + e⁻ˣ), element-wise, without overflow.

    Args:
      x: float64 array.

    Returns:
      A float64 array of x's shape, in [0, 1].
    """
    x = _floats(x)
    e = exp(-np.abs(x))
    return np.where(x >= _ZERO, _ONE / (_ONE + e), e / (_ONE + e))


def _atan_reduced(x: np.ndarray) -> np.ndarray:
    """atan x for x ≥ 0 (msun s_atan.c, its five argument intervals: −1 below 7/16, then
    0 to 3 from the bounds up; a NaN's is 3, as no bound is at or below it)."""
    interval = np.searchsorted(_ATAN_BOUNDS, x, side="right") - _ONE_INT
    with np.errstate(divide="ignore", invalid="ignore"):
        reduced = np.choose(
            interval + _ONE_INT,
            [
                x,
                (_TWO * x - _ONE) / (_TWO + x),
                (x - _ONE) / (x + _ONE),
                (x - _ONE_HALF) / (_ONE + _ONE_HALF * x),
                _MINUS_ONE / x,
            ],
        )
    z = reduced * reduced
    w = z * z
    odd = z * _poly(w, _ATAN[0::2])
    even = w * _poly(w, _ATAN[1::2])
    poly = reduced * (odd + even)
    hi, lo = _ATAN_HI_TABLE[interval + _ONE_INT], _ATAN_LO_TABLE[interval + _ONE_INT]
    out = hi - ((poly - lo) - reduced)
    return np.where(interval < _ZERO, reduced - poly, out)


def arctan2(y, x) -> np.ndarray:
    """The angle of the point (x, y), element-wise, in [−π, π] (msun e_atan2.c).

    Args:
      y, x: float64 arrays (broadcast together), finite.

    Returns:
      A float64 array, rad.

    Raises:
      ValueError: On a non-finite coordinate.
    """
    y, x = np.broadcast_arrays(_floats(y), _floats(x))
    if not (np.isfinite(y).all() and np.isfinite(x).all()):
        raise ValueError("arctan2 needs finite coordinates")
    ay, ax = np.abs(y), np.abs(x)
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        ratio = np.where(ax > _ZERO, ay / ax, _INF)
    ratio = np.where((ay == _ZERO) & (ax == _ZERO), _ZERO, ratio)
    infinite = np.isinf(ratio)
    a = _atan_reduced(np.where(infinite, _ONE, ratio))
    a = np.where(infinite, _HALF_PI_HI, a)
    a = np.where(np.signbit(x), _PI_HI - (a - _PI_LO), a)
    return np.copysign(a, y)


def hypot(x, y) -> np.ndarray:
    """√(x² + y²), element-wise, from correctly rounded operations (error ≤ 1.5 units in the
    last place; no scaling against overflow: for lengths and speeds, not for |x| > 1e150).

    Args:
      x, y: float64 arrays (broadcast together).

    Returns:
      A float64 array.
    """
    x, y = _floats(x), _floats(y)
    return np.sqrt(x * x + y * y)

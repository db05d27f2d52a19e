"""Direction-based evaluation of the Preetham sky (private; used by :mod:`atmoscatter.sky.preetham`).

Validation of the sun and view vectors, the per-call set-up (coefficients and zenith values
divided by ``F(0, θ_s)``), the chunked NumPy path, the float32 lookup tables and the dispatch
of the compiled row kernels of :mod:`._preetham_kernels` over a thread pool.
"""

from __future__ import annotations

import importlib.util
import math
import os
import threading
from concurrent.futures import ThreadPoolExecutor
from functools import lru_cache

import numpy as np

from .._validate import as_float_array, check_option
from ._preetham_fit import (
    PREETHAM_DISTRIBUTION_MATRIX,
    PREETHAM_ZENITH_CHROMATICITY_MATRICES,
    _BLACK_xy,
    _coefficients,
    _turbidity,
)
from .perez import _horizon_term

#: Whether numba is installed (the compiled kernels of :mod:`._preetham_kernels` are imported
#: on first use, not here, so that ``import atmoscatter`` stays light; the NumPy path computes
#: the same model without them).
_HAVE_NUMBA = importlib.util.find_spec("numba") is not None

_BACKENDS = ("auto", "numba", "numpy")
#: Elements per chunk of the NumPy path (bounded memory: ~30 temporaries of this size).
_CHUNK = 1 << 16

_KIND_XYZ, _KIND_YXY, _KIND_RGB = 0, 1, 2


def _sun(sun_direction) -> np.ndarray:
    """The unit sun vector (float64, shape (3,)), validated."""
    s = as_float_array(sun_direction, "sun_direction").astype(np.float64)
    if s.shape != (3,):
        raise ValueError(f"sun_direction must have shape (3,), got shape {s.shape}")
    x, y, z = s.tolist()
    norm = math.sqrt(x * x + y * y + z * z)
    if not math.isfinite(norm):
        raise ValueError(f"sun_direction must be finite, got {s.tolist()!r}")
    if norm == 0.0:
        raise ValueError("sun_direction must be a non-zero vector, got [0, 0, 0]")
    return s / norm


def _views(view_directions) -> np.ndarray:
    v = as_float_array(view_directions, "view_directions")
    if v.ndim == 0 or v.shape[-1] != 3:
        raise ValueError(
            f"view_directions must have shape (..., 3) (x=east, y=north, z=up), got shape {v.shape}"
        )
    if v.dtype != np.float32:
        v = v.astype(np.float64, copy=False)
    return v


def _setup(sun: np.ndarray, T: float):
    """Per-call constants: coefficient table (3, 5) and zenith values divided by F(0, θ_s)."""
    return _setup_cached(float(T), float(sun[2]))


@lru_cache(maxsize=64)
def _setup_cached(T: float, cos_sun_zenith: float):
    """:func:`_setup` for a turbidity and sun height (cached: repeated calls for one frame).

    Scalar Python arithmetic (the same formulas as :func:`_zenith`), to keep the per-call
    overhead of the direction API small. Returns read-only arrays.
    """
    ts = math.acos(min(max(cos_sun_zenith, -1.0), 1.0))
    M = PREETHAM_DISTRIBUTION_MATRIX
    coef = M[..., 0] * T + M[..., 1]  # (3, 5)
    chi = (4.0 / 9.0 - T / 120.0) * (math.pi - 2.0 * ts)
    Yz = ((4.0453 * T - 4.9710) * math.tan(chi) - 0.2155 * T + 2.4192) * 1000.0
    t_pow = (T * T, T, 1.0)
    s_pow = (ts**3, ts**2, ts, 1.0)
    Mxy = PREETHAM_ZENITH_CHROMATICITY_MATRICES.tolist()
    xz, yz = (
        sum(t_pow[i] * m[i][j] * s_pow[j] for i in range(3) for j in range(4)) for m in Mxy
    )
    cs2 = math.cos(ts) ** 2
    zen = []
    for k, z in enumerate((Yz, xz, yz)):
        A, B, C, D, E = coef[k].tolist()
        zen.append(z / ((1.0 + A * math.exp(B)) * (1.0 + C * math.exp(D * ts) + E * cs2)))
    coef = np.ascontiguousarray(coef)
    zen = np.array(zen)
    coef.flags.writeable = False
    zen.flags.writeable = False
    return coef, zen


def _numpy_chunk(v, sun, coef, zen_scaled, matrix, kind, out):
    """Straightforward NumPy evaluation of one chunk ``v`` (n, 3) into ``out`` (n, 3)."""
    v = v.astype(np.float64)
    inv = 1.0 / np.sqrt(np.einsum("ij,ij->i", v, v))
    cos_t = v[:, 2] * inv
    cos_g = np.clip((v @ sun) * inv, -1.0, 1.0)
    gamma = np.arccos(cos_g)[:, None]
    A, B, C, D, E = (coef[:, i] for i in range(5))
    F = (1.0 + A * _horizon_term(cos_t[:, None], B)) * (
        1.0 + C * np.exp(D * gamma) + E * (cos_g * cos_g)[:, None]
    )
    Yxy = F * zen_scaled
    if kind == _KIND_YXY:
        out[...] = Yxy
        return
    Y, x, y = Yxy[:, 0], Yxy[:, 1], Yxy[:, 2]
    XYZ = np.stack([x / y * Y, Y, (1.0 - x - y) / y * Y], axis=-1)
    out[...] = XYZ if kind == _KIND_XYZ else XYZ @ matrix.T


# The float32 path replaces the six exponentials and the arccos per direction by linear
# interpolation in lookup tables of the two Perez factors (an algebraic shortcut, checked
# against the float64 formula in tests/test_preetham.py with a stated tolerance of 1e-5
# relative; measured ≤ 4e-6):
#   circumsolar factor  1 + C e^{Dγ} + E cos²γ, tabulated uniformly in sin(γ/2) = |v̂ − ŝ|/2
#       for γ ≤ 90° and in cos(γ/2) = |v̂ + ŝ|/2 for γ ≥ 90° (both smooth in their halves,
#       and computed from differences of unit vectors, so accurate at γ → 0 and γ → 180°
#       where acos of a dot product is ill-conditioned);
#   horizon factor      1 + A e^{B/cos θ}, tabulated uniformly in cos θ ∈ [0, 1].
_TABLE_NODES = 4096
_SQRT_HALF = math.sqrt(0.5)
#: Below this many directions the kernel runs in the calling thread only.
_PARALLEL_MIN = 1 << 15
#: Rows per task when a call is spread over threads (tasks are handed out dynamically, so a
#: thread that the OS deschedules on a busy machine does not hold up the others).
_TASK_ROWS = 1 << 14
_POOL: ThreadPoolExecutor | None = None
_POOL_PID: int | None = None
_POOL_LOCK = threading.Lock()


def _thread_pool() -> ThreadPoolExecutor | None:
    """This process's worker pool (created lazily; a forked child makes its own)."""
    global _POOL, _POOL_PID
    workers = os.cpu_count() or 1
    if workers < 2:
        return None
    with _POOL_LOCK:
        if _POOL is None or _POOL_PID != os.getpid():
            _POOL = ThreadPoolExecutor(max_workers=workers, thread_name_prefix="atmoscatter-sky")
            _POOL_PID = os.getpid()
        return _POOL


def _run_rows(rows, n: int, args) -> None:
    """Run the compiled row kernel ``rows(*args, start, stop)`` over ``0:n``.

    The kernels release the GIL, so large calls from the main thread are split into tasks
    over a thread pool with one worker per core. Plain Python threads (not numba's
    OpenMP layer, whose workers spin and which is not fork-safe) keep the kernel well-behaved
    on a shared machine and in forked worker processes. Calls from other threads (a caller
    that parallelises itself) run in that thread.
    """
    pool = None
    if n >= _PARALLEL_MIN and threading.current_thread() is threading.main_thread():
        pool = _thread_pool()
    if pool is None:
        rows(*args, 0, n)
        return
    bounds = [(i, min(n, i + _TASK_ROWS)) for i in range(0, n, _TASK_ROWS)]
    futures = [pool.submit(rows, *args, lo, hi) for lo, hi in bounds[1:]]
    rows(*args, *bounds[0])
    for f in futures:
        f.result()


@lru_cache(maxsize=16)
def _tables(T: float) -> np.ndarray:
    """Lookup table (6, 2N) of the float32 kernel for turbidity ``T`` (see :func:`._preetham_kernels._table_rows`).

    Rows 0–2: horizon factor ``1 + A e^{B/cos θ}`` of Y, x, y at N nodes uniform in
    cos θ ∈ [0, 1] (then zero padding); rows 3–5: circumsolar factor
    ``1 + C e^{Dγ} + E cos²γ`` at N nodes uniform in sin(γ/2) ∈ [0, √½] (γ ≤ 90°) followed by
    N nodes uniform in cos(γ/2) ∈ [0, √½] (γ ≥ 90°).
    """
    N = _TABLE_NODES
    coef = _coefficients(np.asarray(T))
    A, B, C, D, E = coef.T
    s = np.linspace(0.0, _SQRT_HALF, N)
    near = 2.0 * np.arcsin(s)  # γ in [0, π/2], node = sin(γ/2)
    far = np.pi - near  # γ in [π/2, π], node = cos(γ/2)
    g = np.concatenate([near, far])[:, None]
    c = np.linspace(0.0, 1.0, N)[:, None]
    tab = np.zeros((6, 2 * N))
    tab[:3, :N] = (1.0 + A * _horizon_term(c, B)).T
    tab[3:] = (1.0 + C * np.exp(D * g) + E * np.cos(g) ** 2).T
    tab.flags.writeable = False
    return tab


def _kernels():
    """The compiled row kernels ``(direct_rows, table_rows)`` of
    :mod:`._preetham_kernels`, imported (and compiled or loaded from numba's cache) on first
    use so that importing the package does not import numba; ``None`` without numba."""
    from .._lazy import kernels  # noqa: PLC0415

    k = kernels("atmoscatter.sky._preetham_kernels")
    return None if k is None else (k._direct_rows, k._table_rows)


def _evaluate(view_directions, sun_direction, turbidity, kind, matrix, out_of_range, backend):
    check_option(backend, "backend", _BACKENDS)
    if backend == "numba" and not _HAVE_NUMBA:  # pragma: no cover
        raise ValueError("backend='numba' requested but numba is not installed")
    T = float(_turbidity(turbidity, out_of_range, scalar=True))
    sun = _sun(sun_direction)
    v = _views(view_directions)
    shape = v.shape
    flat = np.ascontiguousarray(v.reshape(-1, 3))
    n = flat.shape[0]
    out = np.empty(flat.shape, dtype=v.dtype)
    if sun[2] < 0.0:  # sun below the horizon: dark sky (documented policy)
        out[...] = 0.0
        if kind == _KIND_YXY:
            out[:, 1:] = _BLACK_xy
        out[np.isnan(flat).any(axis=1)] = np.nan
        return out.reshape(shape)
    if n == 0:
        return out.reshape(shape)
    coef, zen_scaled = _setup(sun, T)
    matrix = np.eye(3) if matrix is None else np.ascontiguousarray(matrix, dtype=np.float64)
    kernels = _kernels() if backend != "numpy" else None
    if kernels is not None:
        direct_rows, table_rows = kernels
        if v.dtype == np.float32:
            args = (flat, sun.astype(np.float32), _tables(T), zen_scaled, matrix, kind, out)
            _run_rows(table_rows, n, args)
        else:
            _run_rows(direct_rows, n, (flat, sun, coef, zen_scaled, matrix, kind, out))
    else:
        with np.errstate(invalid="ignore", divide="ignore"):  # NaN/zero vectors give NaN
            for start in range(0, n, _CHUNK):
                sl = slice(start, start + _CHUNK)
                _numpy_chunk(flat[sl], sun, coef, zen_scaled, matrix, kind, out[sl])
    return out.reshape(shape)

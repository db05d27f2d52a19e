"""Preetham, Shirley & Smits (1999) analytic daylight model.

Public objects
--------------
PREETHAM_DISTRIBUTION_MATRIX
    Perez coefficients ``[A, B, C, D, E] = a·T + b`` for Y, x and y.
PREETHAM_ZENITH_CHROMATICITY_MATRICES
    ``M_x`` and ``M_y`` of the zenith chromaticity polynomials.
PreethamValidityWarning
    Warning issued when the turbidity is clamped into the fit's range.
preetham_distribution_coefficients, preetham_zenith
    The model's building blocks as functions of turbidity and sun zenith.
preetham_Yxy
    Yxy from angles (θ, γ, θ_s), fully broadcasting.
preetham_sky, preetham_sky_Yxy, preetham_sky_rgb, preetham_sky_spectral
    The sky for arrays of view directions in the local frame (x = east, y = north, z = up):
    CIE XYZ, Yxy, linear RGB (through colour-science) and spectral radiance (CIE D-series).

Model (seed 003 §5–6, seed 004, errata 003.3)::

    Y = Y_z F_Y(θ, γ) / F_Y(0, θ_s),  x = x_z F_x(θ, γ) / F_x(0, θ_s),  y = y_z F_y(θ, γ) / F_y(0, θ_s)
    F(θ, γ) = (1 + A e^{B/cos θ}) (1 + C e^{Dγ} + E cos²γ)                     (Perez et al. 1993)
    Y_z = [(4.0453 T − 4.9710) tan χ − 0.2155 T + 2.4192] kcd m⁻²,  χ = (4/9 − T/120)(π − 2θ_s)
    x_z = [T², T, 1] M_x [θ_s³, θ_s², θ_s, 1]ᵀ,   y_z likewise with M_y

Validity policy
---------------
The fit is documented for turbidity 2 ≤ T ≤ 10 and the sun above the horizon (errata 003.4).

* ``T < 1`` or non-finite: :class:`ValueError` (``T = (τ_m + τ_h)/τ_m ≥ 1`` by definition).
* ``1 ≤ T < 2`` or ``T > 10``: with ``out_of_range="warn"`` (default) a
  :class:`PreethamValidityWarning` is issued and the model is evaluated at ``T`` clamped to
  ``[2, 10]``; with ``out_of_range="raise"`` a :class:`ValueError`. Unclamped, the fit turns
  negative (the zenith factor ``1 + A e^{B}`` crosses zero near T ≈ 1.6; ``Y_z`` at a
  horizon sun is negative for T > 11.2).
* Sun below the horizon (``θ_s > 90°``): the sky is dark, every output is exactly 0 (Yxy
  gives ``Y = 0`` with the D65 chromaticity, as colour-science does for black). No warning:
  night is normal use. At ``θ_s = 90°`` exactly the model is evaluated (finite, positive).
* View directions below the horizon are evaluated at the horizon (``cos θ`` clamped to 0;
  γ from the true direction), so the output is continuous and non-negative.

Inside that domain the outputs are finite and non-negative (tested on a dense grid).

References
----------
Preetham, A. J., Shirley, P. & Smits, B. (1999). A practical analytic model for daylight.
*Proceedings of SIGGRAPH 99*, 91–100, Appendix A.2. Perez, R., Seals, R. & Michalsky, J.
(1993). All-weather model for sky luminance distribution. *Solar Energy* 50, 235–245.
Wyszecki, G. & Stiles, W. S. (1982). *Color Science*, 2nd ed., §3.3.4 (CIE daylight basis).
"""

from __future__ import annotations

import importlib.util
import math
import os
import threading
import warnings
from concurrent.futures import ThreadPoolExecutor
from functools import lru_cache

import numpy as np

from .._validate import as_float_array, check_option
from ..colour import K_M, XYZ_to_linear_rgb, cmf_weights, spectral_to_XYZ
from .perez import _horizon_term

#: Whether numba is installed (the compiled kernels of :mod:`._preetham_kernels` are imported
#: on first use, not here, so that ``import atmoscatter`` stays light; the NumPy path computes
#: the same model without them).
_HAVE_NUMBA = importlib.util.find_spec("numba") is not None

__all__ = [
    "PREETHAM_DISTRIBUTION_MATRIX",
    "PREETHAM_ZENITH_CHROMATICITY_MATRICES",
    "PREETHAM_TURBIDITY_RANGE",
    "PreethamValidityWarning",
    "preetham_distribution_coefficients",
    "preetham_zenith",
    "preetham_Yxy",
    "preetham_sky",
    "preetham_sky_Yxy",
    "preetham_sky_rgb",
    "preetham_sky_spectral",
]

#: Perez coefficients of the Preetham model: ``[A, B, C, D, E] = M[k] @ [T, 1]`` for
#: k = Y, x, y (rows), shape (3, 5, 2). Preetham et al. (1999), Appendix A.2; errata 003.3.
PREETHAM_DISTRIBUTION_MATRIX: np.ndarray = np.array(
    [
        [[0.1787, -1.4630], [-0.3554, 0.4275], [-0.0227, 5.3251], [0.1206, -2.5771],
         [-0.0670, 0.3703]],
        [[-0.0193, -0.2592], [-0.0665, 0.0008], [-0.0004, 0.2125], [-0.0641, -0.8989],
         [-0.0033, 0.0452]],
        [[-0.0167, -0.2608], [-0.0950, 0.0092], [-0.0079, 0.2102], [-0.0441, -1.6537],
         [-0.0109, 0.0529]],
    ]
)  # fmt: skip
PREETHAM_DISTRIBUTION_MATRIX.flags.writeable = False

#: Zenith chromaticity matrices ``(M_x, M_y)``, shape (2, 3, 4):
#: ``x_z = [T², T, 1] · M_x · [θ_s³, θ_s², θ_s, 1]ᵀ`` with θ_s in radians.
#: Preetham et al. (1999), Appendix A.2; errata 003.3.
PREETHAM_ZENITH_CHROMATICITY_MATRICES: np.ndarray = np.array(
    [
        [[0.00166, -0.00375, 0.00209, 0.0],
         [-0.02903, 0.06377, -0.03202, 0.00394],
         [0.11693, -0.21196, 0.06052, 0.25886]],
        [[0.00275, -0.00610, 0.00317, 0.0],
         [-0.04214, 0.08970, -0.04153, 0.00516],
         [0.15346, -0.26756, 0.06670, 0.26688]],
    ]
)  # fmt: skip
PREETHAM_ZENITH_CHROMATICITY_MATRICES.flags.writeable = False

#: Turbidity range of the fit (Preetham et al. 1999; errata 003.4). [1]
PREETHAM_TURBIDITY_RANGE: tuple[float, float] = (2.0, 10.0)

#: Chromaticity reported for black (zero luminance): CIE D65, 2° observer (as colour-science).
_BLACK_xy = (0.3127, 0.3290)

_OUT_OF_RANGE_POLICIES = ("warn", "raise")
_BACKENDS = ("auto", "numba", "numpy")
#: Elements per chunk of the NumPy path (bounded memory: ~30 temporaries of this size).
_CHUNK = 1 << 16


class PreethamValidityWarning(UserWarning):
    """The Preetham model left its fitted domain: turbidity clamped into [2, 10], or negative
    spectral values from the D-series reconstruction (see :func:`preetham_sky_spectral`)."""


# ----------------------------------------------------------------------------------------------
# building blocks
# ----------------------------------------------------------------------------------------------
def _turbidity(turbidity, out_of_range: str, *, scalar: bool = False) -> np.ndarray:
    """Apply the validity policy to ``turbidity``; returns the (clamped) float64 array."""
    check_option(out_of_range, "out_of_range", _OUT_OF_RANGE_POLICIES)
    if type(turbidity) in (float, int) and 2.0 <= turbidity <= 10.0:  # fast path, in range
        return np.float64(turbidity)
    T = as_float_array(turbidity, "turbidity").astype(np.float64)
    if scalar and T.ndim != 0:
        raise ValueError(
            f"turbidity must be a scalar for direction-based Preetham skies, got shape {T.shape}"
        )
    bad = ~np.isfinite(T) | (T < 1.0)
    if np.any(bad):
        value = T[bad].ravel()[0] if T.ndim else T.item()
        raise ValueError(
            f"turbidity must be finite and >= 1 (T = (tau_m + tau_h)/tau_m), got {value!r}"
        )
    lo, hi = PREETHAM_TURBIDITY_RANGE
    outside = (T < lo) | (T > hi)
    if np.any(outside):
        value = T[outside].ravel()[0] if T.ndim else T.item()
        if out_of_range == "raise":
            raise ValueError(
                f"turbidity must be in [{lo}, {hi}] (range of the Preetham fit), got {value!r}"
            )
        warnings.warn(
            f"turbidity {value!r} is outside the Preetham fit's range [{lo}, {hi}]; "
            f"evaluating at the clamped turbidity {min(max(value, lo), hi)!r}",
            PreethamValidityWarning,
            stacklevel=4,
        )
        T = np.clip(T, lo, hi)
    return T


def preetham_distribution_coefficients(turbidity, *, out_of_range: str = "warn") -> np.ndarray:
    """Perez distribution coefficients of the Preetham model.

    ``[A, B, C, D, E] = a·T + b`` with the (a, b) pairs of Preetham et al. (1999),
    Appendix A.2 (seed 003 §6, errata 003.3).

    Parameters
    ----------
    turbidity : array_like
        Linke-type turbidity ``T = (τ_m + τ_h)/τ_m``; fit range 2–10 (see the module's
        validity policy). [1]
    out_of_range : {"warn", "raise"}
        Policy for ``T`` outside [2, 10]: warn and clamp, or raise ``ValueError``.

    Returns
    -------
    numpy.ndarray
        Shape ``T.shape + (3, 5)``: rows Y, x, y; columns A, B, C, D, E. [1]
    """
    T = _turbidity(turbidity, out_of_range)
    return _coefficients(T)


def _coefficients(T: np.ndarray) -> np.ndarray:
    M = PREETHAM_DISTRIBUTION_MATRIX
    return M[..., 0] * T[..., None, None] + M[..., 1]


def _zenith(T: np.ndarray, sun_zenith: np.ndarray) -> np.ndarray:
    """Y_z [cd m⁻²], x_z, y_z on the last axis for sun zenith in [0, π/2] (no checks)."""
    chi = (4.0 / 9.0 - T / 120.0) * (np.pi - 2.0 * sun_zenith)
    Yz = ((4.0453 * T - 4.9710) * np.tan(chi) - 0.2155 * T + 2.4192) * 1000.0
    t_pow = np.stack([T * T, T, np.ones_like(T)], axis=-1)
    s_pow = np.stack(
        [sun_zenith**3, sun_zenith**2, sun_zenith, np.ones_like(sun_zenith)], axis=-1
    )
    M = PREETHAM_ZENITH_CHROMATICITY_MATRICES
    xz = np.einsum("...i,ij,...j->...", t_pow, M[0], s_pow)
    yz = np.einsum("...i,ij,...j->...", t_pow, M[1], s_pow)
    return np.stack(np.broadcast_arrays(Yz, xz, yz), axis=-1)


def preetham_zenith(turbidity, sun_zenith, *, out_of_range: str = "warn") -> np.ndarray:
    """Zenith luminance and chromaticity of the Preetham sky.

    ``Y_z = [(4.0453 T − 4.9710) tan χ − 0.2155 T + 2.4192]`` kcd m⁻² with
    ``χ = (4/9 − T/120)(π − 2θ_s)``, and ``x_z``, ``y_z`` from the cubic-in-θ_s, quadratic-in-T
    polynomials of Preetham et al. (1999), Appendix A.2 (seed 003 §6, errata 003.3).

    Parameters
    ----------
    turbidity : array_like
        Turbidity (fit range 2–10; see the validity policy). [1]
    sun_zenith : array_like
        Solar zenith angle, broadcast against ``turbidity``. [rad]
    out_of_range : {"warn", "raise"}
        Turbidity policy outside [2, 10].

    Returns
    -------
    numpy.ndarray
        ``(Y_z [cd m⁻²], x_z, y_z)`` on the last axis. For a sun below the horizon
        (``θ_s > π/2``) ``Y_z = 0`` and ``(x_z, y_z)`` is D65's chromaticity.

    Raises
    ------
    ValueError
        For ``sun_zenith`` outside [0, π] or a turbidity violating the policy.
    """
    T = _turbidity(turbidity, out_of_range)
    ts = as_float_array(sun_zenith, "sun_zenith").astype(np.float64)
    if np.any((ts < 0) | (ts > np.pi)):
        bad = ts[(ts < 0) | (ts > np.pi)].ravel()[0] if ts.ndim else ts.item()
        raise ValueError(f"sun_zenith must be in [0, pi] rad, got {bad!r}")
    night = ts > np.pi / 2
    out = _zenith(T, np.minimum(ts, np.pi / 2))
    if np.any(night):
        out = np.where(night[..., None], np.array([0.0, *_BLACK_xy]), out)
    return out


def preetham_Yxy(view_zenith, gamma, sun_zenith, turbidity, *, out_of_range: str = "warn"):
    """Preetham sky Yxy from angles (broadcasting NumPy evaluation).

    ``Y = Y_z F_Y(θ, γ)/F_Y(0, θ_s)`` and likewise for x, y (seed 004; errata 003.3),
    with :func:`atmoscatter.perez` as ``F``.

    Parameters
    ----------
    view_zenith : array_like
        Zenith angle θ of the view direction; values ≥ π/2 give the horizon value. [rad]
    gamma : array_like
        Angle γ between view direction and sun, in [0, π]. [rad]
    sun_zenith : array_like
        Solar zenith θ_s in [0, π]; above π/2 the result is dark (Y = 0). [rad]
    turbidity : array_like
        Turbidity, fit range 2–10 (see the validity policy). [1]
    out_of_range : {"warn", "raise"}
        Turbidity policy outside [2, 10].

    Returns
    -------
    numpy.ndarray
        ``(Y [cd m⁻²], x, y)`` on the last axis, broadcast shape of the inputs; float64.
    """
    T = _turbidity(turbidity, out_of_range)
    theta = as_float_array(view_zenith, "view_zenith").astype(np.float64)
    gamma = as_float_array(gamma, "gamma").astype(np.float64)
    ts = as_float_array(sun_zenith, "sun_zenith").astype(np.float64)
    if np.any((ts < 0) | (ts > np.pi)):
        bad = ts[(ts < 0) | (ts > np.pi)].ravel()[0] if ts.ndim else ts.item()
        raise ValueError(f"sun_zenith must be in [0, pi] rad, got {bad!r}")
    night = ts > np.pi / 2
    ts_c = np.minimum(ts, np.pi / 2)
    coef = _coefficients(T)  # (..., 3, 5)
    zen = _zenith(T, ts_c)  # (..., 3)
    A, B, C, D, E = (coef[..., i] for i in range(5))  # each (..., 3)
    cos_t = np.cos(theta)[..., None]
    g = gamma[..., None]
    cg = np.cos(g)
    F = (1.0 + A * _horizon_term(cos_t, B)) * (1.0 + C * np.exp(D * g) + E * cg * cg)
    cs = np.cos(ts_c)[..., None]
    F0 = (1.0 + A * np.exp(B)) * (1.0 + C * np.exp(D * ts_c[..., None]) + E * cs * cs)
    out = zen * F / F0
    if np.any(night):
        out = np.where(night[..., None], np.array([0.0, *_BLACK_xy]), out)
    return out


# ----------------------------------------------------------------------------------------------
# direction-based evaluation: shared set-up, NumPy path and compiled kernel
# ----------------------------------------------------------------------------------------------
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


def preetham_sky(
    view_directions, sun_direction, turbidity, *, out_of_range="warn", backend="auto"
):
    """Preetham sky in CIE XYZ for arrays of view directions.

    ``Y = Y_z F_Y(θ, γ)/F_Y(0, θ_s)``, ``x``, ``y`` likewise (seed 003 §5–6, seed 004,
    errata 003.3), then ``X = x Y / y``, ``Z = (1 − x − y) Y / y``. Exact to the published
    model (float64: ≤ 1e-12 relative to a scalar transcription of the formulas).

    Parameters
    ----------
    view_directions : array_like
        Unit view directions, shape (..., 3), local frame x = east, y = north, z = up.
        float32 input gives float32 output (compiled path: table interpolation of the
        Perez factors, within 1e-5 relative of float64, measured ≤ 4e-6); anything else is
        evaluated in float64 from the formulas.
        Non-unit vectors are normalised; NaN (or a zero vector) gives NaN.
    sun_direction : array_like
        Direction toward the sun, shape (3,), same frame (normalised internally).
    turbidity : float
        Turbidity (scalar), fit range 2–10; see the module's validity policy. [1]
    out_of_range : {"warn", "raise"}
        Turbidity outside [2, 10]: warn (:class:`PreethamValidityWarning`) and clamp, or raise.
    backend : {"auto", "numba", "numpy"}
        ``"auto"`` uses the compiled kernel (threaded over the cores for large calls) when numba
        is installed, else chunked NumPy.

    Returns
    -------
    numpy.ndarray
        CIE 1931 XYZ [cd m⁻²] on the last axis, shape of ``view_directions``. All zeros for a
        sun below the horizon; views below the horizon take the horizon value.

    Examples
    --------
    >>> import numpy as np, atmoscatter as ac
    >>> sun = np.array([0.0, np.sin(np.radians(40)), np.cos(np.radians(40))])
    >>> XYZ = ac.preetham_sky([0.0, 0.0, 1.0], sun, 3.0)
    >>> round(float(XYZ[1]) / 1000, 3)   # zenith luminance Y_z [kcd m^-2]
    8.211
    """
    return _evaluate(
        view_directions, sun_direction, turbidity, _KIND_XYZ, None, out_of_range, backend
    )


def preetham_sky_Yxy(
    view_directions, sun_direction, turbidity, *, out_of_range="warn", backend="auto"
):
    """Preetham sky as CIE Yxy (luminance [cd m⁻²], chromaticity x, y) on the last axis.
    Parameters
    ----------
    view_directions : array_like
        Unit view directions, shape (..., 3), local frame x = east, y = north, z = up.
        float32 input gives float32 output (compiled path: table interpolation of the
        Perez factors, within 1e-5 relative of float64, measured ≤ 4e-6); anything else is
        evaluated in float64 from the formulas.
        Non-unit vectors are normalised; NaN (or a zero vector) gives NaN.
    sun_direction : array_like
        Direction toward the sun, shape (3,), same frame (normalised internally).
    turbidity : float
        Turbidity (scalar), fit range 2–10; see the module's validity policy. [1]
    out_of_range : {"warn", "raise"}
        Turbidity outside [2, 10]: warn (:class:`PreethamValidityWarning`) and clamp, or raise.
    backend : {"auto", "numba", "numpy"}
        ``"auto"`` uses the compiled kernel (threaded over the cores for large calls) when numba
        is installed, else chunked NumPy.

    Returns
    -------
    numpy.ndarray
        ``(Y [cd m⁻²], x, y)`` on the last axis (note the Yxy order, not colour-science's xyY).
    """
    return _evaluate(
        view_directions, sun_direction, turbidity, _KIND_YXY, None, out_of_range, backend
    )


@lru_cache(maxsize=32)
def _xyz_to_rgb_matrix(colourspace: str) -> np.ndarray:
    """The linear XYZ → RGB matrix of ``colourspace`` as the colour wrappers apply it.

    Obtained by applying :func:`atmoscatter.XYZ_to_linear_rgb` (colour-science's
    normalised primary matrix, no chromatic adaptation) to the unit vectors, so no matrix is
    copied by hand and the fused kernel agrees with the wrapper by construction.
    """
    m = np.ascontiguousarray(
        np.asarray(XYZ_to_linear_rgb(np.eye(3), colourspace=colourspace), dtype=np.float64).T
    )
    m.flags.writeable = False
    return m


def preetham_sky_rgb(
    view_directions,
    sun_direction,
    turbidity,
    *,
    colourspace="sRGB",
    out_of_range="warn",
    backend="auto",
):
    """Preetham sky in linear RGB (XYZ → RGB through colour-science).

    The linear transform is the one of :func:`atmoscatter.colour.XYZ_to_linear_rgb` for
    ``colourspace`` (default linear sRGB / Rec. 709 primaries, no encoding curve), fused
    into the per-direction kernel.

    Parameters
    ----------
    view_directions : array_like
        Unit view directions, shape (..., 3), local frame x = east, y = north, z = up.
        float32 input gives float32 output (compiled path: table interpolation of the
        Perez factors, within 1e-5 relative of float64, measured ≤ 4e-6); anything else is
        evaluated in float64 from the formulas.
        Non-unit vectors are normalised; NaN (or a zero vector) gives NaN.
    sun_direction : array_like
        Direction toward the sun, shape (3,), same frame (normalised internally).
    turbidity : float
        Turbidity (scalar), fit range 2–10; see the module's validity policy. [1]
    colourspace : str
        A colour-science RGB colourspace name (``colour.RGB_COLOURSPACES``). [default "sRGB"]
    out_of_range : {"warn", "raise"}
        Turbidity outside [2, 10]: warn (:class:`PreethamValidityWarning`) and clamp, or raise.
    backend : {"auto", "numba", "numpy"}
        ``"auto"`` uses the compiled kernel (threaded over the cores for large calls) when numba
        is installed, else chunked NumPy.

    Returns
    -------
    numpy.ndarray
        Linear RGB on the last axis, scaled so that luminance is in cd m⁻² (out-of-gamut
        colours may have negative components; nothing is clipped).
    """
    matrix = _xyz_to_rgb_matrix(colourspace)
    return _evaluate(
        view_directions, sun_direction, turbidity, _KIND_RGB, matrix, out_of_range, backend
    )


# ----------------------------------------------------------------------------------------------
# spectral radiance (CIE D-series reconstruction)
# ----------------------------------------------------------------------------------------------
#: Default wavelengths of :func:`preetham_sky_spectral`: 380–780 nm every 5 nm. [nm]
DEFAULT_WAVELENGTHS = np.arange(380.0, 781.0, 5.0)
_M_METHODS = ("published", "exact")


@lru_cache(maxsize=8)
def _daylight_basis(wavelengths: tuple[float, ...]) -> tuple[np.ndarray, np.ndarray]:
    """S0, S1, S2 on ``wavelengths`` (n, 3) and their tristimulus values (3 XYZ, 3 bases).

    The basis comes from colour-science (CIE 15:2004 Table T.2, 5 nm, linearly interpolated
    as CIE recommends); the XYZ of each basis vector uses the same integration as
    :func:`atmoscatter.colour.spectral_to_XYZ`, so luminance scaling round-trips exactly.
    """
    from colour.colorimetry import SDS_BASIS_FUNCTIONS_CIE_ILLUMINANT_D_SERIES as basis

    wl = np.asarray(wavelengths)
    cols = []
    for name in ("S0", "S1", "S2"):
        sd = basis[name]
        cols.append(np.interp(wl, sd.wavelengths, sd.values))
    S = np.stack(cols, axis=-1)
    XYZ = np.asarray(spectral_to_XYZ(S.T, wl), dtype=np.float64)  # (3 bases, 3 XYZ)
    return S, np.ascontiguousarray(XYZ.T)  # XYZ columns = bases


def _daylight_M(x, y, method, basis_XYZ):
    """M1, M2 of the D-series reconstruction for chromaticity (x, y)."""
    if method == "published":
        # Wyszecki & Stiles (1982) / CIE 15; seed 004 "Preetham et al spectral radiance model".
        den = 0.0241 + 0.2562 * x - 0.7341 * y
        M1 = (-1.3515 - 1.7703 * x + 5.9114 * y) / den
        M2 = (0.0300 - 31.4424 * x + 30.0717 * y) / den
        return M1, M2
    # "exact": solve X - x(X+Y+Z) = 0, Y - y(X+Y+Z) = 0 for (M1, M2) with the tristimulus
    # values of S0, S1, S2 on the wavelength grid in use (linear in M1, M2).
    X, Y, Z = basis_XYZ  # each (3,) over bases S0, S1, S2
    Ssum = X + Y + Z
    a = X[None, :] - x[:, None] * Ssum[None, :]  # (n, 3)
    b = Y[None, :] - y[:, None] * Ssum[None, :]
    det = a[:, 1] * b[:, 2] - a[:, 2] * b[:, 1]
    M1 = (-a[:, 0] * b[:, 2] + a[:, 2] * b[:, 0]) / det
    M2 = (-a[:, 1] * b[:, 0] + a[:, 0] * b[:, 1]) / det
    return M1, M2


def preetham_sky_spectral(
    view_directions,
    sun_direction,
    turbidity,
    wavelengths=None,
    *,
    m_coefficients="published",
    clip_negative=False,
    out_of_range="warn",
    backend="auto",
):
    """Preetham sky spectral radiance from the CIE D-series reconstruction.

    For each direction the model's (x, y) give ``M1``, ``M2`` and
    ``S_D(λ) = S_0(λ) + M_1 S_1(λ) + M_2 S_2(λ)`` (seed 004; Wyszecki & Stiles 1982), which
    is scaled so that ``683 lm/W ∫ L(λ) ȳ(λ) dλ`` equals the model's luminance Y.

    Parameters
    ----------
    view_directions : array_like
        Unit view directions, shape (..., 3), local frame x = east, y = north, z = up.
        float32 input gives float32 output (compiled path: table interpolation of the
        Perez factors, within 1e-5 relative of float64, measured ≤ 4e-6); anything else is
        evaluated in float64 from the formulas.
        Non-unit vectors are normalised; NaN (or a zero vector) gives NaN.
    sun_direction : array_like
        Direction toward the sun, shape (3,), same frame (normalised internally).
    turbidity : float
        Turbidity (scalar), fit range 2–10; see the module's validity policy. [1]
    wavelengths : array_like, optional
        Strictly increasing wavelengths in [300, 830] nm; default 380–780 nm every 5 nm. [nm]
    m_coefficients : {"published", "exact"}
        ``"published"``: the printed M1, M2 formulas (seed 004; CIE 15), whose 4-digit
        coefficients reproduce (x, y) to ~1e-4 after integration; ``"exact"``: M1, M2 solved
        from the chromaticity equations with the basis' tristimulus values on ``wavelengths``,
        reproducing (x, y) to rounding.
    clip_negative : bool
        The D-series basis was fitted to daylight; for chromaticities far from the daylight
        locus (low sun: the yellowish sky near the horizon and sun has x ≈ 0.43, y ≈ 0.47)
        ``S_D`` turns negative at short wavelengths (down to −60 % of the peak at θ_s = 90°,
        T = 2). ``False`` (default): keep the reconstruction (exact round trip) and issue a
        :class:`PreethamValidityWarning` when any value is negative; ``True``: set negative
        values to 0 and rescale each spectrum to keep its luminance Y (its chromaticity then
        moves toward the spectrum locus; no warning).
    out_of_range : {"warn", "raise"}
        Turbidity outside [2, 10]: warn (:class:`PreethamValidityWarning`) and clamp, or raise.
    backend : {"auto", "numba", "numpy"}
        ``"auto"`` uses the compiled kernel (threaded over the cores for large calls) when numba
        is installed, else chunked NumPy.

    Returns
    -------
    numpy.ndarray
        Spectral radiance [W m⁻² sr⁻¹ nm⁻¹], shape ``view_directions.shape[:-1] + (n_wl,)``.
        Integrating it with the CIE 1931 CMFs (``atmoscatter.spectral_to_XYZ``) gives back the
        model's Y exactly and its (x, y) to the accuracy stated for ``m_coefficients``.
    """
    check_option(m_coefficients, "m_coefficients", _M_METHODS)
    wl = DEFAULT_WAVELENGTHS if wavelengths is None else as_float_array(wavelengths, "wavelengths")
    wl = np.asarray(wl, dtype=np.float64)
    if wl.ndim != 1 or wl.size < 2 or np.any(np.diff(wl) <= 0):
        raise ValueError(
            f"wavelengths must be a strictly increasing 1-D array of >= 2 values [nm], got shape {wl.shape}"
        )
    if wl[0] < 300.0 or wl[-1] > 830.0:
        raise ValueError(
            f"wavelengths must lie in [300, 830] nm (range of the CIE daylight basis), "
            f"got [{wl[0]}, {wl[-1]}]"
        )
    Yxy = preetham_sky_Yxy(
        view_directions, sun_direction, turbidity, out_of_range=out_of_range, backend=backend
    )
    dtype = Yxy.dtype
    S, basis_XYZ = _daylight_basis(tuple(wl.tolist()))
    flat = Yxy.reshape(-1, 3).astype(np.float64)
    out = np.empty((flat.shape[0], wl.size), dtype=dtype)
    with np.errstate(invalid="ignore", divide="ignore"):  # NaN directions stay NaN
        for start in range(0, flat.shape[0], max(1, _CHUNK // 4)):
            sl = slice(start, start + max(1, _CHUNK // 4))
            Y, x, y = flat[sl, 0], flat[sl, 1], flat[sl, 2]
            M1, M2 = _daylight_M(x, y, m_coefficients, basis_XYZ)
            w = np.stack([np.ones_like(M1), M1, M2], axis=-1)  # (n, 3)
            Y_D = w @ basis_XYZ[1]  # luminance of the unscaled S_D
            scale = np.where(Y > 0.0, Y / np.where(Y > 0.0, Y_D, 1.0), 0.0)
            scale = np.where(np.isnan(Y), np.nan, scale)
            out[sl] = (w * scale[:, None]) @ S.T
    negative = out < 0
    if np.any(negative):
        if clip_negative:
            rows = negative.any(axis=1)
            part = np.maximum(out[rows].astype(np.float64), 0.0)
            Y_clip = part @ (K_M * cmf_weights(wl)[:, 1])
            Y_want = flat[rows, 0]
            with np.errstate(invalid="ignore", divide="ignore"):
                k = np.where(Y_clip > 0, Y_want / np.where(Y_clip > 0, Y_clip, 1.0), 0.0)
            out[rows] = part * k[:, None]
        else:
            warnings.warn(
                f"{int(negative.any(axis=1).sum())} spectra of the CIE D-series reconstruction "
                "have negative values (chromaticity far from the daylight locus); pass "
                "clip_negative=True to clip them at 0 (keeping Y)",
                PreethamValidityWarning,
                stacklevel=2,
            )
    return out.reshape(Yxy.shape[:-1] + (wl.size,))



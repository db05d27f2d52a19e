"""Hoffman–Preetham aerial perspective, sunlight and two-shell sky (seed 000, seed 004).

Public objects
--------------
one_minus_exp_ratio
    ``(1 − e^{−x})/x`` without cancellation near 0 or overflow far out.
path_integral
    ``∫₀^s e^{−β t} dt = (1 − e^{−β s})/β`` with its limits (β → 0: ``s``; s → ∞: ``1/β``).
HazePreset, HAZE_PRESETS
    Haze/fog parameters of seed 000 Table 1 (errata 000.3), with the g each one assumes.
turbidity_haze
    A :class:`HazePreset` whose zenith extinction gives the turbidity ``T = (τ_m + τ_h)/τ_m``
    at 550 nm with this model's optical lengths (8.4 km air, 1.25 km haze).
HOFFMAN_PREETHAM_WAVELENGTHS, hoffman_preetham_air_scattering
    The R, G, B sample wavelengths of seed 000 (650, 570, 475 nm) and air's Rayleigh
    coefficients there (seed 000: 6.95e-6, 1.18e-5, 2.44e-5 m⁻¹, errata 000.4; or real air).
hoffman_preetham_extinction
    ``F_ex(s_air, s_haze) = e^{−(β_exAir s_air + β_exHaze s_haze)}`` (Eq. 3 and its two-length form).
hoffman_preetham_inscattering
    In-scattered radiance (Eq. 4; two-shell form of errata 000.6 for ``s_air ≠ s_haze``).
hoffman_preetham_sunlight
    ``E_sun`` after extinction along the Iqbal optical lengths (8.4 km air, 1.25 km haze).
hoffman_preetham_sky
    The two-shell sky on a sky mesh sized by the air optical length (seed 000 "Sky Color").
aerial_perspective
    ``F_ex L_0 + L_in`` (Eq. 1) for arrays such as a depth buffer.
solar_illuminance_rgb
    Default ``E_sun⁰``: the ASTM G-173 extraterrestrial spectrum as linear RGB [lx].

Model (seed 000)
----------------
Constant-density medium of air (Rayleigh, no absorption) and haze (Henyey–Greenstein with
asymmetry g > 0 = forward, errata 000.2; optional absorption), single scattering of sunlight
only::

    F_ex = e^{−β_ex s}                                                     (Eq. 3)
    L_in(s, θ) = E_sun β_sc(θ)/β_ex (1 − e^{−β_ex s})                      (Eq. 4)
    β_sc(θ) = β_scAir f_R(θ) + β_scHaze f_HG(θ, g),   β_ex = β_exAir + β_exHaze
    L = F_ex L_0 + L_in                                                    (Eq. 1)

θ is the angle between the view direction and the direction toward the sun. Each
``(1 − e^{−β s})/β`` is evaluated as :func:`path_integral` (``−expm1(−βs)/β``, limit ``s`` for
β = 0), so the model is exact and finite for β s from 0 through 1e-12 to 1e4 and beyond.

Limits (every 0·∞ and ∞/∞ case is the exact limit, never NaN): a zero extinction keeps
the object's radiance at any distance (``F_ex = 1``, ``L = L_0`` for ``s = inf``); a zero
scattering coefficient adds no light over any path (``L_in = 0``, also for ``s = inf``); over
an infinite path with β_ex > 0 the in-scattered light is the airlight ``E β_sc(θ)/β_ex``,
formed as a ratio so that it stays finite for tiny (even subnormal) β; no sunlight
(``E_sun = 0``) gives ``L_in = 0``.  float32 inputs are computed in float64.

Units: ``E_sun`` is an irradiance-like quantity per channel (default: linear-RGB
illuminance [lx] of the extraterrestrial sun, so ``L_in`` is in cd m⁻², the units of
:func:`atmoscatter.preetham_sky_rgb`); coefficients in m⁻¹; distances in m.
"""

from __future__ import annotations

import math

import numpy as np

from .._validate import as_float_array, check_positive
from ..optical_length import relative_optical_length
from ..phase import henyey_greenstein_phase, rayleigh_phase
from ._aerial_medium import (
    AIR_ZENITH_OPTICAL_LENGTH,
    HAZE_PRESETS,
    HAZE_ZENITH_OPTICAL_LENGTH,
    HOFFMAN_PREETHAM_WAVELENGTHS,
    HazePreset,
    _coefficients,
    hoffman_preetham_air_scattering,
    hoffman_preetham_sunlight,
    solar_illuminance_rgb,
    turbidity_haze,
)
from ._preetham_eval import _sun, _views

#: Directions per chunk of the NumPy evaluation (bounded memory).
_CHUNK = 1 << 16

__all__ = [
    "HOFFMAN_PREETHAM_WAVELENGTHS",
    "AIR_ZENITH_OPTICAL_LENGTH",
    "HAZE_ZENITH_OPTICAL_LENGTH",
    "HazePreset",
    "HAZE_PRESETS",
    "turbidity_haze",
    "one_minus_exp_ratio",
    "path_integral",
    "hoffman_preetham_air_scattering",
    "solar_illuminance_rgb",
    "hoffman_preetham_extinction",
    "hoffman_preetham_inscattering",
    "hoffman_preetham_sunlight",
    "hoffman_preetham_sky",
    "aerial_perspective",
]


# ----------------------------------------------------------------------------------------------
# numerics
# ----------------------------------------------------------------------------------------------
def one_minus_exp_ratio(x):
    """``(1 − e^{−x})/x`` for ``x ≥ 0``, with the limit 1 at ``x = 0``.

    Evaluated as ``−expm1(−x)/x`` (relative error ~1 ulp for every x > 0: no cancellation
    as x → 0, no overflow as x → ∞, where it tends to ``1/x``).

    Parameters
    ----------
    x : array_like
        Optical thickness ``β s`` ≥ 0 (``inf`` gives 0). [1]

    Returns
    -------
    numpy.ndarray or float
        The ratio, in (0, 1]. NaN in gives NaN.
    """
    x = as_float_array(x, "x")
    with np.errstate(invalid="ignore"):
        if np.any(x < 0):
            raise ValueError(f"x must be >= 0, got {x[x < 0].ravel()[0] if x.ndim else x.item()!r}")
        safe = np.where(x > 0, x, 1.0)
        out = np.where(x > 0, -np.expm1(-safe) / safe, np.where(np.isnan(x), np.nan, 1.0))
    out = out.astype(x.dtype, copy=False)
    return out[()] if out.ndim == 0 else out


def path_integral(beta, s):
    """``∫₀^s e^{−β t} dt = (1 − e^{−β s})/β`` with its limits, broadcasting.

    ``−expm1(−β s)/β`` for β s > 0, and the limit ``s`` for β = 0 (or s = 0). Finite for
    ``s = inf`` and β > 0 (``1/β``). Inputs ≥ 0.

    Parameters
    ----------
    beta : array_like
        Extinction coefficient ≥ 0. [m⁻¹]
    s : array_like
        Path length ≥ 0 (may be ``inf``). [m]

    Returns
    -------
    numpy.ndarray
        The integral. [m]
    """
    beta = check_positive(beta, "beta", allow_zero=True, unit="m^-1")
    s = _nonneg(s, "s")
    return _path_integral(beta, s)


def _path_integral(beta, s):
    """:func:`path_integral` without input checks (β finite ≥ 0, s ≥ 0 or inf)."""
    with np.errstate(invalid="ignore", over="ignore"):
        x = beta * s
        ok = (x > 0) & np.isfinite(beta) & (beta > 0)
        out = np.where(ok, -np.expm1(-np.where(ok, x, 1.0)) / np.where(ok, beta, 1.0), s)
    # beta > 0 with s = 0: x = 0 -> s = 0 (the limit); beta = 0 with s = inf -> inf.
    return out


# ----------------------------------------------------------------------------------------------
# extinction and in-scattering
# ----------------------------------------------------------------------------------------------
def hoffman_preetham_extinction(s_air, s_haze, beta_ex_air, beta_ex_haze):
    """Extinction factor ``F_ex = e^{−(β_exAir s_air + β_exHaze s_haze)}`` (seed 000 Eq. 3).

    Parameters
    ----------
    s_air, s_haze : array_like
        Optical lengths (or distances in a constant-density medium) for air and haze ≥ 0;
        a trailing channel axis is added. [m]
    beta_ex_air, beta_ex_haze : array_like
        Extinction coefficients per channel (last axis). [m⁻¹]

    Returns
    -------
    numpy.ndarray
        ``F_ex`` in [0, 1], shape ``broadcast(s_air, s_haze).shape + (C,)``; exactly 1 at 0.
    """
    sa = _nonneg(s_air, "s_air")
    sh = _nonneg(s_haze, "s_haze")
    ba = check_positive(beta_ex_air, "beta_ex_air", allow_zero=True, unit="m^-1")
    bh = check_positive(beta_ex_haze, "beta_ex_haze", allow_zero=True, unit="m^-1")
    with np.errstate(invalid="ignore"):
        tau = _mul(ba, sa[..., None]) + _mul(bh, sh[..., None])
    return np.exp(-tau)


def _nonneg(a, name):
    """``a`` as a float array, rejecting negative values (``inf`` allowed; NaN propagates)."""
    arr = as_float_array(a, name)
    bad = ~(arr >= 0) & ~np.isnan(arr)
    if np.any(bad):
        raise ValueError(f"{name} must be in [0, inf] m, got {arr[bad].ravel()[0]!r}")
    return arr


def _mul(beta, s):
    """``β s`` with ``0 · inf = 0`` (a transparent constituent over an infinite path)."""
    with np.errstate(invalid="ignore"):
        return np.where(beta == 0, 0.0, beta * s)


def _phases(cos_theta, g):
    """Phase functions ``f_R(θ)`` and ``f_HG(θ, g)`` with a trailing channel axis. [sr⁻¹]"""
    mu = np.asarray(cos_theta)[..., None]
    return rayleigh_phase(mu), henyey_greenstein_phase(mu, g)


def _scatter_integral(pairs, beta, s):
    """``Σᵢ β_scᵢ fᵢ ∫₀^s e^{−β t} dt`` with the exact limits of every 0·∞ and ∞/∞ path.

    ``pairs`` are ``(β_scᵢ, fᵢ)`` (coefficient [m⁻¹] ≥ 0, phase function [sr⁻¹] ≥ 0),
    ``beta`` ≥ 0 finite, ``s`` ≥ 0 or ``inf``:

    - β > 0, s finite: ``(Σ β_scᵢ fᵢ)·(−expm1(−β s)/β)`` (:func:`path_integral`, ≤ ``s``:
      finite for every finite s, even for a subnormal β);
    - β > 0, s = ∞: the airlight ``Σ (β_scᵢ/β) fᵢ``, ratio first (a tiny β would overflow
      ``1/β`` and turn ``β_sc·(1/β)`` into inf, or inf·0 = NaN for β_sc = 0);
    - β = 0: ``(Σ β_scᵢ fᵢ)·s`` with ``0·∞ = 0`` (no scatterer over an infinite path adds
      nothing; a scatterer without extinction adds ``inf``, the exact limit).
    """
    terms = sum(b * f for b, f in pairs)
    with np.errstate(invalid="ignore", over="ignore", divide="ignore"):
        pos = beta > 0
        fin = np.isfinite(s)
        finite = terms * _path_integral(beta, np.where(fin, s, 0.0))
        safe_b = np.where(pos, beta, 1.0)
        airlight = sum((b / safe_b) * f for b, f in pairs)
        no_ext = np.where(terms == 0, 0.0, terms * s)
    return np.where(pos, np.where(fin, finite, airlight), no_ext)


def _times_sun(E, K):
    """``E_sun · K`` with ``0 · inf = 0`` (no sunlight, no in-scattering)."""
    with np.errstate(invalid="ignore"):
        return np.where(E == 0, 0.0, E * K)


def _two_shell(sa, sh, f_r, f_hg, b_sa, b_sh, ba, bh):
    """Two-shell in-scattering integral per unit E_sun (errata 000.6), general s_air, s_haze.

    The inner shell (length ``s1 = min(s_air, s_haze)``) holds both constituents; the outer
    one (``|s_air − s_haze|``) only the constituent with the longer optical length,
    attenuated by the inner shell.  Each shell is a :func:`_scatter_integral`, so zero
    coefficients, infinite lengths and tiny coefficients over infinite lengths give the
    exact limits (never NaN).
    """
    sa = sa[..., None]
    sh = sh[..., None]
    s1 = np.minimum(sa, sh)
    b_tot = ba + bh
    inner = _scatter_integral(((b_sa, f_r), (b_sh, f_hg)), b_tot, s1)
    with np.errstate(invalid="ignore"):
        # both infinite: no outer shell (inf − inf); else the (possibly infinite) excess
        outer_len = np.where(np.isinf(sa) & np.isinf(sh), 0.0, np.abs(sa - sh))
    air_out = _scatter_integral(((b_sa, f_r),), ba, outer_len)
    haze_out = _scatter_integral(((b_sh, f_hg),), bh, outer_len)
    outer = np.where(sa >= sh, air_out, haze_out)
    # the outer shell seen through the inner one, T = e^{−τ}: nothing gets through an
    # opaque inner shell (τ = inf) and a zero outer shell adds nothing; an infinite outer
    # shell (a scatterer without extinction over an infinite path) behind a finite τ stays
    # inf even where e^{−τ} underflows to 0
    tau = _mul(b_tot, s1)
    with np.errstate(invalid="ignore"):
        seen = np.where(np.isinf(outer), np.inf, outer * np.exp(-tau))
        seen = np.where((outer == 0) | np.isinf(tau), 0.0, seen)
    return inner + seen


def hoffman_preetham_inscattering(
    s_air,
    s_haze,
    cos_theta,
    sun_irradiance,
    beta_sc_air,
    beta_ex_air,
    beta_sc_haze,
    beta_ex_haze,
    g,
):
    r"""In-scattered radiance ``L_in`` of air + haze (seed 000 Eq. 4; errata 000.6).

    For ``s_air = s_haze = s`` (aerial perspective in a constant-density medium) this is Eq. 4
    with the two constituents summed:

    .. math:: L_\mathrm{in} = E_\mathrm{sun}\,(\beta_\mathrm{scAir}(\theta) +
              \beta_\mathrm{scHaze}(\theta))\,\frac{1 - e^{-\beta_\mathrm{ex} s}}{\beta_\mathrm{ex}}

    For ``s_air ≠ s_haze`` it is the two-shell form (errata 000.6): an inner shell of length
    ``min(s_air, s_haze)`` with both constituents and an outer shell with only the one whose
    optical length is longer, attenuated by the inner shell.

    Parameters
    ----------
    s_air, s_haze : array_like
        Optical lengths ≥ 0 (may be ``inf``), broadcasting. [m]
    cos_theta : array_like
        Cosine of the angle between view direction and direction toward the sun. [1]
    sun_irradiance : array_like
        ``E_sun`` per channel (last axis). [lx or the caller's unit]
    beta_sc_air, beta_ex_air, beta_sc_haze, beta_ex_haze : array_like
        Scattering and extinction coefficients per channel (last axis), ≥ 0. [m⁻¹]
    g : float
        Henyey–Greenstein asymmetry of haze, ``|g| < 1`` (g > 0 forward). [1]

    Returns
    -------
    numpy.ndarray
        ``L_in`` [E_sun units sr⁻¹, e.g. cd m⁻²], shape broadcast + (C,); float32 if all
        inputs are float32 (computed in float64).  Exactly 0 at zero length; for β_ex → 0
        the limit ``E_sun β_sc(θ) s``; for ``s = inf`` and β_ex > 0 the airlight
        ``E_sun β_sc(θ)/β_ex`` (finite for any β_ex > 0, subnormal included).

    Notes
    -----
    Exact limits instead of 0·∞ or ∞/∞: a constituent with zero coefficients adds neither
    light nor extinction whatever its length (``inf`` included); zero scattering over an
    infinite path gives 0; ``E_sun = 0`` gives 0; scattering without extinction
    (β_sc > 0 = β_ex, unphysical) over an infinite path gives ``inf``.
    """
    sa = _nonneg(s_air, "s_air")
    sh = _nonneg(s_haze, "s_haze")
    E = as_float_array(sun_irradiance, "sun_irradiance")
    b_sa = check_positive(beta_sc_air, "beta_sc_air", allow_zero=True, unit="m^-1")
    b_ea = check_positive(beta_ex_air, "beta_ex_air", allow_zero=True, unit="m^-1")
    b_sh = check_positive(beta_sc_haze, "beta_sc_haze", allow_zero=True, unit="m^-1")
    b_eh = check_positive(beta_ex_haze, "beta_ex_haze", allow_zero=True, unit="m^-1")
    mu = as_float_array(cos_theta, "cos_theta")
    out_dtype = np.result_type(sa, sh, E, mu, b_sa, b_ea, b_sh, b_eh, np.float32)
    f_r, f_hg = _phases(mu.astype(np.float64), g)
    f64 = [np.asarray(a, dtype=np.float64) for a in (sa, sh, b_sa, b_sh, b_ea, b_eh)]
    K = _two_shell(*f64[:2], f_r, f_hg, *f64[2:])
    out = _times_sun(E.astype(np.float64), K).astype(out_dtype, copy=False)
    return out[()] if out.ndim == 0 else out


# ----------------------------------------------------------------------------------------------
# sky and aerial perspective
# ----------------------------------------------------------------------------------------------
def _unit(v):
    with np.errstate(invalid="ignore", divide="ignore"):
        return v / np.sqrt(np.sum(v * v, axis=-1, keepdims=True))


def hoffman_preetham_sky(
    view_directions,
    sun_direction,
    *,
    haze="light_haze",
    sun_irradiance=None,
    air_scattering=None,
    g=None,
    air_zenith_length=AIR_ZENITH_OPTICAL_LENGTH,
    haze_zenith_length=HAZE_ZENITH_OPTICAL_LENGTH,
):
    """Two-shell sky radiance of seed 000 ("Sky Color"; errata 000.6).

    The sky mesh is sized by the air optical length in every direction,
    ``s_air = 8.4 km · m(θ_v)`` (seed 000 Eq. 5, ``m`` = Iqbal relative optical length), with
    ``s_haze = s_air · 1.25/8.4`` (the constant ratio of the seed); the radiance is
    ``L_in(s_air, s_haze, θ)`` with ``E_sun`` from :func:`hoffman_preetham_sunlight`. The
    starting colour is black (space), so no extinction factor is applied.

    Parameters
    ----------
    view_directions : array_like
        Directions (..., 3), x = east, y = north, z = up; views below the horizon use the
        horizon optical length (the Iqbal formula's value at 90°).
    sun_direction : array_like
        Direction toward the sun (3,); below the horizon the sky is black (E_sun = 0).
    haze : str or HazePreset or None
        A key of :data:`HAZE_PRESETS`, a :class:`HazePreset`, or None (pure air).
    sun_irradiance : array_like, optional
        ``E_sun⁰`` (R, G, B) outside the atmosphere; default :func:`solar_illuminance_rgb`.
    air_scattering : array_like, optional
        ``β_scAir`` (R, G, B); default seed 000's Rayleigh values. [m⁻¹]
    g : float, optional
        Override of the preset's haze asymmetry.
    air_zenith_length, haze_zenith_length : float
        Zenith optical lengths (8400 m, 1250 m). [m]

    Returns
    -------
    numpy.ndarray
        Sky radiance (..., 3) [cd m⁻² with the default ``E_sun⁰``].
    """
    v = _views(view_directions)
    sun = _sun(sun_direction)
    b_sa, b_ea, b_sh, b_eh, gg = _coefficients(haze, air_scattering, g=g)
    la = float(check_positive(air_zenith_length, "air_zenith_length", unit="m"))
    lh = float(check_positive(haze_zenith_length, "haze_zenith_length", allow_zero=True, unit="m"))
    ts = math.acos(min(max(sun[2], -1.0), 1.0))
    E = hoffman_preetham_sunlight(
        ts, b_ea, b_eh, sun_irradiance=sun_irradiance, air_zenith_length=la, haze_zenith_length=lh
    )
    flat = v.reshape(-1, 3)
    out = np.empty(flat.shape, dtype=v.dtype)
    for start in range(0, flat.shape[0], _CHUNK):  # bounded memory
        sl = slice(start, start + _CHUNK)
        vh = _unit(flat[sl].astype(np.float64))
        nan = np.isnan(vh).any(axis=-1)
        vz = np.where(nan, 1.0, vh[:, 2])
        theta_v = np.arccos(np.clip(vz, -1.0, 1.0))
        s_air = la * np.asarray(relative_optical_length(theta_v))
        s_haze = s_air * (lh / la)
        mu = np.where(nan, 0.0, np.clip(vh @ sun, -1.0, 1.0))
        f_r, f_hg = _phases(mu, gg)
        L = _times_sun(E, _two_shell(s_air, s_haze, f_r, f_hg, b_sa, b_sh, b_ea, b_eh))
        out[sl] = np.where(nan[:, None], np.nan, L)
    return out.reshape(v.shape)


_AP_OPTIONS = ("haze", "sun_irradiance", "sun_extinction", "air_scattering", "haze_scattering",
               "haze_absorption", "g")  # fmt: skip


def aerial_perspective(L0, distance, view_direction, sun_direction, **options):
    """Aerial perspective ``L = F_ex L_0 + L_in`` (seed 000 Eq. 1, 3, 4; seed 004).

    Constant-density air + haze along the view ray (``s_air = s_haze = distance``), sunlight
    in-scattered with the Rayleigh and Henyey–Greenstein phase functions.

    Parameters
    ----------
    L0 : array_like
        Radiance of the object, linear RGB, shape (..., 3) [cd m⁻² with the default E_sun⁰].
    distance : array_like
        Distance from the eye to the object, shape (...) broadcasting with ``L0[..., 0]``;
        ``>= 0`` (``inf`` allowed: pure in-scattering). [m]
    view_direction : array_like
        Direction from the eye toward the object, (..., 3) or (3,) (normalised internally).
    sun_direction : array_like
        Direction toward the sun, (3,), x = east, y = north, z = up.
    **options
        ``haze`` (preset name, :class:`HazePreset` or None; default ``"light_haze"``),
        ``sun_irradiance`` (E_sun⁰, R, G, B; default :func:`solar_illuminance_rgb`),
        ``sun_extinction`` (bool, default True: attenuate E_sun⁰ along the Iqbal optical
        lengths, :func:`hoffman_preetham_sunlight`; False: use ``sun_irradiance`` as E_sun),
        ``air_scattering``, ``haze_scattering``, ``haze_absorption`` (R, G, B [m⁻¹]) and
        ``g`` overriding the preset.

    Returns
    -------
    numpy.ndarray
        Radiance at the eye, shape (..., 3); exactly ``L0`` where ``distance == 0`` and,
        per channel, where the extinction coefficient is 0 (at any distance, ``inf``
        included).  For ``distance = inf`` and β_ex > 0 the airlight
        ``E_sun β_sc(θ)/β_ex`` (finite however small β_ex).  float32 ``L0`` gives float32.
        ``L0`` should be finite (an infinite ``L0`` at infinite distance is ∞·0 = NaN).
    """
    unknown = sorted(set(options) - set(_AP_OPTIONS))
    if unknown:
        raise TypeError(f"aerial_perspective got unknown option(s) {unknown}; valid: {sorted(_AP_OPTIONS)}")
    L0a = as_float_array(L0, "L0")
    if L0a.ndim == 0 or L0a.shape[-1] != 3:
        raise ValueError(f"L0 must have shape (..., 3) (linear RGB), got shape {L0a.shape}")
    d = _nonneg(distance, "distance")
    v = _views(view_direction)
    sun = _sun(sun_direction)
    b_sa, b_ea, b_sh, b_eh, gg = _coefficients(
        options.get("haze", "light_haze"),
        options.get("air_scattering"),
        options.get("haze_scattering"),
        options.get("haze_absorption"),
        options.get("g"),
    )
    if options.get("sun_extinction", True):
        ts = math.acos(min(max(sun[2], -1.0), 1.0))
        E = hoffman_preetham_sunlight(ts, b_ea, b_eh, sun_irradiance=options.get("sun_irradiance"))
    else:
        E = solar_illuminance_rgb() if options.get("sun_irradiance") is None else as_float_array(
            options["sun_irradiance"], "sun_irradiance"
        )
    b_ex = b_ea + b_eh
    shape = np.broadcast_shapes(L0a.shape[:-1], d.shape, v.shape[:-1])
    L0b = np.broadcast_to(L0a, shape + (3,))
    db = np.broadcast_to(d, shape)
    vb = np.broadcast_to(v, shape + (3,))
    out = np.empty(shape + (3,), dtype=np.float32 if L0a.dtype == np.float32 else np.float64)
    if len(shape) == 0:
        out[...] = _aerial_chunk(L0b, db, vb, sun, E, b_sa, b_sh, gg, b_ex)
        return out
    # bounded memory: evaluate slabs along the first axis (rows of a depth buffer)
    step = max(1, _CHUNK // max(1, math.prod(shape[1:])))
    for start in range(0, shape[0], step):
        sl = slice(start, start + step)
        out[sl] = _aerial_chunk(L0b[sl], db[sl], vb[sl], sun, E, b_sa, b_sh, gg, b_ex)
    return out


def _aerial_chunk(L0, d, v, sun, E, b_sa, b_sh, g, b_ex):
    """``F_ex L0 + L_in`` for one slab (float64 work arrays)."""
    vh = _unit(v.astype(np.float64))
    bad_dir = np.isnan(vh).any(axis=-1)  # NaN or zero-length view directions
    mu = np.where(bad_dir, 0.0, np.clip(vh @ sun, -1.0, 1.0))
    f_r, f_hg = _phases(mu, g)
    dd = d.astype(np.float64)[..., None]
    F = np.exp(-_mul(b_ex, dd))  # 0·inf = 0: a transparent medium keeps L0 at any distance
    Lin = _times_sun(E, _scatter_integral(((b_sa, f_r), (b_sh, f_hg)), b_ex, dd))
    out = F * L0 + Lin
    if np.any(bad_dir):
        out = np.where(bad_dir[..., None], np.nan, out)
    return np.where((d == 0)[..., None], L0, out)  # exactly L0 at distance 0

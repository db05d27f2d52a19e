r"""Perez all-weather sky luminance model driven by measured irradiance.

Public objects
--------------
perez_sky_clearness, perez_sky_brightness, perez_epsilon_bin
    Sky clearness ε and brightness Δ from direct-normal and diffuse-horizontal irradiance
    (Perez et al. 1990, Eqs. 1–2) and the ε bin (1–8) they select.
precipitable_water_from_dew_point
    ``W = exp(0.07 T_d − 0.075)`` [cm] (Perez et al. 1990, Eq. 3).
perez_diffuse_luminous_efficacy
    ``K_d = a + b W + c cos Z + d ln Δ`` [lm W⁻¹] (Perez et al. 1990, Eq. 7, Table 4).
perez_all_weather_coefficients
    The distribution coefficients ``a … e`` (Perez, Seals & Michalsky 1993, Table 1).
perez_all_weather_relative_luminance
    ``lv(Z, γ) = [1 + a e^{b/cos Z}][1 + c e^{dγ} + e cos²γ]`` (unnormalised).
perez_all_weather_conditions, PerezAllWeatherConditions
    Everything above for one or many (sun, DNI, DHI) inputs, and the absolute scale: the
    factor that makes ``∫ L cos Z dΩ`` equal the diffuse horizontal illuminance.
perez_all_weather_luminance, perez_all_weather_sky
    Absolute sky luminance [cd m⁻²] for (Z, γ) arrays or for view directions.
PerezRangeWarning
    Issued when ε or Δ lie outside the range of the tables and are clamped.

The chain
---------
1. ε = [(D + I)/D + κ Z³] / (1 + κ Z³), κ = 1.041 rad⁻³ (Z in radians; D the diffuse
   horizontal, I the direct normal irradiance), and Δ = m D / I₀ with the relative air mass m
   of Kasten & Young (1989) (:func:`atmoscatter.relative_optical_length`) and the
   extraterrestrial normal irradiance I₀ (default 1367 W m⁻²; the scene adapter scales it by
   1/r² for the Earth–Sun distance r of the date).
2. The bin of ε (edges 1.065, 1.23, 1.5, 1.95, 2.8, 4.5, 6.2) selects the rows of Table 1:
   ``x = x1 + x2 Z + Δ (x3 + x4 Z)`` for x ∈ {a, b, c, d, e}, except in bin 1 where
   ``c = exp[(Δ (c1 + c2 Z))^{c3}] − c4`` and ``d = −exp[Δ (d1 + d2 Z)] + d3 + Δ d4``.
3. The diffuse horizontal illuminance is ``D_v = D K_d`` with the diffuse luminous efficacy
   of Perez et al. (1990), which needs the precipitable water W (from the dew point, or
   W = 2 cm when none is given — the default of Radiance's gendaylit; gendaymtx's default dew
   point of 11 °C gives 2.004 cm).
4. ``L(Z, γ) = D_v lv(Z, γ) / ∫ lv cos Z dΩ``, the integral by the quadrature of
   :mod:`atmoscatter.sky._hemisphere` with extra panel edges at Z = 80° and at the cos Z floor
   (relative error < 1e-8 where lv > 0 over the whole sky; < 1e-3 where the floor at 0
   below cuts the sky, e.g. bins 4 and 8 at Δ ≥ 0.45; both tested).

Failure modes and how they are handled (as published implementations do)
-------------------------------------------------------------------------
* **ε, Δ outside the tables.** ε is clamped to [1, 12] and Δ to [0.01, 0.6] (the ranges
  gendaylit accepts, Wienold's range limits), with a :class:`PerezRangeWarning` that counts the
  clamped values — never NaN. The clamped values drive both the coefficients and the
  efficacy (``ln Δ`` would diverge as Δ → 0).
* **Low Δ in bins 2–5.** For 1.065 < ε < 2.8, Δ < 0.2 is raised to 0.2 for the coefficients
  (the correction applied by gendaylit and gendaymtx, which avoids their worst
  negative-luminance and horizon-brightening regions); ``low_delta_correction=False`` uses the
  paper's formulas unchanged. The efficacy keeps the (clamped) measured Δ.
* **Negative luminance.** Some (ε, Δ, Z) give ``1 + c e^{dγ} + e cos²γ < 0`` or
  ``1 + a e^{b/cos Z} < 0`` over part of the sky; the relative luminance is floored at 0 there
  (gendaymtx sets negative patch luminances to 0; gendaylit leaves them negative).
* **Horizon brightening without bound.** Where b > 0 the gradation ``e^{b/cos Z}`` diverges at
  the horizon; as in Radiance's ``perezlum.cal``, cos Z is floored at 0.01 (Z ≤ 89.43°) in the
  gradation term, for every b.
* **Low sun.** Defined for the sun on or above the horizon (Z ∈ [0, π/2]); the Kasten–Young
  air mass is finite there (37.9 at 90°). No altitude cap (gendaylit lowers a sun above 87° to
  87°; this model is smooth at the zenith).
* **No sky light.** A diffuse irradiance of 0 gives a black sky (luminance 0, ε = ∞, no
  warning). A sun below the horizon with diffuse light > 0 raises ValueError (the model has no
  twilight sky); with D = 0 it gives 0.

References
----------
R. Perez, R. Seals & J. Michalsky (1993), "All-weather model for sky luminance distribution —
preliminary configuration and validation", *Solar Energy* 50(3), 235–245; erratum *Solar
Energy* 51(5), 423. R. Perez, P. Ineichen, R. Seals, J. Michalsky & R. Stewart (1990),
"Modeling daylight availability and irradiance components from direct and global
irradiance", *Solar Energy* 44(5), 271–289. F. Kasten & A. T. Young (1989), "Revised optical
air mass tables and approximation formula", *Applied Optics* 28(22), 4735–4738. Radiance
``gendaylit`` (J.-J. Delaunay 1994, J. Wienold) and ``gendaymtx`` (I. Ashdown, G. Ward 2013),
NREL/Radiance ``src/gen``, for the published handling of the failure modes above.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass

import numpy as np

from .._validate import as_float_array, check_finite, check_positive
from . import _hemisphere
from ._preetham_eval import _sun, _views

__all__ = [
    "PEREZ_EPSILON_BIN_EDGES",
    "PEREZ_EPSILON_RANGE",
    "PEREZ_DELTA_RANGE",
    "DEFAULT_PRECIPITABLE_WATER",
    "PEREZ_SOLAR_CONSTANT",
    "PerezRangeWarning",
    "PerezAllWeatherConditions",
    "perez_sky_clearness",
    "perez_sky_brightness",
    "perez_epsilon_bin",
    "precipitable_water_from_dew_point",
    "perez_diffuse_luminous_efficacy",
    "perez_all_weather_coefficients",
    "perez_all_weather_relative_luminance",
    "perez_all_weather_conditions",
    "perez_all_weather_luminance",
    "perez_all_weather_sky",
]


from ._perez_conditions import (  # noqa: F401  (public names re-exported here)
    _COS_Z_FLOOR,
    _LOW_DELTA_FLOOR,
    _Z_BREAKS,
    DEFAULT_PRECIPITABLE_WATER,
    PEREZ_DELTA_RANGE,
    PEREZ_EPSILON_BIN_EDGES,
    PEREZ_EPSILON_RANGE,
    PEREZ_SOLAR_CONSTANT,
    PerezRangeWarning,
    _clamp,
    _luminance_table,
    _zenith,
    perez_diffuse_luminous_efficacy,
    perez_epsilon_bin,
    perez_sky_brightness,
    perez_sky_clearness,
    precipitable_water_from_dew_point,
)


def perez_all_weather_coefficients(sun_zenith, epsilon, delta, *, low_delta_correction=True):
    """Distribution coefficients ``a, b, c, d, e`` (Perez, Seals & Michalsky 1993, Table 1).

    Parameters
    ----------
    sun_zenith : array_like
        Solar zenith angle Z in [0, π/2]. [rad]
    epsilon, delta : array_like
        Sky clearness and brightness [1]; clamped to :data:`PEREZ_EPSILON_RANGE` and
        :data:`PEREZ_DELTA_RANGE` with a :class:`PerezRangeWarning`. All inputs broadcast.
    low_delta_correction : bool, optional
        Raise Δ < 0.2 to 0.2 for 1.065 < ε < 2.8 (gendaylit/gendaymtx; default True).

    Returns
    -------
    tuple of 5 numpy.ndarray or float
        ``a, b, c, d, e`` [1] (``d`` per radian) of the model's bin of ε: ``x = x1 + x2 Z +
        Δ (x3 + x4 Z)``; in bin 1, ``c = exp[(Δ (c1 + c2 Z))^{c3}] − c4`` and
        ``d = −exp[Δ (d1 + d2 Z)] + d3 + Δ d4``.
    """
    z = _zenith(sun_zenith)
    eps, dlt = _clamp(as_float_array(epsilon, "epsilon"), as_float_array(delta, "delta"))
    z, eps, dlt = np.broadcast_arrays(z, eps, dlt)
    if low_delta_correction:
        dlt = np.where((eps > 1.065) & (eps < 2.8), np.maximum(dlt, _LOW_DELTA_FLOOR), dlt)
    bins = np.asarray(perez_epsilon_bin(eps))
    x = _luminance_table()[bins - 1]  # (..., 5, 4)
    zz, dd = z[..., None], dlt[..., None]
    lin = x[..., 0] + x[..., 1] * zz + dd * (x[..., 2] + x[..., 3] * zz)  # (..., 5)
    first = bins == 1
    xc, xd = x[..., 2, :], x[..., 3, :]
    with np.errstate(invalid="ignore", over="ignore"):  # the other bins' rows are discarded
        c1 = np.exp((dlt * (xc[..., 0] + xc[..., 1] * z)) ** xc[..., 2]) - xc[..., 3]
        d1 = -np.exp(dlt * (xd[..., 0] + xd[..., 1] * z)) + xd[..., 2] + dlt * xd[..., 3]
    c = np.where(first, c1, lin[..., 2])
    d = np.where(first, d1, lin[..., 3])
    out = (lin[..., 0], lin[..., 1], c, d, lin[..., 4])
    if z.ndim == 0:
        return tuple(float(v) for v in out)
    return out


def _lv(cos_z, cos_g, gamma, a, b, c, d, e):
    """Unnormalised relative luminance, floored at 0 (no checks)."""
    mu = np.maximum(cos_z, _COS_Z_FLOOR)
    grad = 1.0 + a * np.exp(b / mu)
    ind = 1.0 + c * np.exp(d * gamma) + e * cos_g * cos_g
    return np.maximum(grad * ind, 0.0)


def _lv_quadrature(cos_z, cos_g, gamma, sun_zenith, a, b, c, d, e):
    return _lv(cos_z, cos_g, gamma, a, b, c, d, e)


def perez_all_weather_relative_luminance(view_zenith, gamma, a, b, c, d, e):
    r"""Unnormalised Perez all-weather luminance ``lv(Z, γ)`` (Perez et al. 1993, Eq. 1).

    .. math:: l_v = \left[1 + a\,e^{b/\cos Z}\right]\left[1 + c\,e^{d\gamma} + e\cos^2\gamma\right]

    Parameters
    ----------
    view_zenith : array_like
        Zenith angle Z of the view direction; cos Z is floored at 0.01 (Z ≥ 89.43° and below
        the horizon take the value at 89.43°, as Radiance's ``perezlum.cal``). [rad]
    gamma : array_like
        Angle γ between the view direction and the sun. [rad]
    a, b, c, d, e : array_like
        Coefficients (:func:`perez_all_weather_coefficients`). All inputs broadcast. [1]

    Returns
    -------
    numpy.ndarray or float
        lv [1], floored at 0 (where the fitted function is negative).
    """
    z = as_float_array(view_zenith, "view_zenith")
    g = as_float_array(gamma, "gamma")
    a, b, c, d, e = (as_float_array(v, n) for v, n in zip((a, b, c, d, e), "abcde", strict=True))
    with np.errstate(over="ignore"):
        out = _lv(np.cos(z), np.cos(g), g, a, b, c, d, e)
    return out[()] if out.ndim == 0 else out


@dataclass(frozen=True)
class PerezAllWeatherConditions:
    """One or many Perez all-weather skies: the inputs and every derived quantity.

    Each field is a float or an array of the broadcast input shape.

    Attributes
    ----------
    sun_zenith : solar zenith angle [rad].
    epsilon, delta : sky clearness and brightness as computed from the inputs [1] (ε = inf
        where the diffuse irradiance is 0).
    epsilon_used, delta_used : the values clamped to the tables' range [1].
    epsilon_bin : ε bin 1–8.
    coefficients : tuple ``(a, b, c, d, e)`` of the distribution [1].
    precipitable_water : W [cm].
    diffuse_luminous_efficacy : K_d [lm W⁻¹].
    diffuse_horizontal_illuminance : D_v = D K_d [lx].
    horizontal_integral : ``∫ lv cos Z dΩ`` [sr].
    scale : ``D_v / ∫ lv cos Z dΩ`` [cd m⁻²]: luminance = scale × lv (0 for a black sky).
    zenith_luminance : scale × lv(0, Z_s) [cd m⁻²].
    """

    sun_zenith: np.ndarray | float
    epsilon: np.ndarray | float
    delta: np.ndarray | float
    epsilon_used: np.ndarray | float
    delta_used: np.ndarray | float
    epsilon_bin: np.ndarray | int
    coefficients: tuple
    precipitable_water: np.ndarray | float
    diffuse_luminous_efficacy: np.ndarray | float
    diffuse_horizontal_illuminance: np.ndarray | float
    horizontal_integral: np.ndarray | float
    scale: np.ndarray | float
    zenith_luminance: np.ndarray | float


def _scalar(x):
    x = np.asarray(x)
    return x[()] if x.ndim == 0 else x


def perez_all_weather_conditions(sun_zenith, direct_normal_irradiance,
                                 diffuse_horizontal_irradiance, *, dew_point=None,
                                 extraterrestrial_normal_irradiance=PEREZ_SOLAR_CONSTANT,
                                 low_delta_correction=True):
    """ε, Δ, coefficients, efficacy and absolute scale of Perez all-weather skies.

    Parameters
    ----------
    sun_zenith : array_like
        Solar zenith angle in [0, π]; above π/2 only with zero diffuse irradiance. [rad]
    direct_normal_irradiance : array_like
        Direct normal irradiance ≥ 0, at most ``extraterrestrial_normal_irradiance``. [W m⁻²]
    diffuse_horizontal_irradiance : array_like
        Diffuse horizontal irradiance ≥ 0. [W m⁻²]
    dew_point : array_like, optional
        Surface dew point [°C] for the precipitable water; None → W = 2 cm.
    extraterrestrial_normal_irradiance : array_like, optional
        I₀ [W m⁻²] (default 1367, the solar constant at 1 AU).
    low_delta_correction : bool, optional
        See :func:`perez_all_weather_coefficients`.

    Returns
    -------
    PerezAllWeatherConditions
        All inputs broadcast; the fields have the broadcast shape.

    Raises
    ------
    ValueError
        Negative or non-finite irradiance, direct irradiance above I₀, a sun below the horizon
        with diffuse irradiance > 0, a dew point outside [−100, 60] °C.
    """
    zs = check_finite(sun_zenith, "sun_zenith")
    dni = check_positive(direct_normal_irradiance, "direct_normal_irradiance", allow_zero=True,
                         unit="W m^-2")
    dhi = check_positive(diffuse_horizontal_irradiance, "diffuse_horizontal_irradiance",
                         allow_zero=True, unit="W m^-2")
    i0 = check_positive(extraterrestrial_normal_irradiance, "extraterrestrial_normal_irradiance",
                        unit="W m^-2")
    zs, dni, dhi, i0 = np.broadcast_arrays(zs, dni, dhi, i0)
    if np.any((zs < 0) | (zs > np.pi)):
        v = zs[(zs < 0) | (zs > np.pi)].ravel()[0]
        raise ValueError(f"sun_zenith must be in [0, pi] rad, got {v!r}")
    night = (zs > np.pi / 2) & (dhi > 0)
    if np.any(night):
        v = zs[night].ravel()[0]
        raise ValueError(f"sun_zenith must be in [0, pi/2] rad when diffuse_horizontal_irradiance "
                         f"> 0 (the Perez all-weather model has no sky for a sun below the "
                         f"horizon), got {v!r}")
    if np.any(dni > i0):
        v = dni[dni > i0].ravel()[0]
        raise ValueError(f"direct_normal_irradiance must be in [0, extraterrestrial_normal_"
                         f"irradiance] W m^-2, got {v!r}")
    if dew_point is None:
        w = np.full(zs.shape, DEFAULT_PRECIPITABLE_WATER)
    else:
        w = np.broadcast_to(precipitable_water_from_dew_point(dew_point), zs.shape)
    lit = dhi > 0
    zc = np.minimum(zs, np.pi / 2)
    eps = np.asarray(perez_sky_clearness(dni, dhi, zc))
    dlt = np.asarray(perez_sky_brightness(dhi, zc, extraterrestrial_normal_irradiance=i0))
    # the black sky (D = 0) takes valid placeholders: no warning, scale 0
    eps_in = np.where(lit, eps, 1.0)
    dlt_in = np.where(lit, dlt, PEREZ_DELTA_RANGE[0])
    eps_u, dlt_u = _clamp(eps_in, dlt_in)
    coef = perez_all_weather_coefficients(zc, eps_u, dlt_u, low_delta_correction=low_delta_correction)
    coef = tuple(np.broadcast_to(np.asarray(c, dtype=float), zs.shape) for c in coef)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", PerezRangeWarning)  # already clamped and reported
        kd = np.asarray(perez_diffuse_luminous_efficacy(eps_u, dlt_u, zc, precipitable_water=w))
    dv = dhi * kd
    with np.errstate(over="ignore"):
        integ = _hemisphere.horizontal_integral(
            _lv_quadrature, zc.ravel(), tuple(c.ravel() for c in coef),
            z_breaks=_Z_BREAKS).reshape(zs.shape)
        with np.errstate(divide="ignore", invalid="ignore"):
            scale = np.where(lit & (integ > 0), dv / integ, 0.0)
        lz = scale * _lv(np.ones(zs.shape), np.cos(zc), zc, *coef)
    return PerezAllWeatherConditions(
        sun_zenith=_scalar(zs), epsilon=_scalar(eps), delta=_scalar(dlt),
        epsilon_used=_scalar(eps_u), delta_used=_scalar(dlt_u),
        epsilon_bin=perez_epsilon_bin(eps_u), coefficients=tuple(_scalar(c) for c in coef),
        precipitable_water=_scalar(w), diffuse_luminous_efficacy=_scalar(kd),
        diffuse_horizontal_illuminance=_scalar(dv), horizontal_integral=_scalar(integ),
        scale=_scalar(scale), zenith_luminance=_scalar(lz))


def perez_all_weather_luminance(view_zenith, gamma, sun_zenith, direct_normal_irradiance,
                                diffuse_horizontal_irradiance, *, dew_point=None,
                                extraterrestrial_normal_irradiance=PEREZ_SOLAR_CONSTANT,
                                low_delta_correction=True):
    """Absolute luminance of the Perez all-weather sky [cd m⁻²].

    ``L(Z, γ) = D_v lv(Z, γ) / ∫ lv cos Z dΩ`` (see the module docstring for the chain and
    the handling of its failure modes).

    Parameters
    ----------
    view_zenith, gamma : array_like
        Zenith angle of the view direction and its angle to the sun. [rad]
    sun_zenith, direct_normal_irradiance, diffuse_horizontal_irradiance, dew_point, \
extraterrestrial_normal_irradiance, low_delta_correction
        As in :func:`perez_all_weather_conditions`; every sky parameter broadcasts against the
        view angles.

    Returns
    -------
    numpy.ndarray or float
        Luminance [cd m⁻²], ≥ 0; its horizontal integral equals the model's diffuse
        horizontal illuminance to < 1e-8 relative (< 1e-3 where the floor at 0 applies).
    """
    z = as_float_array(view_zenith, "view_zenith")
    g = as_float_array(gamma, "gamma")
    cond = perez_all_weather_conditions(
        sun_zenith, direct_normal_irradiance, diffuse_horizontal_irradiance, dew_point=dew_point,
        extraterrestrial_normal_irradiance=extraterrestrial_normal_irradiance,
        low_delta_correction=low_delta_correction)
    with np.errstate(over="ignore", invalid="ignore"):
        out = np.asarray(cond.scale) * _lv(np.cos(z), np.cos(g), g, *cond.coefficients)
    out = np.where(np.asarray(cond.scale) > 0, out, 0.0) if out.ndim else out
    return out[()] if np.ndim(out) == 0 else out


def perez_all_weather_sky(view_directions, sun_direction, direct_normal_irradiance,
                          diffuse_horizontal_irradiance, *, dew_point=None,
                          extraterrestrial_normal_irradiance=PEREZ_SOLAR_CONSTANT,
                          low_delta_correction=True):
    """Perez all-weather luminance for view directions (..., 3) [cd m⁻²].

    Same model as :func:`perez_all_weather_luminance`; frame x = east, y = north, z = up; γ is
    computed as ``2 atan2(|v̂ − ŝ|, |v̂ + ŝ|)``.

    Parameters
    ----------
    view_directions : array_like
        View directions, shape (..., 3); normalised internally; NaN gives NaN.
    sun_direction : array_like
        Direction toward the sun, shape (3,).
    direct_normal_irradiance, diffuse_horizontal_irradiance : float
        [W m⁻²].
    dew_point, extraterrestrial_normal_irradiance, low_delta_correction
        As in :func:`perez_all_weather_conditions`.

    Returns
    -------
    numpy.ndarray
        Luminance [cd m⁻²], shape ``view_directions.shape[:-1]``; float32 in → float32 out.
    """
    v = _views(view_directions)
    sun = _sun(sun_direction)
    zs = math.acos(max(-1.0, min(1.0, float(sun[2]))))
    cond = perez_all_weather_conditions(
        zs, direct_normal_irradiance, diffuse_horizontal_irradiance, dew_point=dew_point,
        extraterrestrial_normal_irradiance=extraterrestrial_normal_irradiance,
        low_delta_correction=low_delta_correction)
    vh, gamma = _hemisphere.unit_views_and_sun_angle(v, sun)
    scale = float(cond.scale)
    with np.errstate(over="ignore", invalid="ignore"):
        out = scale * _lv(vh[..., 2], np.cos(gamma), gamma, *(float(c) for c in cond.coefficients))
    if scale == 0.0:
        out = np.where(np.isnan(vh[..., 0]), np.nan, 0.0)
    out = np.where(np.isnan(vh[..., 0]), np.nan, out)
    return np.asarray(out, dtype=v.dtype)

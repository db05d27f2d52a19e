"""Sky condition of the Perez all-weather model from measured irradiance: sky clearness ε
and brightness Δ (Perez et al. 1990, Eqs. 1–2, Kasten & Young 1989 air mass), their bins,
precipitable water from the dew point, the clamping of ε and Δ to the model's range, and the
Perez et al. (1990) luminous efficacy of diffuse light (Table 4).  The public names are
re-exported by :mod:`atmoscatter.sky.perez_all_weather`, where the sky itself lives.
"""

from __future__ import annotations

import csv
import math
import warnings
from functools import lru_cache
from importlib import resources

import numpy as np

from .._validate import as_float_array, check_finite, check_positive

__all__: list[str] = []

#: Lower edges of the sky-clearness bins 1–8 (Perez et al. 1990 Table 1; bin 8 is open above).
PEREZ_EPSILON_BIN_EDGES: tuple[float, ...] = (1.0, 1.065, 1.23, 1.5, 1.95, 2.8, 4.5, 6.2)
#: ε range the model is evaluated in; values outside are clamped with a warning (gendaylit).
PEREZ_EPSILON_RANGE: tuple[float, float] = (1.0, 12.0)
#: Δ range the model is evaluated in; values outside are clamped with a warning (gendaylit).
PEREZ_DELTA_RANGE: tuple[float, float] = (0.01, 0.6)
#: Δ floor applied to the coefficients for 1.065 < ε < 2.8 (gendaylit, gendaymtx).
_LOW_DELTA_FLOOR = 0.2
#: Precipitable water [cm] used when no dew point is given (gendaylit's default).
DEFAULT_PRECIPITABLE_WATER: float = 2.0
#: Extraterrestrial normal irradiance at 1 AU used by default [W m⁻²] (Perez et al. 1990;
#: gendaylit, gendaymtx).
PEREZ_SOLAR_CONSTANT: float = 1367.0
#: κ of the sky clearness [rad⁻³] (Perez et al. 1990, Eq. 1).
_KAPPA = 1.041
#: Floor of cos Z in the gradation term (Radiance perezlum.cal).
_COS_Z_FLOOR = 0.01
#: Quadrature panel edges: the kink of the cos Z floor, and 80° where a gradation with b > 0
#: starts to rise steeply.
_Z_BREAKS = (math.radians(80.0), math.acos(_COS_Z_FLOOR))



class PerezRangeWarning(UserWarning):
    """ε or Δ outside the range of the Perez tables: clamped to the nearest valid value."""


def _read_csv(name):
    path = resources.files("atmoscatter") / "data" / name
    with path.open("r", encoding="utf-8") as fh:
        rows = [r for r in csv.reader(line for line in fh if not line.startswith("#"))]
    return np.array([[float(x) for x in r[3:]] for r in rows])


@lru_cache(maxsize=1)
def _luminance_table() -> np.ndarray:
    """(8, 5, 4): bin × (a, b, c, d, e) × (x1, x2, x3, x4) of Perez et al. (1993), Table 1."""
    return _read_csv("perez_all_weather.csv").reshape(8, 5, 4)


@lru_cache(maxsize=1)
def _efficacy_table() -> np.ndarray:
    """(8, 4): bin × (a, b, c, d) of the diffuse efficacy, Perez et al. (1990), Table 4."""
    return _read_csv("perez_luminous_efficacy.csv")


def _zenith(sun_zenith, name="sun_zenith"):
    z = check_finite(sun_zenith, name)
    bad = (z < 0) | (z > np.pi / 2)
    if np.any(bad):
        v = z[bad].ravel()[0] if z.ndim else z.item()
        raise ValueError(f"{name} must be in [0, pi/2] rad (sun on or above the horizon), got {v!r}")
    return z


def perez_sky_clearness(direct_normal_irradiance, diffuse_horizontal_irradiance, sun_zenith):
    r"""Perez sky clearness ε (Perez et al. 1990, Eq. 1).

    .. math:: \varepsilon = \frac{(D + I)/D + \kappa Z^3}{1 + \kappa Z^3}, \quad \kappa = 1.041

    Parameters
    ----------
    direct_normal_irradiance : array_like
        Direct normal irradiance I ≥ 0. [W m⁻²]
    diffuse_horizontal_irradiance : array_like
        Diffuse horizontal irradiance D ≥ 0. [W m⁻²]
    sun_zenith : array_like
        Solar zenith angle Z in [0, π/2]. [rad]

    Returns
    -------
    numpy.ndarray or float
        ε [1], ≥ 1; ``inf`` where D = 0 (no diffuse light: the limit for I > 0, and the
        convention for I = 0). Not clamped (see :func:`perez_all_weather_conditions`).
    """
    dni = check_positive(direct_normal_irradiance, "direct_normal_irradiance", allow_zero=True,
                         unit="W m^-2")
    dhi = check_positive(diffuse_horizontal_irradiance, "diffuse_horizontal_irradiance",
                         allow_zero=True, unit="W m^-2")
    z = _zenith(sun_zenith)
    k = _KAPPA * z**3
    with np.errstate(divide="ignore", invalid="ignore"):
        eps = ((dhi + dni) / dhi + k) / (1.0 + k)
    eps = np.where(dhi > 0, eps, np.inf)
    return eps[()] if eps.ndim == 0 else eps


def perez_sky_brightness(diffuse_horizontal_irradiance, sun_zenith, *,
                         extraterrestrial_normal_irradiance=PEREZ_SOLAR_CONSTANT):
    """Perez sky brightness ``Δ = m D / I₀`` (Perez et al. 1990, Eq. 2).

    Parameters
    ----------
    diffuse_horizontal_irradiance : array_like
        Diffuse horizontal irradiance D ≥ 0. [W m⁻²]
    sun_zenith : array_like
        Solar zenith angle in [0, π/2]; the relative air mass m is that of Kasten & Young
        (1989), 37.92 at the horizon. [rad]
    extraterrestrial_normal_irradiance : array_like, optional
        I₀ > 0 (default 1367 W m⁻², the solar constant at 1 AU). [W m⁻²]

    Returns
    -------
    numpy.ndarray or float
        Δ [1], ≥ 0. Not clamped.
    """
    from ..optical_length import relative_optical_length  # noqa: PLC0415  (physics layer)

    dhi = check_positive(diffuse_horizontal_irradiance, "diffuse_horizontal_irradiance",
                         allow_zero=True, unit="W m^-2")
    z = _zenith(sun_zenith)
    i0 = check_positive(extraterrestrial_normal_irradiance, "extraterrestrial_normal_irradiance",
                        unit="W m^-2")
    out = np.asarray(relative_optical_length(z, method="kasten_young") * dhi / i0)
    return out[()] if out.ndim == 0 else out


def perez_epsilon_bin(epsilon):
    """Sky-clearness bin 1–8 of ε (lower edge inclusive: ε = 1.065 is in bin 2).

    Parameters
    ----------
    epsilon : array_like
        Sky clearness ε; values below 1 fall in bin 1, ``inf`` in bin 8. [1]

    Returns
    -------
    numpy.ndarray or int
        Bin number(s) 1–8.

    Examples
    --------
    >>> [int(perez_epsilon_bin(e)) for e in (1.0, 1.0649, 1.065, 6.2, 20.0)]
    [1, 1, 2, 8, 8]
    """
    eps = as_float_array(epsilon, "epsilon")
    if np.any(np.isnan(eps)):
        raise ValueError("epsilon must not be NaN")
    out = np.clip(np.searchsorted(PEREZ_EPSILON_BIN_EDGES, eps, side="right"), 1, 8)
    return int(out) if out.ndim == 0 else out


def precipitable_water_from_dew_point(dew_point):
    """Atmospheric precipitable water ``W = exp(0.07 T_d − 0.075)`` (Perez et al. 1990, Eq. 3).

    Parameters
    ----------
    dew_point : array_like
        Surface dew point temperature T_d, in [−100, 60] °C. [°C]

    Returns
    -------
    numpy.ndarray or float
        W [cm] (2.0 cm at T_d ≈ 10.97 °C).
    """
    td = check_finite(dew_point, "dew_point")
    bad = (td < -100) | (td > 60)
    if np.any(bad):
        v = td[bad].ravel()[0] if td.ndim else td.item()
        raise ValueError(f"dew_point must be in [-100, 60] degC, got {v!r}")
    out = np.exp(0.07 * td - 0.075)
    return out[()] if out.ndim == 0 else out


def _clamp(epsilon, delta, *, warn=True):
    lo_e, hi_e = PEREZ_EPSILON_RANGE
    lo_d, hi_d = PEREZ_DELTA_RANGE
    bad_e = (epsilon < lo_e) | (epsilon > hi_e)
    bad_d = (delta < lo_d) | (delta > hi_d)
    if warn and (np.any(bad_e) or np.any(bad_d)):
        parts = []
        if np.any(bad_e):
            parts.append(f"{int(np.count_nonzero(bad_e))} epsilon value(s) outside "
                         f"[{lo_e}, {hi_e}] (e.g. {float(np.asarray(epsilon)[bad_e].ravel()[0]):.4g})")
        if np.any(bad_d):
            parts.append(f"{int(np.count_nonzero(bad_d))} delta value(s) outside "
                         f"[{lo_d}, {hi_d}] (e.g. {float(np.asarray(delta)[bad_d].ravel()[0]):.4g})")
        warnings.warn("Perez all-weather model: " + "; ".join(parts) + " clamped to the "
                      "range of the published tables", PerezRangeWarning, stacklevel=3)
    return np.clip(epsilon, lo_e, hi_e), np.clip(delta, lo_d, hi_d)


def perez_diffuse_luminous_efficacy(epsilon, delta, sun_zenith, *,
                                    precipitable_water=DEFAULT_PRECIPITABLE_WATER):
    r"""Luminous efficacy of the diffuse horizontal irradiance (Perez et al. 1990, Eq. 7).

    .. math:: K_d = a_i + b_i W + c_i \cos Z + d_i \ln\Delta \quad [\mathrm{lm\,W^{-1}}]

    with the coefficients of ε bin i (Table 4).

    Parameters
    ----------
    epsilon, delta : array_like
        Sky clearness and brightness [1]; clamped to :data:`PEREZ_EPSILON_RANGE` and
        :data:`PEREZ_DELTA_RANGE` with a :class:`PerezRangeWarning`.
    sun_zenith : array_like
        Solar zenith angle in [0, π/2]. [rad]
    precipitable_water : array_like, optional
        W ≥ 0 (:func:`precipitable_water_from_dew_point`; default 2 cm). [cm]

    Returns
    -------
    numpy.ndarray or float
        K_d [lm W⁻¹]. Validity: the fit's data span W ≈ 0.5–5 cm and the full ε, Δ range; the
        paper reports an RMS error of the fit of a few percent of the diffuse illuminance.
    """
    eps, dlt = _clamp(as_float_array(epsilon, "epsilon"), as_float_array(delta, "delta"))
    z = _zenith(sun_zenith)
    w = check_positive(precipitable_water, "precipitable_water", allow_zero=True, unit="cm")
    coef = _efficacy_table()[np.asarray(perez_epsilon_bin(eps)) - 1]
    out = coef[..., 0] + coef[..., 1] * w + coef[..., 2] * np.cos(z) + coef[..., 3] * np.log(dlt)
    out = np.asarray(out)
    return out[()] if out.ndim == 0 else out

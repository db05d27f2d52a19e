"""The public sun-position API: :func:`sun_position` and what the sky models consume.

- :func:`sun_position` checks its inputs, takes the time-only columns of the chosen method
  from :data:`SUN_POSITION_METHODS` (the SPA through :mod:`atmoscatter.sun.nodes`, the seed
  003 formula from :mod:`atmoscatter.sun.iqbal`) and the per-site geometry from
  :mod:`atmoscatter.sun.topocentric`, and returns a :class:`SunPosition`.
- :func:`earth_sun_distance`: the SPA radius vector (Reda & Andreas 2004 Eq. 11).
- :func:`sun_direction`, :class:`SkySun`, :func:`sky_sun` and
  :data:`TOTAL_SOLAR_IRRADIANCE`: the Sun as the sky models take it (unit vector,
  zenith/azimuth, extraterrestrial irradiance ``S₀/r²``).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from .._validate import as_float_array, check_option
from ._common import _CHUNK, _DEG, _checked, _out_dtype
from .iqbal import _iqbal_columns
from .nodes import _spa_columns
from .time import _as_datetime64, _check_years, _days_since_j2000
from .topocentric import _block, _blocks, _site_terms

__all__ = [
    "TOTAL_SOLAR_IRRADIANCE",
    "SUN_POSITION_METHODS",
    "SunPosition",
    "SkySun",
    "sun_position",
    "earth_sun_distance",
    "sun_direction",
    "sky_sun",
]

#: Total solar irradiance at 1 AU [W m⁻²] (Kopp & Lean 2011, GRL 38, L01706: 1360.8 ± 0.5).
TOTAL_SOLAR_IRRADIANCE: float = 1361.0


# ---------------------------------------------------------------------------------------------
# result types and registry
# ---------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class SunPosition:
    """Sun position at the requested times and sites (arrays broadcast to one shape).

    Attributes
    ----------
    zenith : ndarray
        Topocentric zenith angle [rad]: apparent (refracted) when ``refraction=True``, else
        true.
    azimuth : ndarray
        Azimuth [rad] in [0, 2π), from north toward east.
    apparent_zenith, true_zenith : ndarray
        Refracted and unrefracted topocentric zenith angles [rad] (equal when
        ``refraction=False``).
    elevation : ndarray
        ``π/2 − zenith`` [rad].
    direction : ndarray, shape (..., 3)
        Unit vector toward the Sun matching ``zenith``/``azimuth``, local frame x = east,
        y = north, z = up.
    declination : ndarray
        Geocentric apparent declination [rad] (time-only; a read-only broadcast view).
    equation_of_time : ndarray
        Apparent minus mean solar time [min] (time-only; a read-only broadcast view).
    earth_sun_distance : ndarray
        Earth–Sun distance [AU] (time-only; a read-only broadcast view).
    method : str
        The method used.
    """

    zenith: np.ndarray
    azimuth: np.ndarray
    apparent_zenith: np.ndarray
    true_zenith: np.ndarray
    elevation: np.ndarray
    direction: np.ndarray
    declination: np.ndarray
    equation_of_time: np.ndarray
    earth_sun_distance: np.ndarray
    method: str

    @property
    def irradiance_scale(self):
        """Extraterrestrial irradiance relative to its 1 AU value, ``1/r²`` [1]."""
        return 1.0 / np.square(self.earth_sun_distance)


def _columns_spa(d, t_us, dt_user):
    return _spa_columns(d, dt_user)


def _columns_iqbal(d, t_us, dt_user):
    return _iqbal_columns(d, t_us)


#: Registry of sun-position methods: name → (time-only columns function, parallax?, summary).
SUN_POSITION_METHODS: dict[str, tuple[Callable, bool, str]] = {
    "spa": (
        _columns_spa,
        True,
        "NREL SPA (Reda & Andreas 2004): ±0.0003° for −2000…6000; here ≤1e-5° (measured "
        "4e-6°) from a direct SPA evaluation (cubic interpolation of the time-only terms every "
        "2 days).",
    ),
    "iqbal": (
        _columns_iqbal,
        False,
        "Seed 003 / Preetham 1999 / Iqbal 1983 formula (errata 003.1): declination and "
        "equation of time from two-term fits; measured error vs SPA up to 0.84° (RMS 0.23°) "
        "in zenith for 2011 at |latitude| ≤ 60°.",
    ),
}


def sun_position(
    time,
    latitude,
    longitude,
    *,
    method: str = "spa",
    elevation=0.0,
    pressure=101325.0,
    temperature=12.0,
    refraction: bool = True,
    delta_t=None,
) -> SunPosition:
    """Topocentric position of the Sun, vectorised over times and sites.

    Parameters
    ----------
    time : datetime-like or array of them
        Instants.  ``numpy.datetime64`` (any unit) and ISO strings without offset are UTC;
        timezone-aware ``datetime``/pandas objects are converted to UTC; naive ``datetime`` and
        naive pandas objects raise ``ValueError``.  NaT elements of an array give NaN for that
        element only; a scalar NaT raises ``ValueError``.
    latitude : array_like
        Geodetic latitude [deg], [−90, 90], north positive.
    longitude : array_like
        Longitude [deg], [−360, 360], **east positive**.
    method : {"spa", "iqbal"}
        See :data:`SUN_POSITION_METHODS`.
    elevation : array_like
        Observer height above the ellipsoid [m] (parallax; SPA only), ≥ −1e4.
    pressure : array_like
        Local air pressure [Pa], ≥ 0, for the refraction correction (0 = no refraction).
    temperature : array_like
        Local air temperature [°C], > −273.15, for the refraction correction.
    refraction : bool
        Whether ``zenith``/``direction`` include atmospheric refraction.
    delta_t : array_like or None
        TT − UT [s], broadcastable to ``time``.  ``None`` uses :func:`default_delta_t` (Espenak & Meeus
        polynomials); with an explicit value the SPA terms are evaluated directly at every
        time (no interpolation), which is slower.

    Returns
    -------
    SunPosition
        Arrays of the broadcast shape of ``time``, ``latitude``, ``longitude``, ``elevation``,
        ``pressure``, ``temperature`` (floats for all-scalar input).  float32 when every float
        input is float32 (computed in float64).  NaN inputs (array elements) give NaN for that
        element only.

    Notes
    -----
    *SPA*: Reda & Andreas (2004), all equations; refraction by their Eq. 42 (applied while the
    true elevation is ≥ −0.8334°).  The time-only terms (Earth's heliocentric position, nutation,
    obliquity, aberration → apparent right ascension/declination, distance, equation of time)
    are computed once per time, shared across sites, and — for batches with many times per
    2-day interval — evaluated at nodes every 2 days and interpolated with a 4-point cubic;
    the added error is < 1e-5° (measured 3.9e-6°, see ``tests/test_sun.py``).  Validity: the SPA
    claims ±0.0003° for years −2000…6000 given the true ΔT; the default ΔT polynomial's error
    (≤ 5 s for 1900–2025) adds ≤ 6e-5° (see :func:`default_delta_t`).

    *iqbal*: seed 003 Sec. 3 with errata 003.1 (solar time with east-positive longitude):
    declination ``δ = 0.4093 sin(2π(J − 81)/368)``, solar time
    ``t = t_UTC + 0.170 sin(4π(J − 80)/373) − 0.129 sin(2π(J − 8)/355) + 12 L/π`` (SM = 0 for
    UTC input) and the printed zenith formula.  The azimuth is computed from the same δ and t by
    exact spherical trigonometry: the printed azimuth formula (errata 003.2) is not consistent
    with the printed zenith formula — its denominator has the wrong sign on ``cos l sin δ``, so it
    puts the noon Sun south of the zenith when δ > l — see docs/sun.md.  No parallax; the same
    refraction formula as SPA.  Kept for fidelity to the seeds; measured error: see
    :data:`SUN_POSITION_METHODS` and docs/sun.md.

    Examples
    --------
    >>> sp = sun_position(np.datetime64("2003-10-17T19:30:30"), 39.742476, -105.1786,
    ...                   elevation=1830.14, pressure=82000.0, temperature=11.0, delta_t=67.0)
    >>> round(float(np.rad2deg(sp.zenith)), 4), round(float(np.rad2deg(sp.azimuth)), 4)
    (50.1116, 194.3402)
    """
    check_option(method, "method", SUN_POSITION_METHODS)
    columns_fn, parallax, _ = SUN_POSITION_METHODS[method]
    t_us = _as_datetime64(time, "time")
    _check_years(t_us, "time")
    d = _days_since_j2000(t_us, "time")
    lat = _checked(latitude, "latitude", -90.0, 90.0, "deg")
    lon = _checked(longitude, "longitude", -360.0, 360.0, "deg")
    elev = _checked(elevation, "elevation", -1e4, 1e8, "m")
    pres = _checked(pressure, "pressure", 0.0, 1e7, "Pa")
    temp = _checked(temperature, "temperature", -273.0, 1e4, "degC")
    dt_user = None
    if delta_t is not None:
        dt_user = _checked(delta_t, "delta_t", -1e6, 1e6, "s")
        try:
            dt_user = np.broadcast_to(dt_user, d.shape)
        except ValueError as exc:
            raise ValueError(
                f"delta_t of shape {dt_user.shape} does not broadcast to time of shape {d.shape}"
            ) from exc
    out_dtype = _out_dtype(lat, lon)
    try:
        shape = np.broadcast_shapes(d.shape, lat.shape, lon.shape, elev.shape, pres.shape, temp.shape)
    except ValueError as exc:
        raise ValueError(
            "time, latitude, longitude, elevation, pressure and temperature do not broadcast: "
            f"shapes {d.shape}, {lat.shape}, {lon.shape}, {elev.shape}, {pres.shape}, {temp.shape}"
        ) from exc

    cols = columns_fn(d, t_us, dt_user)  # time-only, shape of `time`
    if parallax:
        sin_xi = np.sin((8.794 / 3600.0) * _DEG / cols["dist"])
    else:
        sin_xi = np.zeros(d.shape)
    sphi, cphi, xs, ys = _site_terms(lat.astype(np.float64), elev.astype(np.float64))
    if not parallax:
        xs, ys = cphi, sphi
    lon_rad = lon.astype(np.float64) * _DEG
    p_hpa = pres.astype(np.float64) / 100.0
    temp_c = temp.astype(np.float64)

    zen = np.empty(shape)
    tzen = np.empty(shape)
    azi = np.empty(shape)
    direc = np.empty((*shape, 3))
    ins = [d, cols["q"], cols["sin_dec"], sin_xi, lon_rad, sphi, cphi, xs, ys, p_hpa, temp_c]
    ins = [np.broadcast_to(a, shape) for a in ins]
    for idx in _blocks(shape, _CHUNK):
        zen[idx], tzen[idx], azi[idx], direc[idx] = _block(*(a[idx] for a in ins), refraction)

    def fin(a):
        a = a.astype(out_dtype, copy=False)
        return a[()] if a.ndim == 0 else a

    def tonly(a):
        a = np.broadcast_to(a.astype(out_dtype, copy=False), shape)
        return a[()] if a.ndim == 0 else a

    return SunPosition(
        zenith=fin(zen),
        azimuth=fin(azi),
        apparent_zenith=fin(zen),
        true_zenith=fin(tzen),
        elevation=fin(np.pi / 2 - zen),
        direction=direc.astype(out_dtype, copy=False),
        declination=tonly(cols["dec"]),
        equation_of_time=tonly(cols["eot"]),
        earth_sun_distance=tonly(cols["dist"]),
        method=method,
    )


def earth_sun_distance(time, *, delta_t=None):
    """Earth–Sun distance [AU] (SPA radius vector, Reda & Andreas 2004 Eq. 11).

    Parameters
    ----------
    time : datetime-like or array of them
        UTC instants (see :func:`sun_position`).
    delta_t : array_like or None
        TT − UT [s]; ``None`` uses :func:`default_delta_t`.

    Returns
    -------
    ndarray or float
        Distance [AU], between about 0.9833 (early January) and 1.0167 (early July); within
        1e-7 AU of a direct SPA evaluation (interpolation bound).  NaT elements give NaN.

    Examples
    --------
    >>> round(float(earth_sun_distance(np.datetime64("2024-07-05T05:00"))), 4)
    1.0167
    """
    d = _days_since_j2000(_as_datetime64(time, "time"), "time")
    dt_user = None if delta_t is None else _checked(delta_t, "delta_t", -1e6, 1e6, "s")
    out = _spa_columns(d, dt_user)["dist"]
    return out[()] if out.ndim == 0 else out


# ---------------------------------------------------------------------------------------------
# helpers for the sky models
# ---------------------------------------------------------------------------------------------
def sun_direction(zenith, azimuth):
    """Unit vector toward the Sun in the local frame (x = east, y = north, z = up).

    Parameters
    ----------
    zenith : array_like
        Zenith angle [rad].
    azimuth : array_like
        Azimuth [rad], from north toward east.

    Returns
    -------
    ndarray, shape (..., 3)
        ``(sin z sin a, sin z cos a, cos z)``; float32 if both inputs are float32.

    Examples
    --------
    >>> np.round(sun_direction(np.pi / 2, np.pi / 2), 12).tolist()
    [1.0, 0.0, 0.0]
    """
    z = as_float_array(zenith, "zenith")
    a = as_float_array(azimuth, "azimuth")
    sz = np.sin(z)
    return np.stack(np.broadcast_arrays(sz * np.sin(a), sz * np.cos(a), np.cos(z)), axis=-1)


@dataclass(frozen=True)
class SkySun:
    """What a sky model needs from the Sun.

    Attributes
    ----------
    direction : ndarray, shape (..., 3)
        Unit vector toward the Sun (x = east, y = north, z = up).
    zenith, azimuth : ndarray
        Zenith angle and azimuth (from north toward east) [rad].
    above_horizon : ndarray of bool
        ``zenith < π/2``.
    distance : ndarray
        Earth–Sun distance [AU].
    irradiance_scale : ndarray
        ``1/distance²``: multiply 1 AU extraterrestrial irradiance by this [1].
    irradiance : ndarray
        Total extraterrestrial irradiance normal to the beam [W m⁻²]
        (``solar_constant · irradiance_scale``).
    """

    direction: np.ndarray
    zenith: np.ndarray
    azimuth: np.ndarray
    above_horizon: np.ndarray
    distance: np.ndarray
    irradiance_scale: np.ndarray
    irradiance: np.ndarray


def sky_sun(position: SunPosition, *, solar_constant=TOTAL_SOLAR_IRRADIANCE) -> SkySun:
    """Turn a :class:`SunPosition` into the inputs of the sky models.

    Parameters
    ----------
    position : SunPosition
        Result of :func:`sun_position` (its ``zenith``/``direction`` are apparent when computed
        with ``refraction=True``, which is what an observer sees).
    solar_constant : float
        Total solar irradiance at 1 AU [W m⁻²], > 0; default :data:`TOTAL_SOLAR_IRRADIANCE`.

    Returns
    -------
    SkySun

    Examples
    --------
    >>> sp = sun_position(np.datetime64("2024-01-03T12:00"), 0.0, 0.0)
    >>> round(float(sky_sun(sp).irradiance), 1)
    1407.6
    """
    if not isinstance(position, SunPosition):
        raise TypeError(f"position must be a SunPosition, got {type(position).__name__}")
    s0 = _checked(solar_constant, "solar_constant", 0.0, np.inf, "W m-2")
    if np.any(s0 <= 0):
        raise ValueError(f"solar_constant must be > 0 W m-2, got {solar_constant!r}")
    scale = position.irradiance_scale
    with np.errstate(invalid="ignore"):
        above = np.asarray(position.zenith) < np.pi / 2
    return SkySun(
        direction=position.direction,
        zenith=position.zenith,
        azimuth=position.azimuth,
        above_horizon=above[()] if above.ndim == 0 else above,
        distance=position.earth_sun_distance,
        irradiance_scale=scale,
        irradiance=s0 * scale if np.ndim(scale) else float(s0 * scale),
    )

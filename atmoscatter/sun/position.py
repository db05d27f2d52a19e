"""Sun position, sunrise/sunset/solar noon and the solar geometry the sky models need.

Public objects
--------------
- :func:`sun_position`: topocentric zenith and azimuth (true and refracted), unit direction
  vector, declination, equation of time and Earth–Sun distance, vectorised over times and sites.
  ``method="spa"`` (default) is the NREL Solar Position Algorithm (Reda & Andreas 2004);
  ``method="iqbal"`` is the seed 003 / Preetham 1999 formula (errata 003.1–2).
- :data:`SUN_POSITION_METHODS`: registry of the methods above.
- :class:`SunPosition`: the result of :func:`sun_position`.
- :func:`sunrise_sunset`: sunrise, sunset and solar noon (UTC ``datetime64``) per local date,
  with flags for polar day and polar night.
- :class:`SunriseSunset`: the result of :func:`sunrise_sunset`.
- :func:`earth_sun_distance`: Earth–Sun distance [AU] at given times.
- :func:`default_delta_t`: the default TT − UT [s] (Espenak & Meeus polynomials).
- :func:`sun_direction`: zenith/azimuth → unit vector in the local frame (x east, y north, z up).
- :func:`sky_sun`: a :class:`SunPosition` → :class:`SkySun`, what sky models consume
  (direction, zenith, azimuth, extraterrestrial irradiance scale).
- :data:`HORIZON_APPARENT`, :data:`TOTAL_SOLAR_IRRADIANCE`.

Times
-----
``numpy.datetime64`` values (and ISO-8601 strings without offset) are **UTC**. Timezone-aware
:class:`datetime.datetime` objects and pandas ``Timestamp``/``DatetimeIndex``/``Series`` are
converted to UTC. *Naive* ``datetime``/pandas objects raise ``ValueError`` — a naive Python
datetime is most often local time, and silently reading it as UTC is a classic bug; pass
``np.datetime64`` (UTC) or attach a timezone.

References
----------
- I. Reda, A. Andreas (2004), "Solar position algorithm for solar radiation applications",
  Solar Energy 76, 577–589; NREL/TP-560-34302 (rev. 2008). Periodic terms: Tables A4.2–A4.3
  (shipped in :mod:`atmoscatter._spa_tables`); worked example: Table A5.1–2.
- F. Espenak, J. Meeus (2006), *Five Millennium Canon of Solar Eclipses*, NASA/TP-2006-214141,
  "Polynomial expressions for Delta T" (also eclipse.gsfc.nasa.gov/SEcat5/deltatpoly.html).
- M. Iqbal (1983), *An Introduction to Solar Radiation*, Academic Press (Eq. 1.2.1, Spencer's
  Earth–Sun distance series); A. J. Preetham, P. Shirley, B. Smits (1999), "A practical
  analytic model for daylight", SIGGRAPH, Appendix A.6; seed 003 (Kolivand & Sunar), Sec. 3.
- J. Meeus (1998), *Astronomical Algorithms*, 2nd ed., Ch. 15 (rising, transit, setting).
"""

from __future__ import annotations

import datetime as _dt
import functools
import re
import threading
from collections.abc import Callable
from dataclasses import dataclass
from importlib import resources

import numpy as np

from . import _spa_tables as _tab
from .._validate import as_float_array, check_option

__all__ = [
    "HORIZON_APPARENT",
    "TOTAL_SOLAR_IRRADIANCE",
    "SUN_POSITION_METHODS",
    "SunPosition",
    "SunriseSunset",
    "SkySun",
    "sun_position",
    "sunrise_sunset",
    "earth_sun_distance",
    "default_delta_t",
    "sun_direction",
    "sky_sun",
    "SPA_YEARS",
]

#: Standard altitude of the Sun's centre at apparent sunrise/sunset [rad]: −0.8333°
#: = −(34′ mean horizontal refraction + 16′ solar semi-diameter) (Meeus 1998, Ch. 15).
HORIZON_APPARENT: float = float(np.deg2rad(-50.0 / 60.0))

#: Total solar irradiance at 1 AU [W m⁻²] (Kopp & Lean 2011, GRL 38, L01706: 1360.8 ± 0.5).
TOTAL_SOLAR_IRRADIANCE: float = 1361.0

_TWO_PI = 2.0 * np.pi
_DEG = np.pi / 180.0
_J2000_US = np.datetime64("2000-01-01T12:00:00", "us").astype(np.int64)  # JD 2451545.0 (UT)
_US_PER_DAY = 86_400e6
#: Interpolation node spacing for the time-only SPA terms [days].  The cubic (4-point
#: Lagrange) interpolation error is below 1e-5° (measured 3.9e-6°; tested against direct
#: evaluation).
_NODE_STEP = 2.0
#: Elements per block in the per-sample part (keeps temporaries in cache, bounds memory).
_CHUNK = 1 << 15
#: Earth equatorial radius used by the SPA parallax terms [m]; flattening factor b/a.
_EARTH_RADIUS_SPA = 6378140.0
_B_OVER_A = 0.99664719
#: SPA refraction is applied while the true elevation is ≥ −(0.26667° + 0.5667°).
_REFRACTION_LIMIT_DEG = -(0.26667 + 0.5667)
#: Rise/set solve: stop when the bracket is below this [days] (1e-9 d = 86 µs) or after
#: this many regula-falsi (Illinois) steps.
_EVENT_TOL_DAYS = 1e-9
_EVENT_ITERATIONS = 80


# ---------------------------------------------------------------------------------------------
# input handling
# ---------------------------------------------------------------------------------------------
def _is_pandas(obj) -> bool:
    return type(obj).__module__.split(".")[0] == "pandas"


def _scalar_to_datetime64(value, name: str) -> np.datetime64:
    """One time-like scalar → ``datetime64[us]`` (UTC)."""
    if isinstance(value, np.datetime64):
        return value.astype("datetime64[us]")
    if _is_pandas(value):
        if value is not value or str(value) == "NaT":  # pandas.NaT
            return np.datetime64("NaT", "us")
        if getattr(value, "tzinfo", None) is None:
            raise ValueError(
                f"{name} must be timezone-aware or numpy datetime64 (UTC), got naive "
                f"{value!r}; use tz_localize(...) or pass np.datetime64 in UTC"
            )
        value = value.to_pydatetime()
    if isinstance(value, _dt.datetime):
        off = value.utcoffset()
        if off is None:
            raise ValueError(
                f"{name} must be timezone-aware or numpy datetime64 (UTC), got naive datetime "
                f"{value!r}; attach tzinfo (e.g. datetime.timezone.utc) or pass np.datetime64"
            )
        return np.datetime64(value.replace(tzinfo=None) - off, "us")
    if isinstance(value, _dt.date):
        return np.datetime64(value, "D").astype("datetime64[us]")
    if isinstance(value, str):
        try:
            return _parse_iso(value)
        except ValueError as exc:
            raise ValueError(f"{name}: cannot parse {value!r} as an ISO-8601 UTC time") from exc
    raise TypeError(
        f"{name} must be datetime64, datetime, pandas timestamps or ISO strings, "
        f"got {type(value).__name__} {value!r}"
    )


_TZ_SUFFIX = re.compile(r"T.*(?:[Zz]|[+-]\d\d(?::?\d\d)?)$")


def _parse_iso(text: str) -> np.datetime64:
    """One ISO-8601 string → ``datetime64[us]`` UTC.

    A trailing ``Z`` or ``±hh:mm`` offset is applied (converted to UTC) by the standard
    library; strings without one are read as UTC by NumPy.  (NumPy itself only warns about
    offsets and is deprecating them.)
    """
    if _TZ_SUFFIX.search(text):
        t = text[:-1] + "+00:00" if text[-1] in "Zz" else text
        d = _dt.datetime.fromisoformat(t)
        return np.datetime64(d.astimezone(_dt.timezone.utc).replace(tzinfo=None), "us")
    return np.datetime64(text).astype("datetime64[us]")


def _as_datetime64(time, name: str = "time") -> np.ndarray:
    """Convert ``time`` to a ``datetime64[us]`` array (UTC); see the module docstring."""
    if _is_pandas(time) and hasattr(time, "__len__"):
        import pandas as pd

        try:
            idx = pd.DatetimeIndex(time)
        except (TypeError, ValueError) as exc:
            raise TypeError(f"{name} must hold datetimes, got {type(time).__name__}") from exc
        if idx.tz is None:
            raise ValueError(
                f"{name} must be timezone-aware or numpy datetime64 (UTC), got a naive "
                f"{type(time).__name__}; use tz_localize(...) or pass datetime64 values in UTC"
            )
        vals = idx.tz_convert("UTC").tz_localize(None).values
        return vals.astype("datetime64[us]").reshape(np.shape(time))
    arr = np.asarray(time) if not isinstance(time, np.ndarray) else time
    kind = arr.dtype.kind
    if kind == "M":
        return arr.astype("datetime64[us]", copy=False)
    if kind in "US":
        try:
            if any(_TZ_SUFFIX.search(v) for v in arr.astype(str).ravel()):
                flat = [_parse_iso(v) for v in arr.astype(str).ravel()]
                return np.array(flat, dtype="datetime64[us]").reshape(arr.shape)
            return arr.astype("datetime64[us]")
        except ValueError as exc:
            raise ValueError(f"{name}: cannot parse {time!r} as ISO-8601 UTC times") from exc
    if kind == "O":
        if arr.ndim == 0:
            return np.asarray(_scalar_to_datetime64(arr.item(), name))
        flat = [_scalar_to_datetime64(v, name) for v in arr.ravel()]
        return np.array(flat, dtype="datetime64[us]").reshape(arr.shape)
    raise TypeError(
        f"{name} must be datetime64, datetime, pandas timestamps or ISO strings, "
        f"got dtype {arr.dtype}"
    )


#: Years (inclusive, proleptic Gregorian) for which the SPA (Reda & Andreas 2004) states
#: its accuracy; :func:`sun_position` refuses times outside them.
SPA_YEARS = (-2000, 6000)
_SPA_T0 = np.datetime64(f"{SPA_YEARS[0]}-01-01T00:00:00", "us")
_SPA_T1 = np.datetime64(f"{SPA_YEARS[1] + 1}-01-01T00:00:00", "us")


def _check_years(t_us: np.ndarray, name: str) -> None:
    """``ValueError`` if a (non-NaT) time lies outside :data:`SPA_YEARS`."""
    bad = ~np.isnat(t_us) & ((t_us < _SPA_T0) | (t_us >= _SPA_T1))
    if np.any(bad):
        raise ValueError(f"{name} must be within the years {SPA_YEARS[0]}..{SPA_YEARS[1]} "
                         f"(validity of the SPA), got {_describe_time(t_us, bad)}")


def _describe_time(t_us: np.ndarray, bad: np.ndarray) -> str:
    if t_us.ndim == 0:
        return np.datetime_as_string(t_us, unit="s")
    idx = tuple(int(i) for i in np.argwhere(bad)[0])
    return f"{np.datetime_as_string(t_us[idx], unit='s')} (at index {idx})"


def _days_since_j2000(t_us: np.ndarray, name: str) -> np.ndarray:
    """``datetime64[us]`` → float days since J2000.0 (2000-01-01 12:00 UT); NaT → NaN."""
    nat = np.isnat(t_us)
    if t_us.ndim == 0 and nat:
        raise ValueError(f"{name} must not be NaT")
    d = (t_us.view(np.int64) - _J2000_US) * (1.0 / _US_PER_DAY)
    if np.any(nat):
        d = np.where(nat, np.nan, d)
    return d


def _describe_first(arr: np.ndarray, bad: np.ndarray) -> str:
    if arr.ndim == 0:
        return repr(arr.item())
    idx = tuple(int(i) for i in np.argwhere(bad)[0])
    return f"{arr[idx].item()!r} (at index {idx})"


def _checked(value, name: str, low: float, high: float, unit: str) -> np.ndarray:
    """Float array in [low, high]; ±inf and a scalar NaN raise, NaN array elements pass."""
    arr = as_float_array(value, name)
    nan = np.isnan(arr)
    if arr.ndim == 0 and nan:
        raise ValueError(f"{name} must be finite, got nan")
    bad = np.isinf(arr)
    if np.any(bad):
        raise ValueError(f"{name} must be finite, got {_describe_first(arr, bad)}")
    with np.errstate(invalid="ignore"):
        bad = (arr < low) | (arr > high)
    if np.any(bad):
        raise ValueError(f"{name} must be in [{low}, {high}] {unit}, got {_describe_first(arr, bad)}")
    return arr


def _out_dtype(*arrays) -> type:
    """float32 if every float input is float32, else float64."""
    floats = [a.dtype for a in arrays if a.dtype.kind == "f"]
    return np.float32 if floats and all(dt == np.float32 for dt in floats) else np.float64


# ---------------------------------------------------------------------------------------------
# ΔT
# ---------------------------------------------------------------------------------------------
def _horner(x, coeffs):
    """Σ coeffs[i] x^i by Horner's rule (coefficients in increasing order)."""
    out = np.full_like(x, coeffs[-1])
    for c in coeffs[-2::-1]:
        out = out * x + c
    return out


#: Espenak & Meeus (2006) ΔT pieces: (start year, reference year, coefficients in t = y − ref).
_DELTA_T_PIECES = (
    (1800.0, 1800.0, (13.72, -0.332447, 0.0068612, 0.0041116, -0.00037436, 0.0000121272,
                      -0.0000001699, 0.000000000875)),
    (1860.0, 1860.0, (7.62, 0.5737, -0.251754, 0.01680668, -0.0004473624, 1.0 / 233174.0)),
    (1900.0, 1900.0, (-2.79, 1.494119, -0.0598939, 0.0061966, -0.000197)),
    (1920.0, 1920.0, (21.20, 0.84493, -0.076100, 0.0020936)),
    (1941.0, 1950.0, (29.07, 0.407, -1.0 / 233.0, 1.0 / 2547.0)),
    (1961.0, 1975.0, (45.45, 1.067, -1.0 / 260.0, -1.0 / 718.0)),
    (1986.0, 2000.0, (63.86, 0.3345, -0.060374, 0.0017275, 0.000651814, 0.00002373599)),
    (2005.0, 2000.0, (62.92, 0.32217, 0.005589)),
    (2050.0, None, None),  # −20 + 32 u² − 0.5628 (2150 − y)
    (2150.0, None, None),  # long-term parabola −20 + 32 u², u = (y − 1820)/100
)
_DELTA_T_EDGES = np.array([p[0] for p in _DELTA_T_PIECES])


def _delta_t_piece(k: int, y: np.ndarray) -> np.ndarray:
    u = (y - 1820.0) / 100.0
    if k == 0 or k == len(_DELTA_T_PIECES):  # before 1800 / from 2150: long-term parabola
        return -20.0 + 32.0 * u * u
    _, ref, coeffs = _DELTA_T_PIECES[k - 1]
    if coeffs is None:  # 2050–2150
        return -20.0 + 32.0 * u * u - 0.5628 * (2150.0 - y)
    return _horner(y - ref, coeffs)


def _delta_t_of_year(y: np.ndarray) -> np.ndarray:
    """Espenak & Meeus (2006) ΔT polynomials [s] for decimal year ``y`` (any year)."""
    y = np.asarray(y, dtype=np.float64)
    piece = np.searchsorted(_DELTA_T_EDGES, y, side="right")  # NaN → last piece (NaN out)
    present = np.unique(piece)
    if present.size == 1:
        return _delta_t_piece(int(present[0]), y)
    out = np.empty_like(y)
    for k in present:
        sel = piece == k
        out[sel] = _delta_t_piece(int(k), y[sel])
    return out


def default_delta_t(time):
    """Default ΔT = TT − UT [s] used by :func:`sun_position` when ``delta_t=None``.

    Parameters
    ----------
    time : datetime-like or array of them
        UTC times (see the module docstring for accepted types).

    Returns
    -------
    ndarray or float
        ΔT [s] from the Espenak & Meeus (2006) polynomials, evaluated at the decimal year
        ``2000 + (JD − 2451545)/365.25``.

    Notes
    -----
    The polynomials fit observed ΔT to about a second over 1900–2005.  Their 2005–2050 piece is
    an extrapolation published in 2006 that overestimates the observed ΔT (IERS) by about 2 s in
    2015 and 5 s in 2025.  ΔT only shifts the ephemeris time (Earth's rotation uses UT), so a
    ΔT error of 1 s moves the Sun by about 1.2e-5° (its orbital motion in 1 s; measured: 5 s →
    5.9e-5°).  Pass ``delta_t=`` explicitly (e.g. from IERS Bulletin A) for the best absolute
    accuracy.

    Examples
    --------
    >>> round(float(default_delta_t(np.datetime64("2000-01-01T12:00"))), 2)
    63.86
    """
    d = _days_since_j2000(_as_datetime64(time), "time")
    out = _delta_t_of_year(2000.0 + d / 365.25)
    return out[()] if out.ndim == 0 else out


# ---------------------------------------------------------------------------------------------
# SPA: time-only part (heliocentric → geocentric apparent sun)
# ---------------------------------------------------------------------------------------------
def _table(rows) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    a = np.asarray(rows, dtype=np.float64)
    return a[:, 0], a[:, 1], a[:, 2]


_L = [_table(getattr(_tab, f"L{i}")) for i in range(6)]
_B = [_table(getattr(_tab, f"B{i}")) for i in range(2)]
_R = [_table(getattr(_tab, f"R{i}")) for i in range(5)]
_NUT_ARGS_INT = np.asarray(_tab.NUTATION_ARGS, dtype=np.int64)
_NUT_COEFFS = np.asarray(_tab.NUTATION_COEFFS, dtype=np.float64)  # (63, 4) in 1e-4 arcsec
_NUT_PSI = np.ascontiguousarray(_NUT_COEFFS[:, :2].T)  # (2, 63): a, b
_NUT_EPS = np.ascontiguousarray(_NUT_COEFFS[:, 2:].T)  # (2, 63): c, d


def _earth_series(series, jme: np.ndarray) -> np.ndarray:
    """Σ_i JME^i Σ_k A cos(B + C·JME) (Reda & Andreas Eq. 9–10), divided by 1e8."""
    total = np.zeros_like(jme)
    for a, b, c in reversed(series):  # Horner in JME (x**p is slow for negative x)
        term = np.cos(b[:, None] + c[:, None] * jme[None, :])
        # einsum, not a BLAS gemv: gemv goes multithreaded at this size and stalls under load
        total = total * jme + np.einsum("k,kn->n", a, term)
    return total * 1e-8


#: Nodes per run for :func:`_earth_series_runs`.
_RUN = 32
_ROTATIONS: dict[tuple[int, float], list] = {}


def _earth_series_runs(series, jme: np.ndarray, step: float) -> np.ndarray:
    """:func:`_earth_series` for runs of ``_RUN`` nodes nominally ``step`` [millennia] apart.

    Within a run starting at JME₀, ``e^{i(B + C·JME_k)} = e^{i(B + C·JME₀)} · e^{iC·k·step} ·
    e^{iC·ε_k}`` with ``ε_k = JME_k − JME₀ − k·step`` (the change of ΔT along the run,
    |C·ε| < 1e-6, kept to first order: error < 1e-12).  The sum over terms then becomes a
    complex matrix product, so a run costs one cos/sin per term instead of ``_RUN``.
    """
    n_runs = jme.size // _RUN
    runs = jme.reshape(n_runs, _RUN)
    start = runs[:, 0]
    eps = runs - start[:, None] - np.arange(_RUN) * step
    key = (id(series), float(step))
    if key not in _ROTATIONS:
        k = np.arange(_RUN) * step
        _ROTATIONS[key] = [np.exp(1j * c[:, None] * k[None, :]) for _, _, c in series]
        if len(_ROTATIONS) > 8:  # pragma: no cover - only a few steps are ever used
            _ROTATIONS.pop(next(iter(_ROTATIONS)))
    rot = _ROTATIONS[key]
    total = np.zeros_like(runs)
    for power in range(len(series) - 1, -1, -1):  # Horner in JME (x**p is slow for x < 0)
        a, b, c = series[power]
        e0 = np.exp(1j * (b[:, None] + c[:, None] * start[None, :]))  # (terms, n_runs)
        s_cos = (a[:, None] * e0).T @ rot[power]  # Σ A e^{i·angle}: real part = Σ A cos
        s_sin = ((a * c)[:, None] * e0).T @ rot[power]  # imaginary part = Σ A C sin
        total = total * runs + (s_cos.real - eps * s_sin.imag)
    return total.ravel() * 1e-8


def _nutation_args(jce: np.ndarray) -> np.ndarray:
    """Fundamental arguments D, M, M′, F, Ω [deg] (Reda & Andreas Eq. 15–19), shape (5, n)."""
    return np.stack([_horner(jce, coeffs) for coeffs in _NUT_POLYS])


_NUT_POLYS = (
    (297.85036, 445267.111480, -0.0019142, 1.0 / 189474.0),
    (357.52772, 35999.050340, -0.0001603, -1.0 / 300000.0),
    (134.96298, 477198.867398, 0.0086972, 1.0 / 56250.0),
    (93.27191, 483202.017538, -0.0036825, 1.0 / 327270.0),
    (125.04452, -1934.136261, 0.0020708, 1.0 / 450000.0),
)

#: Linear rates of the fundamental arguments [deg per Julian century].
_NUT_RATES = np.array([445267.111480, 35999.050340, 477198.867398, 483202.017538, -1934.136261])


def _nutation(jce: np.ndarray):
    """Δψ, Δε [0.0001″] (Eq. 20–22) at every ``jce``.

    ``e^{i·arg_k} = Π_j (e^{i X_j})^{Y_kj}``: 5 sin/cos pairs and complex products instead of
    63 sin/cos pairs (same values to ~1e-15).
    """
    z = np.exp(1j * (_nutation_args(jce) * _DEG))  # (5, n)
    z2 = z * z
    zc = np.conj(z)
    powers = np.stack([np.conj(z2), zc, np.ones_like(z), z, z2, z2 * z])  # Y = −2 … 3
    rot = powers[_NUT_ARGS_INT[:, 0] + 2, 0]
    for j in range(1, 5):
        rot = rot * powers[_NUT_ARGS_INT[:, j] + 2, j]
    # real matrix products on the real/imaginary parts: a complex matrix-vector product with a
    # real vector goes through a multithreaded zgemv that stalls badly on a busy machine
    sums_psi = _NUT_PSI @ rot.imag  # (2, n): Σ a sin, Σ b sin
    sums_eps = _NUT_EPS @ rot.real  # (2, n): Σ c cos, Σ d cos
    return sums_psi[0] + jce * sums_psi[1], sums_eps[0] + jce * sums_eps[1]


_NUT_ROTATIONS: dict[float, np.ndarray] = {}


def _nutation_runs(jce: np.ndarray, step: float):
    """:func:`_nutation` for runs of ``_RUN`` times nominally ``step`` [centuries] apart.

    Each term's phase advances by its linear rate × ``step`` from one node to the next, so a run
    is its start phasors times a fixed rotation: one complex matrix product per block.  Left
    out: the quadratic/cubic parts of the arguments and the change of ΔT within a run (phase
    < 1e-5 rad, i.e. < 1e-6″ in Δψ/Δε; tested against :func:`_nutation`).
    """
    n_runs = jce.size // _RUN
    runs = jce.reshape(n_runs, _RUN)
    key = float(step)
    if key not in _NUT_ROTATIONS:
        rate = (_NUT_ARGS_INT @ _NUT_RATES) * _DEG  # (63,) [rad per century]
        _NUT_ROTATIONS.clear()
        _NUT_ROTATIONS[key] = np.exp(1j * rate[:, None] * (np.arange(_RUN) * step)[None, :])
    rot = _NUT_ROTATIONS[key]  # (63, RUN)
    start = np.exp(1j * ((_NUT_ARGS_INT @ _nutation_args(runs[:, 0])) * _DEG))  # (63, n_runs)
    # one product per coefficient column: (n_runs × 63)·(63 × RUN) stays below OpenBLAS's
    # threading threshold (a threaded zgemm stalls badly on a busy machine)
    sums = [(w[None, :] * start.T) @ rot for w in _NUT_COEFFS.T]  # 4 × (n_runs, RUN)
    dpsi = sums[0].imag + runs * sums[1].imag
    deps = sums[2].real + runs * sums[3].real
    return dpsi.ravel(), deps.ravel()


def _spa_time_terms(d: np.ndarray, dt_s: np.ndarray, *, run_step=None) -> dict[str, np.ndarray]:
    """Time-only SPA quantities for 1-D float ``d`` (days since J2000 UT, finite).

    Returns a dict of 1-D arrays: ``q`` [rad] such that the geocentric local hour angle is
    ``H = 2π·frac(d) + longitude − q``; ``dec`` (geocentric apparent declination) [rad],
    ``sin_dec``; ``dist`` [AU]; ``eot`` (equation of time) [min].  With ``run_step`` [days],
    ``d`` is made of runs of ``_RUN`` times that far apart (see :func:`_earth_series_runs`).
    """
    jc = d / 36525.0
    jde = d + dt_s / 86400.0
    jce = jde / 36525.0
    jme = jce / 10.0
    # heliocentric longitude, latitude, radius (Eq. 9–11) [rad, rad, AU]
    if run_step is None:
        lon_h = _earth_series(_L, jme)
        lat_h = _earth_series(_B, jme)
        radius = _earth_series(_R, jme)
    else:
        step = run_step / 365250.0
        lon_h = _earth_series_runs(_L, jme, step)
        lat_h = _earth_series_runs(_B, jme, step)
        radius = _earth_series_runs(_R, jme, step)
    # geocentric (Eq. 13–14)
    theta = lon_h + np.pi
    beta = -lat_h
    # nutation (Eq. 15–23)
    if run_step is None:
        dpsi, deps = _nutation(jce)
    else:
        dpsi, deps = _nutation_runs(jce, run_step / 36525.0)
    dpsi = dpsi * (_DEG / 36e6)  # 0.0001″ → rad
    deps = deps * (_DEG / 36e6)
    # obliquity (Eq. 24–25)
    u = jme / 10.0
    eps0 = _horner(
        u, (84381.448, -4680.93, -1.55, 1999.25, -51.38, -249.67, -39.05, 7.12, 27.87, 5.79, 2.45)
    )
    eps = eps0 * (_DEG / 3600.0) + deps
    # aberration and apparent longitude (Eq. 26–27)
    lam = theta + dpsi - (20.4898 / 3600.0) * _DEG / radius
    # geocentric right ascension and declination (Eq. 30–31)
    sl, ce, se = np.sin(lam), np.cos(eps), np.sin(eps)
    alpha = np.arctan2(sl * ce - np.tan(beta) * se, np.cos(lam))
    sin_dec = np.sin(beta) * ce + np.cos(beta) * se * sl
    dec = np.arcsin(sin_dec)
    # hour-angle offset: ν = 280.46061837 + 360.98564736629 d + 0.000387933 T² − T³/38710000
    # (+ Δψ cos ε); 360·d ≡ 360·frac(d), so H = 2π frac(d) + σ − q with the slow part q:
    gm_slow = 280.46061837 + 0.98564736629 * d + jc * jc * (0.000387933 - jc / 38710000.0)
    q = alpha - dpsi * ce - gm_slow * _DEG
    q = (q + np.pi) % _TWO_PI - np.pi
    # equation of time (Eq. A.1–A.2) [min]
    m = _horner(
        jme, (280.4664567, 360007.6982779, 0.03032028, 1 / 49931.0, -1 / 15300.0, -1 / 2.0e6)
    )
    e_deg = (m - 0.0057183 - alpha / _DEG + dpsi * ce / _DEG + 180.0) % 360.0 - 180.0
    return {"q": q, "dec": dec, "sin_dec": sin_dec, "dist": radius, "eot": 4.0 * e_deg}


_COLUMNS = ("q", "dec", "sin_dec", "dist", "eot")


def _spa_direct(d: np.ndarray, dt_s: np.ndarray) -> dict[str, np.ndarray]:
    """Full SPA time terms at every element (NaN-safe, any shape), in blocks."""
    shape = d.shape
    d = d.ravel()
    dt_s = np.broadcast_to(dt_s, shape).ravel()
    ok = np.isfinite(d) & np.isfinite(dt_s)
    out = {k: np.full(d.shape, np.nan) for k in _COLUMNS}
    idx = np.flatnonzero(ok)
    step = 512  # (terms × block) temporaries stay in cache
    for s in range(0, idx.size, step):
        sel = idx[s : s + step]
        res = _spa_time_terms(d[sel], dt_s[sel])
        for k in _COLUMNS:
            out[k][sel] = res[k]
    return {k: v.reshape(shape) for k, v in out.items()}


# Node values depend only on the node's time and ΔT, so runs of _RUN nodes are cached per
# process (bounded: _RUN_CACHE_MAX runs ≈ 5 MB): repeated calls over the same years — a batch
# of skies, a notebook — pay for the periodic terms once.
_RUN_CACHE: dict = {}
_RUN_CACHE_MAX = 4096
_RUN_CACHE_LOCK = threading.Lock()


@functools.lru_cache(maxsize=1)
def _node_table():
    """The shipped node table (default ΔT, 1900–2100): ``(first_run, runs)`` or None.

    ``atmoscatter/data/spa_nodes.npz`` holds exactly what :func:`_spa_time_terms` computes at
    the nodes (generated by ``scripts/make_spa_nodes.py``; a test recomputes a sample of runs
    and requires agreement to 1e-12).  A table made with another node spacing is ignored.
    """
    try:
        path = resources.files("atmoscatter") / "data" / "spa_nodes.npz"
        with np.load(str(path)) as z:
            if float(z["node_step"]) != _NODE_STEP or int(z["run"]) != _RUN or tuple(
                z["columns"].tolist()
            ) != _COLUMNS:
                return None
            return int(z["first_run"]), np.array(z["runs"])
    except (FileNotFoundError, OSError, KeyError):  # pragma: no cover - broken install
        return None


def _node_runs(run_ids: np.ndarray, dt_const, *, use_table: bool = True) -> np.ndarray:
    """Time terms at the nodes of runs ``run_ids`` (sorted, unique): (n_runs, _RUN, ncol).

    Taken from the shipped table (default ΔT, 1900–2100), then from the per-process cache,
    and computed otherwise.
    """
    key0 = None if dt_const is None else float(dt_const)
    out = np.empty((run_ids.size, _RUN, len(_COLUMNS)))
    table = _node_table() if (use_table and key0 is None) else None
    if table is not None:
        first, runs = table
        k = run_ids - first
        inside = (k >= 0) & (k < runs.shape[0])
        if inside.all():
            return runs[k]
        out[inside] = runs[k[inside]]
        cached = [out[i] if inside[i] else None for i in range(run_ids.size)]
        with _RUN_CACHE_LOCK:
            cached = [c if c is not None else _RUN_CACHE.get((key0, int(r)))
                      for c, r in zip(cached, run_ids, strict=True)]
    else:
        with _RUN_CACHE_LOCK:
            cached = [_RUN_CACHE.get((key0, int(r))) for r in run_ids]
    missing = np.array([i for i, c in enumerate(cached) if c is None], dtype=np.int64)
    for i, c in enumerate(cached):
        if c is not None:
            out[i] = c
    runs_per_block = 16  # keeps every complex matrix product single-threaded (see above)
    for s in range(0, missing.size, runs_per_block):
        sel = missing[s : s + runs_per_block]
        ids = (run_ids[sel][:, None] * _RUN + np.arange(_RUN)).ravel()
        dn = ids * _NODE_STEP
        dtn = _delta_t_of_year(2000.0 + dn / 365.25) if dt_const is None else np.full(
            dn.shape, float(dt_const)
        )
        vals = _spa_time_terms(dn.astype(np.float64), dtn, run_step=_NODE_STEP)
        block = np.stack([vals[name] for name in _COLUMNS], axis=-1).reshape(sel.size, _RUN, -1)
        out[sel] = block
    if missing.size:
        with _RUN_CACHE_LOCK:
            for i in missing:
                if len(_RUN_CACHE) >= _RUN_CACHE_MAX:
                    _RUN_CACHE.pop(next(iter(_RUN_CACHE)))
                _RUN_CACHE[(key0, int(run_ids[i]))] = out[i].copy()
    return out


def _spa_interpolated(d: np.ndarray, dt_const) -> dict[str, np.ndarray] | None:
    """Time terms by cubic interpolation between SPA nodes every ``_NODE_STEP`` days.

    Nodes sit at multiples of ``_NODE_STEP`` days from J2000 (so a result does not depend on
    the rest of the batch) and are evaluated only around the intervals that hold samples.
    ΔT at the nodes is ``dt_const`` [s] or, if None, :func:`_delta_t_of_year`.  Returns None
    when interpolation would not be cheaper than direct evaluation.
    """
    shape = d.shape
    flat = d.ravel()
    finite = np.isfinite(flat)
    n_finite = int(np.count_nonzero(finite))
    if n_finite < 64:
        return None
    fill = flat[finite][0]
    u = np.where(finite, flat, fill) / _NODE_STEP
    iv = np.floor(u)
    lo, hi = int(iv.min()), int(iv.max())
    span = hi - lo + 1
    table = _node_table() if dt_const is None else None
    # with the shipped nodes covering the batch, interpolation is always the cheaper path
    tabulated = table is not None and (lo - 1) // _RUN >= table[0] and (
        (hi + 2) // _RUN < table[0] + table[1].shape[0])
    if span > 4 * n_finite and not tabulated:
        return None
    iv = iv.astype(np.int64) - lo  # interval index, 0 … span-1
    occ = np.zeros(span, dtype=bool)
    occ[iv] = True
    need = np.zeros(span + 3, dtype=bool)  # node j ↔ node index lo − 1 + j
    for s in range(4):
        need[s : s + span] |= occ
    node_pos = np.flatnonzero(need)
    # evaluate whole runs of _RUN consecutive nodes (cheap per node, see _earth_series_runs)
    node_ids = node_pos + (lo - 1)
    run_ids = np.unique(node_ids // _RUN)
    if run_ids.size * _RUN > 2 * n_finite and not tabulated:
        return None
    runs = _node_runs(run_ids, dt_const)  # (n_runs, _RUN, ncol), from the cache when possible
    pos = np.searchsorted(run_ids, node_ids // _RUN)
    y = runs[pos, node_ids % _RUN]
    row = np.full(span + 3, -1, dtype=np.int64)
    row[node_pos] = np.arange(node_pos.size)
    occ_ids = np.flatnonzero(occ)
    ym, y0, y1, y2 = (y[row[occ_ids + s]] for s in range(4))
    # q is wrapped to (−π, π]: take the other three nodes relative to y0 (no jump inside)
    for yy in (ym, y1, y2):
        yy[:, 0] = y0[:, 0] + (yy[:, 0] - y0[:, 0] + np.pi) % _TWO_PI - np.pi
    # 4-point Lagrange cubic through f = −1, 0, 1, 2, written as y0 + f(c1 + f(c2 + f c3))
    c1 = -ym / 3.0 - y0 / 2.0 + y1 - y2 / 6.0
    c2 = ym / 2.0 - y0 + y1 / 2.0
    c3 = (y2 - ym) / 6.0 + (y0 - y1) / 2.0
    # layout (4, ncol, n_occupied): one np.take per block gathers every coefficient
    coef = np.ascontiguousarray(np.stack([y0, c1, c2, c3]).transpose(0, 2, 1))
    interval_row = np.zeros(span, dtype=np.int64)
    interval_row[occ_ids] = np.arange(occ_ids.size)
    out = np.empty((len(_COLUMNS), flat.size))
    for s in range(0, flat.size, _CHUNK):
        sl = slice(s, s + _CHUNK)
        c = np.take(coef, interval_row[iv[sl]], axis=2)  # (4, ncol, chunk)
        f = u[sl] - np.floor(u[sl])
        out[:, sl] = c[0] + f * (c[1] + f * (c[2] + f * c[3]))
    if n_finite < flat.size:
        out[:, ~finite] = np.nan
    return {k: out[j].reshape(shape) for j, k in enumerate(_COLUMNS)}


def _spa_columns(d: np.ndarray, dt_user, *, interpolate: bool = True) -> dict:
    """Time-only SPA columns at ``d``: interpolated between nodes when that is cheaper.

    ``dt_user`` is None (default ΔT), or an array broadcastable to ``d``; interpolation is
    used only when ΔT is the default or a single value.
    """
    res = None
    if interpolate:
        if dt_user is None:
            res = _spa_interpolated(d, None)
        elif np.ndim(dt_user) == 0 or np.all(dt_user == np.ravel(dt_user)[0]):
            res = _spa_interpolated(d, float(np.ravel(dt_user)[0]))
    if res is not None:
        return res
    dt_s = _delta_t_of_year(2000.0 + d / 365.25) if dt_user is None else dt_user
    return _spa_direct(d, dt_s)


# ---------------------------------------------------------------------------------------------
# Iqbal / Preetham (seed 003): time-only part
# ---------------------------------------------------------------------------------------------
def _day_of_year(t_us: np.ndarray) -> np.ndarray:
    """Day of year J = 1…366 (UTC) as float; NaT → NaN."""
    nat = np.isnat(t_us)
    days = t_us.astype("datetime64[D]")
    years = t_us.astype("datetime64[Y]").astype("datetime64[D]")
    j = (days - years).astype(np.float64) + 1.0
    return np.where(nat, np.nan, j)


def _iqbal_columns(d: np.ndarray, t_us: np.ndarray) -> dict[str, np.ndarray]:
    """Seed 003 Sec. 3 with errata 003.1 (SM = 0 because the input is UTC)."""
    j = _day_of_year(t_us)
    eot_h = 0.170 * np.sin(4.0 * np.pi * (j - 80.0) / 373.0) - 0.129 * np.sin(
        _TWO_PI * (j - 8.0) / 355.0
    )
    dec = 0.4093 * np.sin(_TWO_PI * (j - 81.0) / 368.0)
    # Spencer (1971) in Iqbal (1983) Eq. 1.2.1: E0 = (r0/r)², day angle Γ = 2π(J − 1)/365
    g = _TWO_PI * (j - 1.0) / 365.0
    e0 = (
        1.000110
        + 0.034221 * np.cos(g)
        + 0.001280 * np.sin(g)
        + 0.000719 * np.cos(2 * g)
        + 0.000077 * np.sin(2 * g)
    )
    # solar time t = UTC hours + EoT + 12 L/π  ⇒  hour angle H = π t/12 − π = 2π frac(d) + L − q
    return {
        "q": -eot_h * (np.pi / 12.0),
        "dec": dec,
        "sin_dec": np.sin(dec),
        "dist": 1.0 / np.sqrt(e0),
        "eot": 60.0 * eot_h,
    }


# ---------------------------------------------------------------------------------------------
# per-sample geometry (shared by the methods)
# ---------------------------------------------------------------------------------------------
def _refraction_deg(e0_deg, pressure_hpa, temperature_c):
    """SPA atmospheric refraction Δe [deg] (Reda & Andreas Eq. 42) for true elevation e0."""
    e = np.maximum(e0_deg, _REFRACTION_LIMIT_DEG)
    corr = (
        (pressure_hpa / 1010.0)
        * (283.0 / (273.0 + temperature_c))
        * 1.02
        / (60.0 * np.tan((e + 10.3 / (e + 5.11)) * _DEG))
    )
    return np.where(e0_deg >= _REFRACTION_LIMIT_DEG, corr, 0.0)


def _site_terms(lat_deg, elev_m):
    """Geodetic latitude → sin/cos and the SPA parallax terms x = ρ cos φ′, y = ρ sin φ′."""
    phi = lat_deg * _DEG
    sphi, cphi = np.sin(phi), np.cos(phi)
    u = np.arctan2(_B_OVER_A * sphi, cphi)
    h = elev_m / _EARTH_RADIUS_SPA
    return sphi, cphi, np.cos(u) + h * cphi, _B_OVER_A * np.sin(u) + h * sphi


def _block(d, q, sin_dec, sin_xi, lon_rad, sphi, cphi, xs, ys, p_hpa, temp_c, refraction):
    """Topocentric geometry for one block of broadcast arrays.

    The parallax is applied as a vector subtraction (equivalent to SPA Eq. 36–41): in the
    hour-angle frame the Sun's geocentric unit vector is (cos δ cos H, −cos δ sin H, sin δ)
    and the observer sits at sin ξ·(x, 0, y) in units of the Sun's distance.
    """
    h_ang = _TWO_PI * (d - np.floor(d)) + lon_rad - q
    cos_dec = np.sqrt(1.0 - sin_dec * sin_dec)
    vx = cos_dec * np.cos(h_ang) - xs * sin_xi
    east = -cos_dec * np.sin(h_ang)
    vz = sin_dec - ys * sin_xi
    north = cphi * vz - sphi * vx
    up = cphi * vx + sphi * vz
    horiz = np.sqrt(east * east + north * north)
    true_zen = np.arctan2(horiz, up)
    azimuth = np.arctan2(east, north) % _TWO_PI
    inv_norm = 1.0 / np.sqrt(horiz * horiz + up * up)
    if refraction:
        delta = _refraction_deg(90.0 - true_zen / _DEG, p_hpa, temp_c) * _DEG
        zen = true_zen - delta
        # rotate the true unit vector up by delta (series: |delta| < 0.011 rad, error < 1e-12)
        d2 = delta * delta
        cd = 1.0 - d2 * (0.5 - d2 / 24.0)
        sd = delta * (1.0 - d2 / 6.0)
        ce, se = horiz * inv_norm, up * inv_norm
        ca = ce * cd - se * sd
        k = ca / np.maximum(horiz, 1e-300)
        direction = np.stack([east * k, north * k, se * cd + ce * sd], axis=-1)
    else:
        zen = true_zen
        direction = np.stack([east * inv_norm, north * inv_norm, up * inv_norm], axis=-1)
    return zen, true_zen, azimuth, direction


def _blocks(shape: tuple[int, ...], chunk: int):
    """Index tuples covering ``shape`` in blocks of at most ``chunk`` elements (C order).

    Blocks are slices of the leading axis when a row fits, else single leading indices with
    the rest split recursively, so memory stays bounded whatever the shape.
    """
    if len(shape) == 0:
        yield ()
        return
    inner = int(np.prod(shape[1:], dtype=np.int64))
    if inner <= chunk:
        rows = max(1, chunk // max(inner, 1))
        for s in range(0, shape[0], rows):
            yield (slice(s, s + rows),)
        return
    if len(shape) == 1:  # pragma: no cover - inner == 1 always fits
        yield (slice(None),)
        return
    for i in range(shape[0]):
        for sub in _blocks(shape[1:], chunk):
            yield (i, *sub)


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
# sunrise / sunset / noon
# ---------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class SunriseSunset:
    """Sunrise, sunset and solar noon per (date, site).

    Attributes
    ----------
    sunrise, sunset : ndarray of datetime64[ms]
        UTC instants when the Sun's centre crosses the ``horizon`` altitude upward /
        downward during the solar day (the 24 h centred on ``noon``); NaT when it does not
        (polar day or night, and on the first/last day of a polar season, which has only
        one of the two events).
    noon : ndarray of datetime64[ms]
        UTC instant of the upper transit (solar noon); defined every day.
    polar_day, polar_night : ndarray of bool
        No horizon crossing in the solar day and the Sun above / below the ``horizon``
        altitude all of it.  A day with a sunrise or a sunset is never polar.
    day_length : ndarray of timedelta64[ms]
        Time the Sun spends above the ``horizon`` altitude during the solar day, from the
        events: ``sunset − sunrise``; ``noon + 12 h − sunrise`` on a day with a sunrise
        only, ``sunset − (noon − 12 h)`` on a day with a sunset only; 24 h on polar days,
        0 on polar nights.
    """

    sunrise: np.ndarray
    sunset: np.ndarray
    noon: np.ndarray
    polar_day: np.ndarray
    polar_night: np.ndarray
    day_length: np.ndarray


def _as_dates(dates, name: str) -> np.ndarray:
    """Calendar dates as ``datetime64[D]``: the *local* date of timezone-aware values.

    A date names a day, not an instant, so naive ``datetime``/pandas values are accepted here,
    and an aware value (e.g. local midnight) keeps its own calendar date instead of the UTC one.
    """
    if _is_pandas(dates) and hasattr(dates, "__len__"):
        import pandas as pd

        try:
            idx = pd.DatetimeIndex(dates)
        except (TypeError, ValueError) as exc:
            raise TypeError(f"{name} must hold dates, got {type(dates).__name__}") from exc
        if idx.tz is not None:
            idx = idx.tz_localize(None)
        return idx.values.astype("datetime64[D]").reshape(np.shape(dates))

    def one(v):
        if _is_pandas(v) and str(v) != "NaT":
            v = v.to_pydatetime()
        if isinstance(v, _dt.datetime):
            return np.datetime64(v.date(), "D")
        return _scalar_to_datetime64(v, name).astype("datetime64[D]")

    arr = dates if isinstance(dates, np.ndarray) else np.asarray(dates)
    if arr.dtype.kind == "O":
        if arr.ndim == 0:
            return np.asarray(one(arr.item()))
        return np.array([one(v) for v in arr.ravel()], dtype="datetime64[D]").reshape(arr.shape)
    return _as_datetime64(arr, name).astype("datetime64[D]")


def _hour_angle(d, lon_rad, q):
    """Geocentric local hour angle wrapped to [−π, π)."""
    h = _TWO_PI * (d - np.floor(d)) + lon_rad - q
    return (h + np.pi) % _TWO_PI - np.pi


def _days_to_datetime64(d: np.ndarray) -> np.ndarray:
    ok = np.isfinite(d)
    ms = np.asarray(np.round(np.where(ok, d, 0.0) * 86_400e3)).astype(np.int64)
    out = (ms + _J2000_US // 1000).astype("datetime64[ms]")
    return np.where(ok, out, np.datetime64("NaT", "ms"))


def sunrise_sunset(dates, latitude, longitude, *, horizon=HORIZON_APPARENT, delta_t=None):
    """Sunrise, sunset and solar noon for local dates at sites (NREL SPA ephemeris).

    Parameters
    ----------
    dates : datetime64[D]-like or array
        Local calendar dates (``datetime64``, ``datetime.date``, ISO strings, pandas).  The
        events returned are those of the solar day centred on the local *mean* noon of that
        date, i.e. on ``date 12:00 UTC − longitude/15 h``; for civil time zones within an hour
        or so of mean solar time this is the civil date.  Values with a time of day are
        truncated to their date — for timezone-aware ``datetime``/pandas values, their own
        (local) calendar date; naive values are accepted here since a date is not an instant.
    latitude : array_like
        Geodetic latitude [deg], [−90, 90].
    longitude : array_like
        Longitude [deg], [−360, 360], east positive.
    horizon : array_like
        Altitude of the Sun's centre at rise/set [rad]; default :data:`HORIZON_APPARENT`
        (−0.8333°: standard refraction plus semi-diameter).  Use e.g. ``np.deg2rad(-6)`` for
        civil twilight.  In [−π/2, π/2].
    delta_t : array_like or None
        TT − UT [s]; ``None`` uses :func:`default_delta_t`.

    Returns
    -------
    SunriseSunset
        Arrays of the broadcast shape of the inputs (``sunrise``, ``sunset``, ``noon`` as
        ``datetime64[ms]`` UTC).  Polar day/night give NaT with the matching flag set; the
        first and last day of a polar season have one event and neither flag; NaT dates or
        NaN coordinates give NaT and both flags False.

    Notes
    -----
    Transit: iterate ``t ← t − H(t)/2π`` on the geocentric hour angle (3 steps, < 0.1 s).
    Solar day: ``[noon − 12 h, noon + 12 h]``.  On each half the hour angle runs from about
    −π to 0 (then 0 to π), so the altitude ``sin a = sin φ sin δ + cos φ cos δ cos H`` is
    monotone there and each half holds at most one crossing of the horizon ``h₀``: a sign
    change of ``sin a − sin h₀`` between the half's ends.  It is solved by Newton steps kept
    inside that bracket (bisection when a step leaves it), starting from the hour-angle
    formula ``cos H₀ = (sin h₀ − sin φ sin δ)/(cos φ cos δ)`` at noon (Meeus 1998 Ch. 15),
    with δ and H from the SPA at every step, to 1e-9 d (0.1 ms).  An upward crossing is
    the sunrise, a downward one the sunset; the flags and ``day_length`` follow from the
    events alone, so they always agree with the times (a day with a sunset is not polar
    day).  Parallax and the observer's height are neglected as in SPA A.2 (effect < 2 s at
    low latitude).  Accuracy: a few seconds against the SPA geometry, plus the real-world
    uncertainty of refraction at the horizon (minutes).

    Limits of the semantics: a dip of the Sun's centre below (or rise above) the horizon
    within about a minute of the window edge, where the altitude is at its daily minimum
    (its depth is then < 1e-4°), can be missed or attributed to the neighbouring day; within
    ~0.06° of a pole, where the daily altitude swing is smaller than the declination's
    drift, more than two crossings a day can occur around the equinoxes and only one of
    each kind is reported.

    Examples
    --------
    >>> r = sunrise_sunset(np.datetime64("2011-06-15"), 1.28, 103.45)
    >>> str(r.sunrise + np.timedelta64(8, "h"))[:16], str(r.sunset + np.timedelta64(8, "h"))[:16]
    ('2011-06-15T07:00', '2011-06-15T19:12')
    """
    days = _as_dates(dates, "dates").astype("datetime64[us]")
    if days.ndim == 0 and np.isnat(days):
        raise ValueError("dates must not be NaT")
    d_date = _days_since_j2000(days, "dates")  # 00:00 UTC of the date
    lat = _checked(latitude, "latitude", -90.0, 90.0, "deg")
    lon = _checked(longitude, "longitude", -360.0, 360.0, "deg")
    h0 = _checked(horizon, "horizon", -np.pi / 2, np.pi / 2, "rad")
    dt_user = None if delta_t is None else _checked(delta_t, "delta_t", -1e6, 1e6, "s")
    shape = np.broadcast_shapes(d_date.shape, lat.shape, lon.shape, h0.shape)
    lon_rad = np.broadcast_to(lon.astype(np.float64) * _DEG, shape)
    lon_wrapped = (lon_rad + np.pi) % _TWO_PI - np.pi
    phi = np.broadcast_to(lat.astype(np.float64) * _DEG, shape)
    sphi, cphi = np.sin(phi), np.cos(phi)
    sin_h0 = np.sin(h0.astype(np.float64))
    if dt_user is not None:
        dt_user = np.broadcast_to(dt_user, shape)

    def cols(d):
        return _spa_columns(d, dt_user)

    # transit nearest local mean noon
    t = np.broadcast_to(d_date + 0.5, shape) - lon_wrapped / _TWO_PI
    for _ in range(3):
        c = cols(t)
        t = t - _hour_angle(t, lon_rad, c["q"]) / _TWO_PI
    noon = t
    bad = ~np.isfinite(noon) | ~np.isfinite(phi) | ~np.isfinite(np.broadcast_to(sin_h0, shape))
    noon = np.where(bad, np.nan, noon)

    # The solar day of a date is the 24 h centred on its transit, [noon − 12 h, noon + 12 h].
    # On each half the Sun's altitude is monotone (the hour angle runs from about −π to 0,
    # then 0 to π), so each half holds at most one horizon crossing: an upward one is the
    # sunrise, a downward one the sunset.  It is found by Newton steps safeguarded by the
    # bracket (bisection when a step leaves it).  Flags and lengths then follow from the
    # events alone, so they always agree.
    n = int(np.prod(shape))
    lon_f, sphi_f, cphi_f = lon_rad.ravel(), sphi.ravel(), cphi.ravel()
    sin_h0_f = np.broadcast_to(sin_h0, shape).ravel()
    dt_f = None if dt_user is None else np.broadcast_to(dt_user, shape).ravel()
    bad_f = bad.ravel()

    def excess(t, idx):
        """sin(altitude) − sin(horizon) and its time derivative [1/day] at ``t`` for the
        flat elements ``idx`` (geocentric, parallax neglected; the declination's drift is
        left out of the slope, which only slows the safeguarded Newton steps)."""
        c = _spa_columns(t, None if dt_f is None else dt_f[idx])
        sdec = c["sin_dec"]
        cdec = np.sqrt(1.0 - sdec * sdec)
        H = _hour_angle(t, lon_f[idx], c["q"])
        f = sphi_f[idx] * sdec + cphi_f[idx] * cdec * np.cos(H) - sin_h0_f[idx]
        return f, -cphi_f[idx] * cdec * np.sin(H) * _TWO_PI, sdec

    every = np.arange(n)
    noon_f = np.where(bad_f, 0.0, noon.ravel())
    t_start, t_end = noon_f - 0.5, noon_f + 0.5
    f_start, f_end = excess(t_start, every)[0], excess(t_end, every)[0]
    f_noon, _, sdec_noon = excess(noon_f, every)
    f_start, f_noon, f_end = (np.where(bad_f, np.nan, f) for f in (f_start, f_noon, f_end))
    # first guess: the hour-angle formula with the declination at noon
    with np.errstate(invalid="ignore", divide="ignore"):
        ch = (sin_h0_f - sphi_f * sdec_noon) / (cphi_f * np.sqrt(1.0 - sdec_noon * sdec_noon))
    h_guess = np.arccos(np.clip(np.where(np.isfinite(ch), ch, 0.0), -1.0, 1.0)) / _TWO_PI

    def crossing(lo, f_lo, hi, f_hi, guess):
        """Time of the sign change of ``excess`` in [lo, hi] (NaN where the signs agree)."""
        out = np.full(n, np.nan)
        idx = np.nonzero((f_lo > 0) != (f_hi > 0))[0]
        sgn = np.where(f_lo[idx] > 0, -1.0, 1.0)  # sgn·excess < 0 at a, > 0 at b
        a, b = lo[idx], hi[idx]
        t = np.clip(guess[idx], a + 1e-6 * (b - a), b - 1e-6 * (b - a))
        prev = np.full(idx.size, np.inf)
        for _ in range(_EVENT_ITERATIONS):
            if idx.size == 0:
                break
            f, fp, _ = excess(t, idx)
            below = sgn * f < 0
            a, b = np.where(below, t, a), np.where(below, b, t)
            with np.errstate(invalid="ignore", divide="ignore"):
                step = f / fp
            newton = t - step
            ok = np.isfinite(newton) & (newton >= a) & (newton <= b)
            # converged: a Newton step below the tolerance (it may round to t itself); or
            # steps contracting at the rate r = |step|/|previous step| < 1/2 with the error
            # left after this one, r/(1 − r)·|step| (geometric tail), below the tolerance;
            # an exact root; or a bracket narrower than the tolerance
            ast = np.abs(step)
            with np.errstate(invalid="ignore", divide="ignore"):
                tail = ast * ast / (prev - ast)
            fast = np.isfinite(prev) & (2.0 * ast < prev) & (tail < _EVENT_TOL_DAYS)
            done = (ok & ((ast < _EVENT_TOL_DAYS) | fast)) | (f == 0) | (b - a < _EVENT_TOL_DAYS)
            tn = np.where(ok, newton, 0.5 * (a + b))
            out[idx[done]] = np.where(f[done] == 0, t[done], tn[done])
            keep = ~done
            prev = np.where(ok, np.abs(step), np.inf)[keep]
            idx, sgn, a, b, t = idx[keep], sgn[keep], a[keep], b[keep], tn[keep]
        out[idx] = t  # not converged in _EVENT_ITERATIONS steps (not seen): best estimate
        return out

    c1 = crossing(t_start, f_start, noon_f, f_noon, noon_f - h_guess)
    c2 = crossing(noon_f, f_noon, t_end, f_end, noon_f + h_guess)
    up1 = f_noon > f_start  # direction of the crossing in the first half (if any)
    up2 = f_end > f_noon
    rise = np.where(np.isfinite(c1) & up1, c1, np.where(np.isfinite(c2) & up2, c2, np.nan))
    sset = np.where(np.isfinite(c1) & ~up1, c1, np.where(np.isfinite(c2) & ~up2, c2, np.nan))
    rise, sset, f_noon = rise.reshape(shape), sset.reshape(shape), f_noon.reshape(shape)
    t_start, t_end = t_start.reshape(shape), t_end.reshape(shape)
    has_r, has_s = np.isfinite(rise), np.isfinite(sset)
    quiet = ~bad & ~has_r & ~has_s  # no crossing in the whole solar day
    polar_day = quiet & (f_noon > 0)
    polar_night = quiet & ~(f_noon > 0)
    # time above the horizon within the solar day, from the events
    with np.errstate(invalid="ignore"):
        both = np.where(sset > rise, sset - rise, (sset - t_start) + (t_end - rise))
    length_days = np.select(
        [bad, has_r & has_s, has_r, has_s, polar_day],
        [np.nan, both, t_end - rise, sset - t_start, 1.0],
        default=0.0,
    )
    length = np.where(np.isfinite(length_days), length_days, 0.0) * 86_400e3
    day_length = np.asarray(np.round(length)).astype(np.int64).astype("timedelta64[ms]")
    day_length = np.where(np.isfinite(length_days), day_length, np.timedelta64("NaT", "ms"))

    def fin(a):
        return a[()] if a.ndim == 0 else a

    return SunriseSunset(
        sunrise=fin(_days_to_datetime64(rise)),
        sunset=fin(_days_to_datetime64(sset)),
        noon=fin(_days_to_datetime64(noon)),
        polar_day=fin(np.asarray(polar_day)),
        polar_night=fin(np.asarray(polar_night)),
        day_length=fin(day_length),
    )


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

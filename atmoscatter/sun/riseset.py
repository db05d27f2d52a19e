"""Sunrise, sunset and solar noon per local date and site, with polar day/night flags.

:func:`sunrise_sunset` works on the solar day of each date, the 24 h centred on its upper
transit, with the SPA ephemeris (through :mod:`atmoscatter.sun.nodes`):

1. the transit (solar noon), by iterating ``t ← t − H(t)/2π`` on the geocentric hour angle;
2. on each half of the solar day the altitude ``sin a = sin φ sin δ + cos φ cos δ cos H`` is
   monotone, so each half holds at most one crossing of the horizon ``h₀``; it is solved by
   Newton steps kept inside that bracket, started from the hour-angle formula
   ``cos H₀ = (sin h₀ − sin φ sin δ)/(cos φ cos δ)`` (Meeus 1998, *Astronomical
   Algorithms*, Ch. 15);
3. an upward crossing is the sunrise, a downward one the sunset; the polar day/night flags
   and the day length follow from the events alone.

The default horizon :data:`HORIZON_APPARENT` is Meeus's standard altitude of the Sun's
centre, −0.8333°.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ._common import _DEG, _TWO_PI, _checked
from .nodes import _spa_columns
from .time import _as_dates, _days_since_j2000, _days_to_datetime64

__all__ = ["HORIZON_APPARENT", "SunriseSunset", "sunrise_sunset"]

#: Standard altitude of the Sun's centre at apparent sunrise/sunset [rad]: −0.8333°
#: = −(34′ mean horizontal refraction + 16′ solar semi-diameter) (Meeus 1998, Ch. 15).
HORIZON_APPARENT: float = float(np.deg2rad(-50.0 / 60.0))
#: Rise/set solve: stop when the bracket is below this [days] (1e-9 d = 86 µs) or after
#: this many regula-falsi (Illinois) steps.
_EVENT_TOL_DAYS = 1e-9
_EVENT_ITERATIONS = 80


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


def _hour_angle(d, lon_rad, q):
    """Geocentric local hour angle wrapped to [−π, π)."""
    h = _TWO_PI * (d - np.floor(d)) + lon_rad - q
    return (h + np.pi) % _TWO_PI - np.pi


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

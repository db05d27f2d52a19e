"""Times and dates from the user's objects to ``datetime64`` and days since J2000.0.

Every function of :mod:`atmoscatter.sun` that takes times reads them through
``_as_datetime64`` (instants) or ``_as_dates`` (calendar dates) and works internally in
float days since J2000.0, ``d = JD − 2451545.0`` (2000-01-01 12:00 UT; the SPA forms its
Julian centuries from it, Reda & Andreas 2004 Eq. 6–8), and results go back to
``datetime64`` through ``_days_to_datetime64``.

Rules for instants (``_as_datetime64``):

- ``numpy.datetime64`` values (any unit) and ISO-8601 strings without offset are **UTC**;
  a trailing ``Z`` or ``±hh:mm`` offset is applied.
- Timezone-aware :class:`datetime.datetime` objects and pandas ``Timestamp``/
  ``DatetimeIndex``/``Series`` are converted to UTC.
- *Naive* ``datetime``/pandas objects raise ``ValueError``: a naive Python datetime is most
  often local time, and silently reading it as UTC is a classic bug.
- NaT elements of an array become NaN days (that element's result is NaN); a scalar NaT
  raises ``ValueError``.

Dates (``_as_dates``, for :func:`sunrise_sunset`) name a day, not an instant: naive values
are accepted there and an aware value keeps its own local calendar date.

:data:`SPA_YEARS` is the validity range of the SPA (Reda & Andreas 2004, −2000…6000);
``_check_years`` refuses instants outside it.  pandas is imported only when a pandas object
is passed.
"""

from __future__ import annotations

import datetime as _dt
import re

import numpy as np

__all__ = ["SPA_YEARS"]

_J2000_US = np.datetime64("2000-01-01T12:00:00", "us").astype(np.int64)  # JD 2451545.0 (UT)
_US_PER_DAY = 86_400e6


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


def _days_to_datetime64(d: np.ndarray) -> np.ndarray:
    ok = np.isfinite(d)
    ms = np.asarray(np.round(np.where(ok, d, 0.0) * 86_400e3)).astype(np.int64)
    out = (ms + _J2000_US // 1000).astype("datetime64[ms]")
    return np.where(ok, out, np.datetime64("NaT", "ms"))

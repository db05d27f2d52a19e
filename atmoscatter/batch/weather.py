"""Weather files in, sky domes out: one Perez all-weather scene per daylit hour of an EPW file.

Public objects
--------------
:func:`read_epw`
    Site (:class:`WeatherSite`: name, latitude, longitude, elevation, time zone) and the hourly
    columns the skies need, read with pvlib's maintained EPW reader
    (``pvlib.iotools.read_epw``; optional extra ``atmoscatter[weather]``).
:func:`select_hours`
    The file rows chosen by ``--hours`` (row numbers ``1-744``, dates ``6/21``, date ranges
    ``6/1-6/30``, comma-separated) and ``--every N``.
:func:`weather_batch`
    The :class:`WeatherBatch`: one ``perez_all_weather`` scene per daylit hour, ready for
    :func:`~atmoscatter.batch.run_batch` (resume, Ctrl-C, progress, Dask all apply), the hours
    rejected for missing or out-of-range values (one message per hour naming the field), the
    night hours that were skipped, and a per-hour table (sun, inputs, ε, Δ, the model's
    diffuse illuminance and the file's own).

Conventions (EnergyPlus "Auxiliary Programs", EPW data dictionary)
-------------------------------------------------------------------
* Row h of a day covers the hour from h−1 to h in local *standard* time (no daylight saving;
  the header's time zone in hours east of UTC).  The sun is placed at the **middle of the
  hour**, h − 0.5, as hourly weather data are means over the hour (pvlib labels the row by
  the start of its interval; 30 min are added).
* The year of each row is the file's (a TMY file mixes the years its months come from; those
  are the instants the irradiance was measured, so the sun is computed for them).
* Sun position: :func:`atmoscatter.sun_position` (NREL SPA) at the site's latitude, longitude
  and elevation (parallax), with the standard refraction (101325 Pa, 12 °C).  The
  scene gets the angles explicitly (``sun_elevation_deg``, ``sun_azimuth_deg``) and the UTC
  time (for the Earth–Sun distance of I₀), so the rendered sun is the one the night test saw.
* **Night**: the sun's apparent elevation at mid-hour ≤ 0, or a diffuse horizontal irradiance
  of 0.  Such hours are counted and skipped, never rendered.
* **Bad values** (checked only on daylit hours): a field at or above its EPW missing-value code
  (direct normal and diffuse horizontal irradiance 9999 W m⁻², dew point 99.9 °C), empty, or
  outside its range — irradiances in [0, I₀] with I₀ = 1367 W m⁻² × (1 AU / r)² of that
  instant (the extraterrestrial normal irradiance, the Perez et al. 1990 constant the sky
  uses), dew point in [−70, 60] °C (the EPW minimum; the top of the range of
  :func:`~atmoscatter.precipitable_water_from_dew_point`).  The hour gets one message naming
  it and the field, is not rendered, and is reported as failed at the end of the batch.
* The site elevation is read and reported; the Perez model does not depend on it (its ε and Δ
  use the relative air mass of Kasten & Young 1989, as published).
"""

from __future__ import annotations

import csv
import os
import re
from dataclasses import dataclass, field

import numpy as np

from .results import BatchResult

__all__ = ["WeatherSite", "WeatherBatch", "read_epw", "select_hours", "weather_batch",
           "write_weather_table", "EPW_MISSING"]

#: EPW missing-value codes of the fields the skies use (EnergyPlus Auxiliary Programs, "EnergyPlus
#: Weather File (EPW) Data Dictionary"); a value at or above the code is missing.
EPW_MISSING = {"direct_normal_irradiance": 9999.0, "diffuse_horizontal_irradiance": 9999.0,
               "dew_point": 99.9, "diffuse_horizontal_illuminance": 999999.0}
#: Valid range of the dew point [°C]: the EPW minimum −70 °C and the top of the range of the
#: precipitable-water formula.
DEW_POINT_RANGE = (-70.0, 60.0)
#: Extraterrestrial normal irradiance at 1 AU [W m⁻²] (Perez et al. 1990; the sky's I₀).
_SOLAR_CONSTANT = 1367.0

_PVLIB_COLUMNS = {"direct_normal_irradiance": "dni", "diffuse_horizontal_irradiance": "dhi",
                  "dew_point": "temp_dew",
                  "diffuse_horizontal_illuminance": "diffuse_horizontal_illum"}
_UNITS = {"direct_normal_irradiance": "W m^-2", "diffuse_horizontal_irradiance": "W m^-2",
          "dew_point": "degC"}


@dataclass(frozen=True)
class WeatherSite:
    """The site of a weather file (its ``LOCATION`` header line).

    Attributes
    ----------
    name : str
        City, region and country as the header gives them.
    latitude, longitude : float
        [deg], north and east positive.
    elevation : float
        Site elevation above sea level [m].
    time_zone : float
        Local standard time minus UTC [h] (e.g. −6 for US Central).
    data_type : str
        The header's source field (``TMY3``, ``IWEC``, …).
    """

    name: str
    latitude: float
    longitude: float
    elevation: float
    time_zone: float
    data_type: str = ""


@dataclass
class WeatherBatch:
    """The scenes of a weather file and what happened to every selected hour.

    Attributes
    ----------
    site : WeatherSite
    items : list of (str, dict)
        ``(name, fields)`` of the daylit hours with valid values, for
        :func:`~atmoscatter.batch.run_batch`; ``name`` is ``h<row>`` (``h0001`` … ``h8760``).
    rejected : list of BatchResult
        One failed result per daylit hour with a missing or out-of-range value (pass them
        to ``run_batch(..., rejected=...)`` so the summary reports them).
    table : dict of numpy.ndarray
        One entry per selected row (see :func:`write_weather_table` for the columns).
    rows_in_file : int
        Number of hourly rows in the file.
    """

    site: WeatherSite
    items: list = field(default_factory=list)
    rejected: list = field(default_factory=list)
    table: dict = field(default_factory=dict)
    rows_in_file: int = 0

    @property
    def night(self) -> int:
        """Selected hours skipped as night (sun at or below the horizon, or no diffuse light)."""
        return int(np.count_nonzero(self.table["status"] == "night"))

    def text(self) -> str:
        """One line: rows in the file, selected, daylit scenes, night, bad."""
        sel = len(self.table["row"])
        return (f"weather {self.site.name} ({self.site.latitude:g}, {self.site.longitude:g}, "
                f"{self.site.elevation:g} m, UTC{self.site.time_zone:+g} h): {self.rows_in_file} "
                f"hours in the file, {sel} selected: {len(self.items)} skies, {self.night} night "
                f"(skipped), {len(self.rejected)} with bad values (not rendered)")


def _pvlib_read_epw():
    try:
        from pvlib.iotools import read_epw as pv_read_epw  # noqa: PLC0415
    except ImportError as exc:
        raise ImportError('reading weather files needs pvlib: pip install "atmoscatter[weather]"'
                          ) from exc
    return pv_read_epw


def read_epw(path):
    """Site and hourly columns of an EnergyPlus weather (EPW) file.

    Parameters
    ----------
    path : str or path-like
        The ``.epw`` file (read with ``pvlib.iotools.read_epw``; needs the extra
        ``atmoscatter[weather]``).

    Returns
    -------
    site : WeatherSite
        From the ``LOCATION`` line.
    data : dict of numpy.ndarray
        Per row: ``row`` (1-based), ``year``, ``month``, ``day``, ``hour`` (1–24, the hour
        *ending* at that local standard time), ``start_utc`` (start of the hour,
        ``datetime64[s]`` UTC), ``mid_utc`` (middle of the hour) and the raw values
        ``direct_normal_irradiance``, ``diffuse_horizontal_irradiance`` [W m⁻²], ``dew_point``
        [°C], ``diffuse_horizontal_illuminance`` [lx] (missing codes kept; empty fields NaN).

    Raises
    ------
    ValueError
        The file does not exist, is not an EPW file pvlib can read, or is not hourly.
    ImportError
        pvlib is not installed.
    """
    path = os.fspath(path)
    if not os.path.isfile(path):
        raise ValueError(f"weather file {path!r} does not exist")
    reader = _pvlib_read_epw()
    try:
        df, meta = reader(path)
    except Exception as exc:  # pvlib raises whatever pandas or its parser raise
        msg = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        raise ValueError(f"{path}: not a readable EPW weather file ({type(exc).__name__}: "
                         f"{msg})") from None
    try:
        site = WeatherSite(
            name=", ".join(str(meta.get(k, "")).strip() for k in ("city", "state-prov", "country")
                           if str(meta.get(k, "")).strip() not in ("", "-")),
            latitude=float(meta["latitude"]), longitude=float(meta["longitude"]),
            elevation=float(meta["altitude"]), time_zone=float(meta["TZ"]),
            data_type=str(meta.get("data_type", "")).strip())
    except (KeyError, TypeError, ValueError) as exc:
        raise ValueError(f"{path}: the LOCATION line lacks a valid {exc}") from None
    if not (-90 <= site.latitude <= 90 and -180 <= site.longitude <= 180
            and -12 <= site.time_zone <= 14):
        raise ValueError(f"{path}: LOCATION has latitude {site.latitude}, longitude "
                         f"{site.longitude}, time zone {site.time_zone} h; valid ranges are "
                         "[-90, 90], [-180, 180] deg and [-12, 14] h")
    start = df.index.tz_convert("UTC").tz_localize(None).to_numpy().astype("datetime64[s]")
    if len(np.unique(start)) != len(start):
        raise ValueError(f"{path}: rows repeat an hour (a sub-hourly EPW file?); only hourly "
                         "files are supported")
    data = {"row": np.arange(1, len(df) + 1),
            "year": df["year"].to_numpy(int), "month": df["month"].to_numpy(int),
            "day": df["day"].to_numpy(int), "hour": df["hour"].to_numpy(int),
            "start_utc": start, "mid_utc": start + np.timedelta64(1800, "s")}
    for name, col in _PVLIB_COLUMNS.items():
        data[name] = np.asarray(df[col].to_numpy(float, na_value=np.nan), dtype=float)
    return site, data


_ROW_RE = re.compile(r"^(\d+)(?:-(\d+))?$")
_DATE_RE = re.compile(r"^(\d{1,2})/(\d{1,2})(?:-(\d{1,2})/(\d{1,2}))?$")


def select_hours(spec, month, day, *, every: int = 1) -> np.ndarray:
    """0-based indices of the rows chosen by an ``--hours`` specification and ``--every``.

    Parameters
    ----------
    spec : str or None
        Comma-separated parts, each a row number ``N`` (1-based, the file's hour of the year),
        a row range ``N-M`` (inclusive), a date ``M/D`` (its 24 hours) or a date range
        ``M/D-M/D`` (inclusive; dates as month/day, the file's years ignored).  ``None`` or
        ``""``: every row.
    month, day : numpy.ndarray
        The file's month and day of every row.
    every : int, optional
        Keep every ``every``-th of the selected rows (the first, then every ``every``-th after
        it, counted in the selection before night hours are dropped), ≥ 1.

    Returns
    -------
    numpy.ndarray
        Sorted unique row indices (0-based).

    Raises
    ------
    ValueError
        A part that is none of the forms above, a row outside [1, rows in the file], a date
        not in the file, a range that ends before it starts, ``every`` < 1.
    """
    from .._validate import check_count  # noqa: PLC0415

    every = check_count(every, "--every")
    n = len(month)
    if spec is None or not str(spec).strip():
        chosen = np.arange(n)
    else:
        key = np.asarray(month) * 100 + np.asarray(day)
        parts = []
        for part in str(spec).split(","):
            p = part.strip()
            m = _ROW_RE.match(p)
            d = _DATE_RE.match(p)
            if m:
                a = int(m.group(1))
                b = int(m.group(2)) if m.group(2) else a
                for v in (a, b):
                    if not 1 <= v <= n:
                        raise ValueError(f"--hours {p!r}: row {v} is outside [1, {n}] (the rows "
                                         "of the file)")
                if b < a:
                    raise ValueError(f"--hours {p!r}: the range ends before it starts")
                parts.append(np.arange(a - 1, b))
            elif d:
                lo = int(d.group(1)) * 100 + int(d.group(2))
                hi = int(d.group(3)) * 100 + int(d.group(4)) if d.group(3) else lo
                for v, txt in ((lo, p.split("-")[0]), (hi, p.split("-")[-1])):
                    if not np.any(key == v):
                        raise ValueError(f"--hours {p!r}: the file has no date {txt} (month/day)")
                if hi < lo:
                    raise ValueError(f"--hours {p!r}: the date range ends before it starts")
                parts.append(np.flatnonzero((key >= lo) & (key <= hi)))
            else:
                raise ValueError(f"--hours {p!r}: expected row numbers N or N-M (1-{n}), a "
                                 "date M/D or a date range M/D-M/D, comma-separated")
        chosen = np.unique(np.concatenate(parts))
    return chosen[::every]


def _label(data, i) -> str:
    h = int(data["hour"][i])
    return (f"hour {int(data['row'][i])} ({int(data['month'][i]):02d}/{int(data['day'][i]):02d} "
            f"{h - 1:02d}:00-{h:02d}:00 local standard time)")


def _check_value(name, value, upper) -> str:
    """'' if ``value`` is a valid ``name``, else why not."""
    unit = _UNITS[name]
    if not np.isfinite(value):
        return f"{name} is missing (empty field)"
    if value >= EPW_MISSING[name]:
        return f"{name} = {value:g} {unit} is the EPW missing-value code ({EPW_MISSING[name]:g})"
    if name == "dew_point":
        lo, hi = DEW_POINT_RANGE
        if not lo <= value <= hi:
            return f"{name} = {value:g} {unit} is outside [{lo:g}, {hi:g}] {unit}"
        return ""
    if not 0.0 <= value <= upper:
        return (f"{name} = {value:g} {unit} is outside [0, {upper:.1f}] {unit} (the "
                "extraterrestrial normal irradiance of that date)")
    return ""


def _iso(t) -> str:
    return str(np.datetime64(t, "s")) + "Z"


def weather_batch(path, *, hours=None, every: int = 1, overrides=None) -> WeatherBatch:
    """One ``perez_all_weather`` scene per daylit hour of an EPW weather file.

    Parameters
    ----------
    path : str or path-like
        The EPW file (:func:`read_epw`).
    hours : str, optional
        Rows to consider (:func:`select_hours`); default all.
    every : int, optional
        Keep every ``every``-th selected row (:func:`select_hours`).
    overrides : dict, optional
        Scene fields set in every scene after the weather fields (the CLI's ``--set``: size,
        projection, output …); keys must be scene fields.

    Returns
    -------
    WeatherBatch
        Scenes of the daylit hours with valid values (fields ``model``, ``latitude``,
        ``longitude``, ``time`` (UTC, mid-hour), ``sun_elevation_deg``, ``sun_azimuth_deg``,
        ``direct_normal_irradiance``, ``diffuse_horizontal_irradiance``, ``dew_point``, then
        ``overrides``), the rejected hours and the per-hour table.

    Raises
    ------
    ValueError
        An unreadable file, a bad ``hours``/``every``, an unknown field in ``overrides``.
    """
    import warnings  # noqa: PLC0415

    from ..scene import Scene  # noqa: PLC0415
    from ..sky.perez_all_weather import PerezRangeWarning, perez_all_weather_conditions  # noqa: PLC0415
    from ..sun import sun_position  # noqa: PLC0415

    overrides = dict(overrides or {})
    unknown = [k for k in overrides if k not in Scene.field_names()]
    if unknown:
        raise ValueError(f"unknown scene field {unknown[0]!r}; valid fields are: "
                         + ", ".join(Scene.field_names()))
    site, data = read_epw(path)
    idx = select_hours(hours, data["month"], data["day"], every=every)
    sel = {k: v[idx] for k, v in data.items()}
    pos = sun_position(sel["mid_utc"], site.latitude, site.longitude, elevation=site.elevation)
    elev = np.degrees(np.asarray(pos.elevation, dtype=float)).reshape(-1)
    azim = np.degrees(np.asarray(pos.azimuth, dtype=float)).reshape(-1) % 360.0
    i0 = _SOLAR_CONSTANT / np.asarray(pos.earth_sun_distance, dtype=float).reshape(-1) ** 2
    dni = sel["direct_normal_irradiance"]
    dhi = sel["diffuse_horizontal_irradiance"]
    td = sel["dew_point"]
    status = np.full(len(idx), "sky", dtype=object)
    message = np.full(len(idx), "", dtype=object)
    for k in range(len(idx)):  # per-hour messages: a loop over rows, not a hot path
        if elev[k] <= 0.0:
            status[k] = "night"
            continue
        why = _check_value("diffuse_horizontal_irradiance", dhi[k], i0[k])
        if not why and dhi[k] == 0.0:
            status[k] = "night"
            continue
        why = why or _check_value("direct_normal_irradiance", dni[k], i0[k]) \
            or _check_value("dew_point", td[k], 0.0)
        if why:
            status[k], message[k] = "bad", f"{_label(sel, k)}: {why}"
    sky = status == "sky"
    nan = np.full(len(idx), np.nan)
    eps, dlt, dv = nan.copy(), nan.copy(), nan.copy()
    if np.any(sky):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", PerezRangeWarning)  # each render reports its own
            cond = perez_all_weather_conditions(
                np.radians(90.0 - elev[sky]), dni[sky], dhi[sky], dew_point=td[sky],
                extraterrestrial_normal_irradiance=i0[sky])
        eps[sky], dlt[sky] = cond.epsilon, cond.delta
        dv[sky] = cond.diffuse_horizontal_illuminance
    names = np.array([f"h{int(r):04d}" for r in sel["row"]], dtype=object)
    items, rejected = [], []
    for k in np.flatnonzero(sky):
        fields = {"name": names[k], "model": "perez_all_weather",
                  "latitude": site.latitude, "longitude": site.longitude,
                  "time": _iso(sel["mid_utc"][k]),
                  "sun_elevation_deg": float(elev[k]), "sun_azimuth_deg": float(azim[k]),
                  "direct_normal_irradiance": float(dni[k]),
                  "diffuse_horizontal_irradiance": float(dhi[k]), "dew_point": float(td[k])}
        fields.update(overrides)
        fields["name"] = names[k]
        items.append((names[k], fields))
    for k in np.flatnonzero(status == "bad"):
        rejected.append(BatchResult(names[k], "", "failed", 0.0, message[k]))
    table = {**sel, "name": names, "sun_elevation_deg": elev, "sun_azimuth_deg": azim,
             "extraterrestrial_normal_irradiance": i0, "status": status, "message": message,
             "epsilon": eps, "delta": dlt, "model_diffuse_horizontal_illuminance": dv}
    return WeatherBatch(site=site, items=items, rejected=rejected, table=table,
                        rows_in_file=len(data["row"]))


#: Columns of :func:`write_weather_table`, in order.
TABLE_COLUMNS = ("row", "name", "year", "month", "day", "hour", "mid_utc", "status",
                 "sun_elevation_deg", "sun_azimuth_deg", "direct_normal_irradiance",
                 "diffuse_horizontal_irradiance", "dew_point", "epsilon", "delta",
                 "model_diffuse_horizontal_illuminance", "diffuse_horizontal_illuminance",
                 "message")


def write_weather_table(batch: WeatherBatch, path) -> str:
    """Write the per-hour table of a :class:`WeatherBatch` as CSV (atomically).

    Columns (:data:`TABLE_COLUMNS`): the file's ``row``, the output ``name``, ``year``,
    ``month``, ``day``, ``hour`` (1–24, ending at that local standard time), ``mid_utc`` (the
    sun's instant), ``status`` (``sky``, ``night`` or ``bad``), the sun's apparent
    ``sun_elevation_deg`` and ``sun_azimuth_deg`` [deg], the file's irradiances [W m⁻²] and dew
    point [°C], the model's ``epsilon`` and ``delta`` [1] and diffuse horizontal illuminance
    ``model_diffuse_horizontal_illuminance`` [lx] (empty unless ``sky``), the file's own
    ``diffuse_horizontal_illuminance`` [lx] (missing code kept) and the ``message`` of a bad
    hour.

    Parameters
    ----------
    batch : WeatherBatch
    path : str or path-like
        Output ``.csv`` file.

    Returns
    -------
    str
        ``path``.
    """
    from .._atomic import atomic_write  # noqa: PLC0415

    path = os.fspath(path)
    t = batch.table

    def cell(col, k):
        v = t[col][k]
        if col == "mid_utc":
            return _iso(v)
        if isinstance(v, (float, np.floating)):
            return "" if np.isnan(v) else f"{float(v):.6g}"
        return str(v)

    with atomic_write(path) as tmp, open(tmp, "w", newline="", encoding="utf-8") as fh:
        w = csv.writer(fh)
        w.writerow(TABLE_COLUMNS)
        for k in range(len(t["row"])):
            w.writerow([cell(c, k) for c in TABLE_COLUMNS])
    return path

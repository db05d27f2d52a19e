"""``atmoscatter batch --weather FILE.epw``: one Perez all-weather sky per daylit hour.

The weather file is a real one, shipped in ``tests/data`` (Chicago O'Hare TMY3; source and
licence in ``tests/data/README.md``).  The references are computed here independently of
the package: the site from the file's ``LOCATION`` line as text, the instants from the EPW
convention (row h of a day covers h−1…h local standard time), the sun from
``pvlib.solarposition``, and ε, Δ and the Perez et al. (1990) diffuse efficacy from their
published equations.
"""

from __future__ import annotations

import csv
import datetime as dt
import math
import shutil
from pathlib import Path

import numpy as np
import pytest

pvlib = pytest.importorskip("pvlib")

import atmoscatter as ac  # noqa: E402
from atmoscatter.batch.weather import read_epw, select_hours, weather_batch  # noqa: E402
from atmoscatter.cli import main  # noqa: E402

EPW = Path(__file__).parent / "data" / "USA_IL_Chicago-OHare.Intl.AP.725300_TMY3.epw"
#: EPW column numbers (0-based; EnergyPlus EPW data dictionary)
COL = {"year": 0, "month": 1, "day": 2, "hour": 3, "dew_point": 7, "dni": 14, "dhi": 15,
       "dhi_illum": 18}


def epw_rows():
    lines = EPW.read_text().splitlines()
    return lines[:8], [r.split(",") for r in lines[8:]]


def write_copy(tmp_path, changes, name="copy.epw"):
    """A copy of the test file with ``changes`` = {(row 1-based, column name): text}."""
    head, rows = epw_rows()
    for (row, col), text in changes.items():
        rows[row - 1][COL[col]] = text
    path = tmp_path / name
    path.write_text("\n".join(head + [",".join(r) for r in rows]) + "\n")
    return path


def row_of(month, day, hour):
    _, rows = epw_rows()
    for i, r in enumerate(rows):
        if (int(r[1]), int(r[2]), int(r[3])) == (month, day, hour):
            return i + 1
    raise AssertionError("no such row")


# --- site and time ---------------------------------------------------------------
def test_site_and_time_zone_from_the_header():
    head, rows = epw_rows()
    loc = head[0].split(",")  # LOCATION,city,state,country,source,WMO,lat,lon,tz,elevation
    site, data = read_epw(EPW)
    assert site.latitude == float(loc[6]) and site.longitude == float(loc[7])
    assert site.time_zone == float(loc[8]) and site.elevation == float(loc[9])
    assert loc[1] in site.name and site.data_type == loc[4]
    assert len(data["row"]) == len(rows) == 8760
    # every row's instant: local standard time (h - 1):30 of its own date -> UTC
    tz = dt.timezone(dt.timedelta(hours=float(loc[8])))
    for k in (0, 23, 4000, 8759):
        y, m, d, h = (int(rows[k][COL[c]]) for c in ("year", "month", "day", "hour"))
        mid = dt.datetime(y, m, d, tzinfo=tz) + dt.timedelta(hours=h - 0.5)
        expect = np.datetime64(mid.astimezone(dt.timezone.utc).replace(tzinfo=None), "s")
        assert data["mid_utc"][k] == expect


def test_mid_hour_sun_against_pvlib():
    import pandas as pd

    site, data = read_epw(EPW)
    wb = weather_batch(EPW, every=7)  # 1252 rows spread over the year and the day
    t = wb.table
    times = pd.DatetimeIndex(t["mid_utc"]).tz_localize("UTC")
    ref = pvlib.solarposition.get_solarposition(
        times, site.latitude, site.longitude, altitude=site.elevation, pressure=101325.0,
        temperature=12.0, delta_t=np.asarray(ac.default_delta_t(t["mid_utc"])))
    # both are the NREL SPA with the same refraction formula and inputs: the package adds
    # its node interpolation (< 1e-5 deg) to float64 rounding; 1e-4 deg is 10x that
    day = ref["apparent_elevation"].to_numpy() > -1.0
    np.testing.assert_allclose(t["sun_elevation_deg"][day],
                               ref["apparent_elevation"].to_numpy()[day], atol=1e-4, rtol=0)
    daz = (t["sun_azimuth_deg"] - ref["azimuth"].to_numpy() + 180.0) % 360.0 - 180.0
    assert np.max(np.abs(daz[day])) < 1e-3  # azimuth: 1e-4 deg / sin(zenith) near the zenith
    # the scenes carry exactly those angles and the mid-hour time
    f = dict(wb.items[len(wb.items) // 2][1])
    k = list(t["name"]).index(f["name"])
    assert f["sun_elevation_deg"] == t["sun_elevation_deg"][k]
    assert f["time"] == str(t["mid_utc"][k]) + "Z"
    # night: the sun at or below the horizon at mid-hour, or no diffuse light
    night = (ref["apparent_elevation"].to_numpy() <= 0) | (t["diffuse_horizontal_irradiance"] == 0)
    assert wb.night == int(np.count_nonzero(night))
    assert np.all((t["status"] == "night") == night)


# --- selection ---------------------------------------------------------------------
def test_hours_and_every():
    _, data = read_epw(EPW)
    m, d = data["month"], data["day"]
    jan = select_hours("1-744", m, d)
    assert len(jan) == 744 and set(m[jan]) == {1}
    day = select_hours("6/21", m, d)
    assert len(day) == 24 and set(m[day]) == {6} and set(d[day]) == {21}
    june = select_hours("6/1-6/30", m, d)
    assert len(june) == 720 and set(m[june]) == {6}
    assert list(select_hours("1-10, 5-20", m, d)) == list(range(20))
    assert list(select_hours("1-10", m, d, every=3)) == [0, 3, 6, 9]
    assert len(select_hours(None, m, d, every=24)) == 365
    for bad, what in (("0", "outside"), ("8761", "outside"), ("5-2", "ends before"),
                      ("13/1", "no date"), ("2/30", "no date"), ("noon", "expected")):
        with pytest.raises(ValueError, match=what):
            select_hours(bad, m, d)
    with pytest.raises((ValueError, TypeError), match="--every"):
        select_hours(None, m, d, every=0)


# --- bad values ----------------------------------------------------------------------
def test_bad_values_are_reported_per_hour(tmp_path):
    r1, r2, r3, r4 = (row_of(6, 21, h) for h in (10, 11, 12, 13))
    path = write_copy(tmp_path, {(r1, "dni"): "9999", (r2, "dhi"): "-5",
                                 (r3, "dew_point"): "99.9", (r4, "dni"): "1500"})
    wb = weather_batch(path, hours="6/21")
    bad = {r.name: r.error for r in wb.rejected}
    assert set(bad) == {f"h{r:04d}" for r in (r1, r2, r3, r4)}
    assert f"hour {r1} (06/21 09:00-10:00" in bad[f"h{r1:04d}"]
    assert "direct_normal_irradiance = 9999" in bad[f"h{r1:04d}"] and "missing" in bad[f"h{r1:04d}"]
    assert "diffuse_horizontal_irradiance = -5" in bad[f"h{r2:04d}"]
    assert "dew_point = 99.9" in bad[f"h{r3:04d}"]
    assert "direct_normal_irradiance = 1500" in bad[f"h{r4:04d}"] and "outside" in bad[f"h{r4:04d}"]
    good = weather_batch(EPW, hours="6/21")
    assert len(wb.items) == len(good.items) - 4  # the other hours go on
    assert wb.night == good.night
    # through the command: the others are rendered, the bad ones reported at the end
    out = tmp_path / "out"
    code = main(["batch", "--weather", str(path), "--hours", f"{r1 - 1}-{r2}", "-o", str(out),
                 "--set", "width=8", "--set", "height=4", "--quiet"])
    assert code == 1
    assert (out / f"h{r1 - 1:04d}.exr").exists() and not (out / f"h{r1:04d}.exr").exists()
    summary = (out / "batch_summary.json").read_text()
    assert "direct_normal_irradiance = 9999" in summary and "diffuse_horizontal_irradiance = -5" in summary


def test_weather_errors(tmp_path):
    with pytest.raises(ValueError, match="does not exist"):
        weather_batch(tmp_path / "none.epw")
    junk = tmp_path / "junk.epw"
    junk.write_text("not,a,weather,file\n")
    with pytest.raises(ValueError, match="junk.epw"):
        weather_batch(junk)
    with pytest.raises(ValueError, match="unknown scene field 'widht'"):
        weather_batch(EPW, hours="6/21", overrides={"widht": 8})
    assert main(["batch", "-o", str(tmp_path), "--hours", "1-3"]) == 2
    assert main(["batch", "x.csv", "--weather", str(EPW), "-o", str(tmp_path)]) == 2


# --- resume and the end-to-end check --------------------------------------------------
def run_cli(path, out, hours, size, capsys, *extra):
    code = main(["batch", "--weather", str(path), "--hours", hours, "-o", str(out),
                 "--set", f"width={size[0]}", "--set", f"height={size[1]}", "--quiet", *extra])
    return code, capsys.readouterr().out


def test_resume_skips_done_hours_and_renders_changed_ones(tmp_path, capsys):
    hours = "-".join(str(row_of(3, 20, h)) for h in (11, 13))
    out = tmp_path / "out"
    code, text = run_cli(EPW, out, hours, (32, 16), capsys)
    assert code == 0 and "3 scenes: 3 rendered" in text
    code, text = run_cli(EPW, out, hours, (32, 16), capsys)
    assert code == 0 and "0 rendered, 3 already complete" in text
    r = row_of(3, 20, 12)
    _, rows = epw_rows()
    changed = write_copy(tmp_path, {(r, "dhi"): str(int(rows[r - 1][COL["dhi"]]) + 1)})
    code, text = run_cli(changed, out, hours, (32, 16), capsys)
    assert code == 0 and "1 rendered, 2 already complete" in text


def perez_efficacy_illuminance(dni, dhi, dew_point, zenith, i0):
    """D_v = D K_d from Perez et al. (1990) Eqs. 1-3 and 7, written out here."""
    table = np.loadtxt(Path(ac.__file__).parent / "data" / "perez_luminous_efficacy.csv",
                       delimiter=",", comments="#")
    kappa = 1.041
    eps = ((dhi + dni) / dhi + kappa * zenith**3) / (1 + kappa * zenith**3)
    zd = math.degrees(zenith)
    airmass = 1.0 / (math.cos(zenith) + 0.50572 * (96.07995 - zd) ** -1.6364)  # Kasten & Young
    delta = airmass * dhi / i0
    w = math.exp(0.07 * dew_point - 0.075)
    row = table[np.searchsorted(table[:, 1], eps, side="right") - 1]
    a, b, c, d = row[3:]
    return dhi * (a + b * w + c * math.cos(zenith) + d * math.log(delta))


def test_end_to_end_dome_illuminance_matches_perez_efficacy(tmp_path, capsys):
    import pandas as pd

    hours = f"{row_of(6, 21, 7)},{row_of(6, 21, 12)},{row_of(12, 10, 10)}"
    site, data = read_epw(EPW)
    errors = {}
    for size in ((32, 16), (64, 32)):
        out = tmp_path / f"out{size[0]}"
        code, text = run_cli(EPW, out, hours, size, capsys, "--set", "output=luminance")
        assert code == 0 and "3 scenes: 3 rendered" in text
        table = list(csv.DictReader((out / "weather_hours.csv").open()))
        for row in table:
            k = int(row["row"]) - 1
            t = pd.DatetimeIndex([data["mid_utc"][k]]).tz_localize("UTC")
            sp = pvlib.solarposition.get_solarposition(
                t, site.latitude, site.longitude, altitude=site.elevation, pressure=101325.0)
            i0 = 1367.0 / pvlib.solarposition.nrel_earthsun_distance(t).iloc[0] ** 2
            dv = perez_efficacy_illuminance(
                data["direct_normal_irradiance"][k], data["diffuse_horizontal_irradiance"][k],
                data["dew_point"][k], math.radians(sp["apparent_zenith"].iloc[0]), i0)
            img = ac.read_exr(out / f"{row['name']}.exr")
            y = img.channels["Y"].astype(float)
            d, om = ac.latlong_quadrature(y.shape[1], y.shape[0])
            e = ac.diffuse_irradiance(y, directions=d, weights=om)
            errors.setdefault(row["name"], []).append(e / dv - 1.0)
            # the table's model value is the same chain (sun angles agree to 1e-4 deg)
            assert float(row["model_diffuse_horizontal_illuminance"]) == pytest.approx(dv, rel=1e-4)
    for name, (e32, e64) in errors.items():
        # The lat-long pixel rule is second order: its error e(h) = C h^2 + O(h^4) (up to
        # about 1.3 % at 32 x 16 for the low December sun) falls about 4x when the size
        # doubles, and Richardson's (4 e(h/2) - e(h)) / 3 removes the h^2 term.  What is left
        # is the O(h^4) rest (of the order of e(h)^2 / e_scale, a few 1e-4, the sharper
        # circumsolar peak included), so 2e-3 bounds it; an error in the absolute level (the
        # efficacy, I0, the dew point) would survive the extrapolation and fail.
        assert abs(e64) < abs(e32) / 3, name
        assert abs((4 * e64 - e32) / 3) < 2e-3, name


def test_weather_table_columns(tmp_path):
    from atmoscatter.batch.weather import TABLE_COLUMNS, write_weather_table

    wb = weather_batch(EPW, hours="6/21")
    path = write_weather_table(wb, tmp_path / "w.csv")
    rows = list(csv.DictReader(open(path)))
    assert tuple(rows[0]) == TABLE_COLUMNS and len(rows) == 24
    assert {r["status"] for r in rows} == {"sky", "night"}
    assert all(r["epsilon"] == "" for r in rows if r["status"] == "night")


def test_missing_pvlib_names_the_extra(monkeypatch, tmp_path):
    import builtins

    real = builtins.__import__

    def fake(name, *a, **k):
        if name.startswith("pvlib"):
            raise ImportError("no pvlib")
        return real(name, *a, **k)

    monkeypatch.setattr(builtins, "__import__", fake)
    shutil.copy(EPW, tmp_path / "w.epw")
    with pytest.raises(ImportError, match=r'pip install "atmoscatter\[weather\]"'):
        read_epw(tmp_path / "w.epw")

"""Measured numbers of the prose pages: integrals, analytic skies, sun, oracle, render.

Run (from the repository root; ``scripts/make_docs_data.py --only docs_numbers`` does it)::

    PYTHONPATH=. python scripts/docs_numbers.py                      # writes docs/numbers/*.md
    PYTHONPATH=. python scripts/docs_numbers.py --quick --out DIR    # CI smoke run (tiny sizes)
    PYTHONPATH=. python scripts/docs_numbers.py --only sun integrals # a subset of the sections

Each section writes Markdown fragments that the pages include with ``--8<--`` (so a number
on ``docs/integrals.md``, ``docs/analytic_skies.md``, ``docs/aerial_perspective.md``,
``docs/sun.md``, ``docs/oracle.md`` or ``docs/theory/render.md`` is the output of this file, not typed by hand; see
``tests/test_docs_numbers.py``).  Accuracy figures are deterministic (fixed seeds); timing
fragments state the machine, the date, the load and the command, and are noisy on a shared
machine.  The quick mode runs every section on small problems into ``--out``: its numbers
prove the code runs and are not for publishing.
"""

from __future__ import annotations

import argparse
import datetime
import math
import os
import platform
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
OUT = ROOT / "docs" / "numbers"
COMMAND = "PYTHONPATH=. python scripts/docs_numbers.py"


def _machine() -> str:
    cpu = platform.processor() or platform.machine()
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    load = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")
    return (f"{datetime.date.today().isoformat()}, {cpu}, {os.cpu_count()} CPUs, load average "
            f"{load:.1f} (shared machine: times are noisy), Python {platform.python_version()}")


def _timing_note(section: str) -> str:
    return (f"*Measured by `{COMMAND} --only {section}` on {_machine()}; best of the repeats "
            f"stated.*")


def _best(fn, repeat: int) -> float:
    fn()  # warm-up: JIT compile, caches
    best = math.inf
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - t0)
    return best


def _fmt_t(seconds: float) -> str:
    if seconds < 1e-6:
        return f"{seconds * 1e9:.3g} ns"
    if seconds < 1e-3:
        return f"{seconds * 1e6:.3g} µs"
    if seconds < 1.0:
        return f"{seconds * 1e3:.3g} ms"
    return f"{seconds:.3g} s"


def _int(n: int) -> str:
    """An integer with a space between thousands (the pages' style): 20 000."""
    return f"{n:,}".replace(",", " ")


def _pow10(n: int) -> str:
    """10⁴ for 10000 (powers of ten only)."""
    k = round(math.log10(n))
    return "10" + str(k).translate(str.maketrans("0123456789", "⁰¹²³⁴⁵⁶⁷⁸⁹"))


def _rate(x: float) -> str:
    """A rate with two significant digits: 1.3e7 (no '+0' exponent padding)."""
    m, k = f"{x:.1e}".split("e")
    return f"{m}e{int(k)}"


def _e(x: float) -> str:
    """Two significant digits in scientific notation (the tables' style)."""
    return f"{x:.1e}"


def _write(out: Path, name: str, text: str) -> None:
    out.mkdir(parents=True, exist_ok=True)
    path = out / name
    path.write_text(text.rstrip() + "\n", encoding="utf-8")
    print(f"wrote {path}")


# ---------------------------------------------------------------------------------------------
# integrals
# ---------------------------------------------------------------------------------------------
def _lobe_sky(sun):
    def sky(d):
        return (1 + 2 * d[:, 2]) / 3 + 5 * np.exp(50 * (d @ sun - 1))
    return sky


def integrals(out: Path, quick: bool) -> None:
    import atmoscatter as ac

    def overcast(d):
        return 5000.0 * (1 + 2 * d[:, 2]) / 3

    rows = []
    e_h = float(ac.diffuse_irradiance(overcast))
    rows.append(("`ac.diffuse_irradiance(overcast)`", e_h, "7π/9 · 5000", 7 * math.pi / 9 * 5000))
    e_w = float(ac.diffuse_irradiance(overcast, normal=(0, -1, 0)))
    exact_w = 5000 / 3 * (math.pi / 2 + 4 / 3)
    rows.append(("`ac.diffuse_irradiance(overcast, normal=(0, -1, 0))` (a wall)", e_w,
                 "5000/3 · (π/2 + 4/3)", exact_w))
    coef = ac.sh_project(overcast, order=4, domain="upper")
    e_sh = float(ac.sh_irradiance(coef, [0, 0, 1]))
    rows.append(("`ac.sh_irradiance(coef, [0, 0, 1])` (order 4)", e_sh, "7π/9 · 5000",
                 7 * math.pi / 9 * 5000))
    wl = np.arange(380, 781, 5.0)
    e_n = ac.direct_normal_irradiance(ac.earth_atmosphere(wavelengths=wl), [0, 0.5, 0.75**0.5])
    dni = float(ac.K_M * e_n @ ac.cmf_weights(wl)[:, 1])
    rows.append(("`ac.K_M * E_n @ ac.cmf_weights(wl)[:, 1]` (sun 60° high)", dni, "—", None))
    lines = ["| expression | value [lx] | closed form | relative difference |", "|---|---|---|---|"]
    for expr, v, form, exact in rows:
        diff = "—" if exact is None else _e(abs(v / exact - 1))
        lines.append(f"| {expr} | {v:.1f} | {form} | {diff} |")
    _write(out, "integrals_examples.md", "\n".join(lines))

    # SH truncation of the overcast sky's horizon step (zenith-facing plane)
    orders = (2, 4, 8)
    errs = []
    for o in orders:
        c = ac.sh_project(overcast, order=o, domain="upper")
        errs.append(abs(float(ac.sh_irradiance(c, [0, 0, 1])) / (7 * math.pi / 9 * 5000) - 1))
    _write(out, "integrals_sh_truncation.md",
           "For the overcast sky with its horizon step the zenith-plane irradiance from the "
           "SH projection is off by " + ", ".join(f"{_e(e)} at order {o}" for o, e in
                                                zip(orders, errs, strict=True))
           + " (relative to the exact 7π/9 · L_z).")

    # quadrature convergence for the sun-lobe sky
    sun = np.array([0.0, math.cos(math.radians(30)), math.sin(math.radians(30))])
    sky = _lobe_sky(sun)
    n_ref = 256 if quick else 1024
    levels = (8, 16) if quick else (8, 16, 32, 48)
    ref_h = float(ac.diffuse_irradiance(sky, n_theta=n_ref))
    ref_w = float(ac.diffuse_irradiance(sky, normal=(0, 1, 0), n_theta=n_ref))
    ref_c = ac.sh_project(sky, order=4, domain="upper", n_theta=n_ref)
    lines = [f"Relative error against n_theta = {n_ref}; sun 30° high in the north; SH column: "
             "largest coefficient error over the largest coefficient, order 4, "
             "`domain=\"upper\"`.", "",
             "| n_theta (per hemisphere) | horizontal irradiance | wall facing the sun | "
             "SH coefficients |", "|---|---|---|---|"]
    for n in levels:
        h = float(ac.diffuse_irradiance(sky, n_theta=n))
        w = float(ac.diffuse_irradiance(sky, normal=(0, 1, 0), n_theta=n))
        c = ac.sh_project(sky, order=4, domain="upper", n_theta=n)
        sh = float(np.max(np.abs(c - ref_c)) / np.max(np.abs(ref_c)))
        tag = " (default)" if n == 48 else ""
        lines.append(f"| {n}{tag} | {_e(abs(h / ref_h - 1))} | {_e(abs(w / ref_w - 1))} | "
                     f"{_e(sh)} |")
    # tilted planes: closed forms
    beta = math.radians(35)
    tilt = float(ac.diffuse_irradiance(lambda d: np.full(len(d), 1000.0),
                                       normal=(0, math.sin(beta), math.cos(beta))))
    tilt_err = abs(tilt / (math.pi * 1000 * (1 + math.cos(beta)) / 2) - 1)
    wall_err = abs(e_w / (5000 * (math.pi / 6 + 4 / 9)) - 1)
    lines += ["", f"Closed forms: a uniform sky on a plane tilted by 35° against "
              f"πL(1 + cos β)/2: {_e(tilt_err)}; the overcast sky on a wall against "
              f"L_z(π/6 + 4/9): {_e(wall_err)} (vertical/horizontal ratio "
              f"{e_w / e_h:.3f})."]
    _write(out, "integrals_quadrature.md", "\n".join(lines))

    # a rendered lat-long map against the quadrature of the same sky
    lines = []
    for w_, h_ in ((64, 32), (128, 64)) if quick else ((64, 32), (256, 128)):
        scene = ac.Scene(width=w_, height=h_)
        s = scene.sun_direction()
        img = ac.render(scene)
        ref = float(ac.diffuse_irradiance(lambda d, s=s, t=scene.turbidity: ac.preetham_sky(d, s, t)
                                          [..., 1]))
        lines.append(f"{w_}×{h_}: {_e(abs(float(ac.diffuse_irradiance(img)) / ref - 1))}")
    _write(out, "integrals_latlong.md",
           "A rendered lat-long map of the default scene against the Gauss–Legendre integral "
           "of the same Preetham sky, relative difference of the horizontal illuminance: "
           + "; ".join(lines) + ".")

    # facade example (page code)
    s = ac.Scene(time="2024-06-21T18:00:00Z", latitude=39.742, longitude=-105.179).sun_direction()
    fsky = lambda d: ac.preetham_sky(d, s, 3.0)[..., 1]  # noqa: E731
    e_n = ac.K_M * ac.direct_normal_irradiance(
        ac.earth_turbidity_atmosphere(3.0, wavelengths=wl), s) @ ac.cmf_weights(wl)[:, 1]
    el = math.degrees(math.asin(s[2]))
    az = math.degrees(math.atan2(s[0], s[1])) % 360
    lines = [f"Sun {el:.1f}° high, azimuth {az:.0f}°.", "",
             "| plane | diffuse (sky) [lx] | direct (sun) [lx] |", "|---|---|---|"]
    for label, n in (("horizontal", (0, 0, 1)), ("north wall", (0, 1, 0)),
                     ("east wall", (1, 0, 0)), ("south wall", (0, -1, 0)),
                     ("west wall", (-1, 0, 0))):
        d = float(ac.diffuse_irradiance(fsky, normal=n))
        b = float(ac.direct_irradiance(e_n, s, normal=n))
        lines.append(f"| {label} | {_int(round(d))} | {_int(round(b))} |")
    _write(out, "integrals_facade.md", "\n".join(lines))

    # speed
    rep = 3 if quick else 20
    n_big = 10**4 if quick else 10**6
    t_h = _best(lambda: ac.diffuse_irradiance(sky), rep)
    t_w = _best(lambda: ac.diffuse_irradiance(sky, normal=(0, 1, 0)), rep)
    t_su = _best(lambda: ac.sh_project(sky, order=4, domain="upper"), rep)
    t_ss = _best(lambda: ac.sh_project(sky, order=4, domain="sphere"), rep)
    dirs = np.random.default_rng(0).normal(size=(n_big, 3))
    dirs /= np.linalg.norm(dirs, axis=1, keepdims=True)
    t_y = _best(lambda: ac.real_sph_harm(4, dirs), 1 if not quick else 2)
    _write(out, "integrals_speed.md",
           f"For the sun-lobe sky above: `diffuse_irradiance` at the default resolution "
           f"{_fmt_t(t_h)} (horizontal) and {_fmt_t(t_w)} (a wall); `sh_project(order=4)` "
           f"{_fmt_t(t_su)} (`domain=\"upper\"`) and {_fmt_t(t_ss)} (whole sphere); "
           f"`real_sph_harm(4, ·)` at {_pow10(n_big)} directions {_fmt_t(t_y)}.\n\n"
           + _timing_note("integrals").replace("best of the repeats stated", f"best of {rep} "
                                                 "calls after a warm-up"))


# ---------------------------------------------------------------------------------------------
# analytic skies
# ---------------------------------------------------------------------------------------------
def analytic(out: Path, quick: bool) -> None:
    import warnings

    import atmoscatter as ac
    from atmoscatter.sky.preetham import DEFAULT_WAVELENGTHS

    sys.path.insert(0, str(ROOT / "benchmarks"))
    import bench_analytic as ba

    rng = np.random.default_rng(3)
    n = 2000 if quick else 20_000
    Ts = (2.0, 6.0, 10.0) if quick else tuple(np.arange(2.0, 10.01, 1.0))
    suns = (0.0, 45.0, 90.0) if quick else tuple(np.arange(0.0, 90.01, 10.0))
    v = rng.normal(size=(n, 3))
    v[:, 2] = np.abs(v[:, 2])
    v /= np.linalg.norm(v, axis=1, keepdims=True)
    y_err, xy_pub, xy_exact, neg = 0.0, 0.0, 0.0, 0.0
    for T in Ts:
        for tsd in suns:
            sun = np.array([0.0, math.sin(math.radians(tsd)), math.cos(math.radians(tsd))])
            Yxy = ac.preetham_sky_Yxy(v, sun, T)
            for method in ("published", "exact"):
                with warnings.catch_warnings():
                    warnings.simplefilter("ignore", ac.PreethamValidityWarning)
                    L = ac.preetham_sky_spectral(v, sun, T, m_coefficients=method)
                XYZ = ac.spectral_to_XYZ(L, DEFAULT_WAVELENGTHS)
                y_err = max(y_err, float(np.max(np.abs(XYZ[:, 1] / Yxy[:, 0] - 1))))
                xy = XYZ[:, :2] / XYZ.sum(axis=1, keepdims=True)
                e = float(np.max(np.abs(xy - Yxy[:, 1:])))
                if method == "published":
                    xy_pub = max(xy_pub, e)
                    neg = min(neg, float(np.min(L.min(axis=1) / L.max(axis=1))))
                else:
                    xy_exact = max(xy_exact, e)
    _write(out, "analytic_spectral.md",
           f"Round trip (T = {Ts[0]:g}–{Ts[-1]:g}, θ_s = {suns[0]:g}–{suns[-1]:g}°, {_int(n)} "
           f"upper-hemisphere directions each, `ac.spectral_to_XYZ` on the default 5 nm grid): "
           f"Y to {_e(y_err)} relative; (x, y) to {_e(xy_pub)} with the printed `M1`, `M2` "
           f"formulas (`m_coefficients=\"published\"`, their 4-digit coefficients) and to "
           f"{_e(xy_exact)} with `m_coefficients=\"exact\"`.  The most negative violet value "
           f"of a spectrum is {neg * 100:.0f} % of its peak.".replace(" -", " −"))

    # float32 table path against the float64 formulas
    n32 = 10**4 if quick else 10**6
    v32 = ba.directions(n32, np.float32, seed=4)
    v32[:, 2] = rng.uniform(-0.2, 1.0, n32)  # include views below the horizon
    v32 /= np.linalg.norm(v32, axis=1, keepdims=True)
    v64 = v32.astype(np.float64)
    worst32, worst64 = 0.0, 0.0
    for T in (2.0, 3.0, 5.0, 10.0):
        for tsd in np.arange(0.0, 90.01, 10.0 if not quick else 45.0):
            sun = np.array([0.0, math.sin(math.radians(tsd)), math.cos(math.radians(tsd))])
            ref = ac.preetham_sky(v64, sun, T, backend="numpy")
            worst32 = max(worst32, float(np.max(np.abs(ac.preetham_sky(v32, sun, T) - ref)
                                                / np.abs(ref))))
            worst64 = max(worst64, float(np.max(np.abs(ac.preetham_sky(v64, sun, T) - ref)
                                                / np.abs(ref))))
    _write(out, "analytic_float32.md",
           f"Measured over T ∈ {{2, 3, 5, 10}}, θ_s ∈ {{0°, …, 90°}} and {_pow10(n32)} random "
           f"directions (a fifth of them below the horizon), XYZ against the float64 formulas "
           f"(`backend=\"numpy\"`): float32 kernel ≤ {_e(worst32)} relative, float64 kernel "
           f"≤ {_e(worst64)}.")

    # speed table (bench_analytic's cases)
    rep = 2 if quick else 7
    sizes = (10**3, 10**4) if quick else tuple(ba.SIZES)
    lines = ["| directions | NumPy float64 baseline | float64 kernel | float32 kernel | "
             "float32 speed-up |", "|---|---|---|---|---|"]
    for n_ in sizes:
        a64, a32 = ba.directions(n_), ba.directions(n_, np.float32)
        tb = _best(lambda a=a64: ba.baseline_rgb(a, ba.SUN, ba.TURBIDITY), rep)
        t64 = _best(lambda a=a64: ac.preetham_sky_rgb(a, ba.SUN, ba.TURBIDITY), rep)
        t32 = _best(lambda a=a32: ac.preetham_sky_rgb(a, ba.SUN, ba.TURBIDITY), rep)
        lines.append(f"| {_pow10(n_)} | {_rate(n_ / tb)} /s | {_rate(n_ / t64)} /s | {_rate(n_ / t32)} /s | "
                     f"{tb / t32:.1f}× |")
    one = ba.directions(1, np.float32)
    t1 = _best(lambda: ac.preetham_sky_rgb(one, ba.SUN, ba.TURBIDITY), 50 if not quick else 5)
    lines += ["", f"Per-call cost of the public function at one direction: {_fmt_t(t1)}.", "",
              _timing_note("analytic").replace("best of the repeats stated",
                                               f"Preetham → linear sRGB, random upper-hemisphere "
                                               f"directions, T = 3, θ_s = 50°, best of {rep}")]
    _write(out, "analytic_speed.md", "\n".join(lines))


# ---------------------------------------------------------------------------------------------
# sun position
# ---------------------------------------------------------------------------------------------
def _unix(t):
    return t.astype("datetime64[ns]").astype(np.int64) / 1e9


def _pvlib_spa(t, lat, lon, elev, pressure_pa, temp_c, delta_t):
    """pvlib.spa numpy SPA: (apparent zenith, true zenith, azimuth, eot) [deg, deg, deg, min]."""
    import pvlib

    n = np.broadcast(t, lat, lon, elev, pressure_pa, temp_c, delta_t).shape
    b = [np.broadcast_to(a, n).ravel() for a in (lat, lon, elev, pressure_pa, temp_c, delta_t)]
    tt = np.broadcast_to(t, n).ravel()
    theta, theta0, _, _, phi, eot = pvlib.spa.solar_position_numpy(
        _unix(tt), b[0], b[1], b[2], b[3] / 100.0, b[4], b[5], 0.5667, 1, sst=False, esd=False)
    return theta.reshape(n), theta0.reshape(n), phi.reshape(n), eot.reshape(n)


def _random_inputs(seed, n, start="1900-01-01", years=200):
    rng = np.random.default_rng(seed)
    t = np.datetime64(start, "s") + rng.integers(0, int(years * 365.25 * 86400), n).astype(
        "timedelta64[s]")
    return (t, rng.uniform(-90.0, 90.0, n), rng.uniform(-180.0, 180.0, n),
            rng.uniform(0.0, 5000.0, n), rng.uniform(60000.0, 105000.0, n),
            rng.uniform(-30.0, 40.0, n))


def _angle_deg(a, b):
    return np.rad2deg(np.arccos(np.clip(np.sum(a * b, axis=-1), -1.0, 1.0)))


def sun(out: Path, quick: bool) -> None:
    import atmoscatter as ac
    import atmoscatter.sun as S

    try:
        import pandas as pd
        import pvlib
    except ImportError:
        _write(out, "sun_accuracy.md", "**Not generated**: pvlib (test extra) is not installed.")
        return
    rows = []
    # random times over two centuries: default ΔT (shipped node table) and an explicit ΔT
    n = 500 if quick else 5000
    t, lat, lon, elev, pres, temp = _random_inputs(1, n)
    dts = S.default_delta_t(t)
    app, _, azi, eot = _pvlib_spa(t, lat, lon, elev, pres, temp, dts)
    for label, kw in (("default ΔT (shipped node table)", {}),
                      ("explicit ΔT array (direct SPA)", {"delta_t": dts})):
        sp = S.sun_position(t, lat, lon, elevation=elev, pressure=pres, temperature=temp, **kw)
        daz = (np.rad2deg(sp.azimuth) - azi + 180.0) % 360.0 - 180.0
        rows.append((f"pvlib `spa.solar_position_numpy`, {label}",
                     f"{_int(n)} random times 1900–2100, random sites 0–5000 m, random P, T",
                     f"zenith {_e(np.max(np.abs(np.rad2deg(sp.zenith) - app)))}°, azimuth × "
                     f"sin z {_e(np.max(np.abs(daz * np.sin(sp.true_zenith))))}°, EoT "
                     f"{_e(np.max(np.abs(sp.equation_of_time - eot)))} min"))
    # interpolated path: dense times (2 years)
    n = 20_000 if quick else 200_000
    t, lat, lon, elev, pres, temp = _random_inputs(2, n, start="2023-06-01", years=2)
    sp = S.sun_position(t, lat, lon, elevation=elev, pressure=pres, temperature=temp)
    app, _, azi, _ = _pvlib_spa(t, lat, lon, elev, pres, temp, S.default_delta_t(t))
    daz = (np.rad2deg(sp.azimuth) - azi + 180.0) % 360.0 - 180.0
    rows.append(("pvlib, dense batch (interpolated time terms)",
                 f"{_int(n)} random times in 2023–2025, random sites",
                 f"zenith {_e(np.max(np.abs(np.rad2deg(sp.zenith) - app)))}°, azimuth × sin z "
                 f"{_e(np.max(np.abs(daz * np.sin(sp.true_zenith))))}°"))
    # sunrise/sunset geometry
    rng = np.random.default_rng(6)
    n = 200 if quick else 2000
    dates = np.datetime64("1950-01-01") + rng.integers(0, 150 * 365, n).astype("timedelta64[D]")
    lat, lon = rng.uniform(-60, 60, n), rng.uniform(-180, 180, n)
    r = S.sunrise_sunset(dates, lat, lon)
    ok = ~(r.polar_day | r.polar_night)
    dts = S.default_delta_t(dates)
    worst = 0.0
    for ev in (r.sunrise, r.sunset):
        _, true, _, _ = _pvlib_spa(ev[ok], lat[ok], lon[ok], 0.0, 0.0, 12.0, dts[ok])
        worst = max(worst, float(np.max(np.abs(90.0 - true + 0.8333))))
    rows.append(("sunrise/sunset: pvlib true elevation (0 m) at our event times",
                 f"{_int(n)} random dates 1950–2100, \\|lat\\| ≤ 60°",
                 f"{worst:.4f}° from −0.8333° (the parallax of at most 8.8″ is neglected)"))
    # rise/set/transit against pvlib's SPA A.2
    dates = np.datetime64("2020-01-01") + np.arange(0, 366, 5).astype("timedelta64[D]")
    times = pd.DatetimeIndex(dates.astype("datetime64[ns]")).tz_localize("UTC")
    ref = pvlib.solarposition.sun_rise_set_transit_spa(times, 40.0, 5.0, delta_t=None)
    r = S.sunrise_sunset(dates, 40.0, 5.0)
    worst = 0.0
    for ours, col in ((r.sunrise, "sunrise"), (r.sunset, "sunset"), (r.noon, "transit")):
        theirs = ref[col].dt.tz_convert("UTC").dt.tz_localize(None).to_numpy()
        diff = (ours - theirs.astype("datetime64[ms]")).astype(float) / 1e3
        worst = max(worst, float(np.max(np.abs(diff))))
    rows.append(("sunrise/sunset/transit vs pvlib `sun_rise_set_transit_spa` (40° N, 5° E, "
                 "2020)", f"{len(dates)} days", f"{worst:.2f} s"))
    # Iqbal against the SPA
    n = 20_000 if quick else 200_000
    rng = np.random.default_rng(5)
    t = np.datetime64("2011-01-01", "s") + rng.integers(0, 365 * 86400, n).astype(
        "timedelta64[s]")
    lat, lon = rng.uniform(-60, 60, n), rng.uniform(-180, 180, n)
    iq = {}
    for refr in (False, True):
        a = S.sun_position(t, lat, lon, refraction=refr)
        b = S.sun_position(t, lat, lon, refraction=refr, method="iqbal")
        up = a.zenith < np.pi / 2
        ez = np.rad2deg(np.abs(a.zenith - b.zenith))[up]
        ed = _angle_deg(a.direction, b.direction)[up]
        iq[refr] = (ez.max(), np.sqrt(np.mean(ez**2)), ed.max(), np.sqrt(np.mean(ed**2)), a, b)
    a, b = iq[False][4], iq[False][5]
    ddec = np.rad2deg(np.max(np.abs(a.declination - b.declination)))
    deot = np.max(np.abs(a.equation_of_time - b.equation_of_time))
    dr = np.max(np.abs(a.earth_sun_distance - b.earth_sun_distance))
    zmax, zrms, dmax, drms = iq[False][:4]
    rz, rrms = iq[True][:2]
    rows.append(("`\"iqbal\"` vs `\"spa\"`", f"{_int(n)} random times in 2011, \\|lat\\| ≤ 60°, "
                 "sun above the horizon",
                 f"true zenith {zmax:.2f}° (RMS {zrms:.2f}°), direction {dmax:.2f}° (RMS "
                 f"{drms:.2f}°), apparent (refracted) zenith {rz:.2f}° (RMS {rrms:.2f}°), "
                 f"δ {ddec:.2f}°, EoT {deot:.1f} min, r {_e(dr)} AU"))
    lines = ["| Comparison | Cases | Max error |", "|---|---|---|"]
    lines += [f"| {c} | {k} | {e} |" for c, k, e in rows]
    lines += ["", f"pvlib {pvlib.__version__}; fixed seeds.  The apparent zenith of the "
              "`\"iqbal\"` row is larger than the true one because both methods refract their "
              "own zenith, and refraction grows steeply toward the horizon."]
    _write(out, "sun_accuracy.md", "\n".join(lines))
    _write(out, "sun_iqbal_error.md",
           f"Zenith ≤ {zmax:.2f}° (RMS {zrms:.2f}°) unrefracted, ≤ {rz:.2f}° refracted; "
           f"direction ≤ {dmax:.2f}° (RMS {drms:.2f}°) ({_int(n)} random times in 2011, "
           f"\\|lat\\| ≤ 60°, sun above the horizon).")
    del ac


def sun_table1(out: Path, quick: bool) -> None:
    """Seed 003 Table 1 (sunrise/sunset at UTM, 2011): the table ``tests/test_sun.py`` asserts."""
    sys.path.insert(0, str(ROOT / "tests"))
    import test_sun as ts

    dates = ts._table1_dates()
    ours = ts._table1_minutes(1.28, 103.45)
    campus = ts._table1_minutes(1.5594, 103.6386)
    cols, worst, worst_soft, worst_campus = {}, 0.0, 0.0, 0.0
    for ev in ("rise", "set"):
        real = ts._minutes(ts.SEED_T1[f"{ev}_real"]) + 0.5  # truncated minutes: the middle
        soft = ts._minutes(ts.SEED_T1[f"{ev}_soft"])
        cols[ev] = (ours[ev] - real, campus[ev] - real, soft - (real - 0.5))
        worst = max(worst, float(np.abs(cols[ev][0]).max()))
        worst_campus = max(worst_campus, float(np.abs(cols[ev][1]).max()))
        worst_soft = max(worst_soft, float(np.abs(cols[ev][2]).max()))
    lines = [f"At the stated site our error is at most **{worst:.1f} min** on every row "
             f"(asserted ≤ 2 min); at the campus' actual position every row is within "
             f"±{worst_campus:.2f} min of the middle of the printed minute; the seed software's "
             f"error reaches **{worst_soft:.0f} min**.", "",
             "| Date | rise: ours | rise: campus | rise: seed sw | set: ours | set: campus | "
             "set: seed sw |", "|---|---|---|---|---|---|---|"]
    def sg(x, digits):
        return f"{x:+.{digits}f}".replace("-", "−")

    for i, d in enumerate(dates):
        r, st = cols["rise"], cols["set"]
        lines.append(f"| {str(d)[5:]} | {sg(r[0][i], 2)} | {sg(r[1][i], 2)} | {sg(r[2][i], 0)} | "
                     f"{sg(st[0][i], 2)} | {sg(st[1][i], 2)} | {sg(st[2][i], 0)} |")
    _write(out, "sun_table1.md", "\n".join(lines))


def sun_speed(out: Path, quick: bool) -> None:
    """Throughput against pvlib's SPA and ephemeris (``benchmarks/bench_sun.py``'s cases),
    the implementations alternated so that a change of load hits all of them."""
    import atmoscatter as ac

    sys.path.insert(0, str(ROOT / "benchmarks"))
    try:
        import bench_sun as bs
    except Exception:  # pytest.importorskip: pvlib/pandas missing  # noqa: BLE001
        _write(out, "sun_speed.md", "**Not generated**: pvlib (test extra) is not installed.")
        return
    import pandas as pd
    import pvlib

    cases = [("hourly", 10**4), ("random", 10**4)] if quick else bs.CASES
    # first call in this process (shipped node table read, nothing cached) vs later calls
    t_first_case = bs._times("random", cases[-2][1] if not quick else 10**4)
    rng = np.random.default_rng(7)
    lat1, lon1 = rng.uniform(-60, 60, len(t_first_case)), rng.uniform(-180, 180,
                                                                       len(t_first_case))
    t0 = time.perf_counter()
    ac.sun_position(t_first_case, lat1, lon1)
    first = time.perf_counter() - t0
    later = _best(lambda: ac.sun_position(t_first_case, lat1, lon1), 3)
    impls = {
        "ours": lambda t, idx: ac.sun_position(t, bs.LAT, bs.LON),
        "nrel": lambda t, idx: pvlib.solarposition.spa_python(idx, bs.LAT, bs.LON, how="numpy",
                                                               delta_t=None),
        "eph": lambda t, idx: pvlib.solarposition.ephemeris(idx, bs.LAT, bs.LON),
    }
    lines = ["| Case | atmoscatter `spa` | pvlib `spa_python(how=\"numpy\")` | ratio | "
             "pvlib `ephemeris` | ephemeris − SPA, max zenith |", "|---|---|---|---|---|---|"]
    for kind, n in cases:
        t = bs._times(kind, n)
        idx = pd.DatetimeIndex(t).tz_localize("UTC")
        best = dict.fromkeys(impls, math.inf)
        reps = 1 if quick else (5 if n <= 100_000 else 2)
        for _ in range(reps):
            for name, fn in impls.items():
                t0 = time.perf_counter()
                fn(t, idx)
                best[name] = min(best[name], time.perf_counter() - t0)
        ours = ac.sun_position(t, bs.LAT, bs.LON)
        eph = pvlib.solarposition.ephemeris(idx, bs.LAT, bs.LON)
        up = ours.zenith < np.pi / 2
        dz = np.max(np.abs(eph["apparent_zenith"].to_numpy() - np.rad2deg(ours.zenith))[up])
        label = f"{_pow10(n)} {'hourly timestamps' if kind == 'hourly' else 'random times 1900–2100'}"
        lines.append(f"| {label} | {_fmt_t(best['ours'])} | {_fmt_t(best['nrel'])} | "
                     f"**{best['nrel'] / best['ours']:.1f}×** | {_fmt_t(best['eph'])} | "
                     f"{dz:.3f}° |")
    nt, ns = (240, 50) if quick else (8760, 1000)
    tg = np.datetime64("2024-01-01T00:00", "ns") + np.arange(nt) * np.timedelta64(1, "h")
    lat, lon = rng.uniform(-60, 60, ns), rng.uniform(-180, 180, ns)
    t_grid = _best(lambda: ac.sun_position(tg[:, None], lat, lon), 1 if quick else 3)
    nd = 30 if quick else 366
    dates = np.datetime64("2024-01-01") + np.arange(nd).astype("timedelta64[D]")
    lat, lon = rng.uniform(-70, 70, ns), rng.uniform(-180, 180, ns)
    t_rs = _best(lambda: ac.sunrise_sunset(dates[:, None], lat, lon), 1 if quick else 3)
    lines += [f"| {nt} hours × {ns} sites ({_int(nt * ns)} positions) | {_fmt_t(t_grid)} | — | | | |",
              f"| `sunrise_sunset`, {nd} days × {ns} sites | {_fmt_t(t_rs)} | — | | | |", "",
              f"One site ({bs.LAT}°, {bs.LON}°), default ΔT; each cell the best of the "
              f"alternated repeats.  {_pow10(len(t_first_case))} random times 1900–2100 at "
              f"random sites: {_fmt_t(first)} for the first call of the process (reads the "
              f"shipped node table), {_fmt_t(later)} for later calls (nodes cached).", "",
              _timing_note("sun_speed").replace("; best of the repeats stated", "")]
    _write(out, "sun_speed.md", "\n".join(lines))


# ---------------------------------------------------------------------------------------------
# oracle: cost of compare
# ---------------------------------------------------------------------------------------------
def oracle(out: Path, quick: bool) -> None:
    import atmoscatter as ac

    w, h = (128, 64) if quick else (1024, 512)
    lines = []
    with tempfile.TemporaryDirectory() as tmp:
        os.environ["ATMOSCATTER_CACHE_DIR"] = os.path.join(tmp, "cache")
        scene = ac.Scene(width=w, height=h)
        theirs = os.path.join(tmp, "theirs.exr")
        ac.write_exr(theirs, ac.render(scene))
        res = None

        def run():
            nonlocal res
            res = ac.compare_exr(theirs, scene)
        t_cmp = _best(run, 2 if quick else 3)
        t_wr = _best(lambda: res.write(os.path.join(tmp, "report")), 2 if quick else 3)
        lines.append(f"`compare_exr` on a {w}×{h} lat-long map with the Preetham reference: "
                     f"{_fmt_t(t_cmp)} (render, colour conversion, statistics and ΔE00), "
                     f"`write` {_fmt_t(t_wr)}.")
        if not quick:
            ms = scene.replace_from_strings(["model=multiple_scattering", "width=64",
                                             "height=32"])
            ac.write_exr(theirs, ac.render(scene.replace_from_strings(["width=64",
                                                                        "height=32"])))
            t0 = time.perf_counter()
            ac.compare_exr(theirs, ms)
            t_first = time.perf_counter() - t0
            t_warm = _best(lambda: ac.compare_exr(theirs, ms), 2)
            n_sky = 64 * 32 // 2
            lines.append(f"With `multiple_scattering` at 64×32 the render dominates: "
                         f"{_fmt_t(t_first)} for the first call with an empty cache (the "
                         f"scattering field of the atmosphere is computed once and cached), "
                         f"then {_fmt_t(t_warm)} ({_fmt_t(t_warm / n_sky)} per sky "
                         f"direction).")
    lines += ["", _timing_note("oracle").replace(
        "best of the repeats stated", f"best of {2 if quick else 3} calls after a warm-up; "
        "the first multiple-scattering call timed once")]
    _write(out, "oracle_cost.md", "\n".join(lines))


# ---------------------------------------------------------------------------------------------
# render: time per model
# ---------------------------------------------------------------------------------------------
def render(out: Path, quick: bool) -> None:
    import atmoscatter as ac

    sys.path.insert(0, str(ROOT / "benchmarks"))
    from bench_analytic import directions

    fast = ("preetham", "cie_overcast", "cie_clear", "hoffman_preetham")
    # the quick mode leaves out multiple scattering: its warm-up builds the field (minutes)
    slow = ("single_scattering",) if quick else ("single_scattering", "multiple_scattering")
    sizes_fast = (10**3, 10**4) if quick else (10**4, 10**5, 10**6)
    sizes_slow = (10**3,) if quick else (10**4, 10**5)
    rep = 2 if quick else 5
    cols = sorted(set(sizes_fast) | set(sizes_slow))
    lines = ["| model | " + " | ".join(_pow10(n) for n in cols) + " | per direction at the "
             "largest |", "|---" * (len(cols) + 2) + "|"]
    with tempfile.TemporaryDirectory() as tmp:
        os.environ["ATMOSCATTER_CACHE_DIR"] = os.path.join(tmp, "cache")
        for model in fast + slow:
            scene = ac.Scene(model=model, turbidity=3.0, sun_elevation_deg=50.0,
                             sun_azimuth_deg=180.0, sampling="rgb")
            sizes = sizes_fast if model in fast else sizes_slow
            cells, last = [], None
            for n in cols:
                if n not in sizes:
                    cells.append("—")
                    continue
                d = directions(n, np.float32, seed=1)
                t = _best(lambda d=d, s=scene: ac.render(s, directions=d),
                          rep if model in fast else 1)
                cells.append(_fmt_t(t))
                last = (t, n)
            lines.append(f"| `{model}` | " + " | ".join(cells)
                         + f" | {_fmt_t(last[0] / last[1])} |")
    lines += ["", "`render(scene, directions=d)` for d random upper-hemisphere directions "
              "(float32), linear sRGB out, sun 50° high, turbidity 3, `sampling=\"rgb\"`; "
              "after one warm-up call (JIT compilation, and for `multiple_scattering` the "
              "field, which is computed once per atmosphere and then cached).", "",
              _timing_note("render").replace("best of the repeats stated",
                                             f"best of {rep} (analytic models) or of 1 "
                                             "(numerical models)")]
    _write(out, "render_speed.md", "\n".join(lines))


def render_overhead(out: Path, quick: bool) -> None:
    """The evaluator's overhead over calling Preetham directly (``benchmarks/bench_render.py``'s
    ``test_evaluator_overhead``, whose target is < 10 %), and the evaluator alone."""
    import atmoscatter as ac
    from atmoscatter.render.models import ModelAdapter, register_model, unregister_model

    sys.path.insert(0, str(ROOT / "benchmarks"))
    import bench_render as br

    n = 10**4 if quick else 10**6
    rep = 3 if quick else 9
    d = br.upper_directions(n)
    register_model(ModelAdapter(name="bench_null", description="no-cost model",
                                prepare=br._null_prepare), replace=True)
    try:
        null_scene = br.scene_for("bench_null")
        t_eval = _best(lambda: ac.render(null_scene, directions=d), rep)
    finally:
        unregister_model("bench_null")
    xyz = ac.preetham_sky(d, br.SUN, 3.0)
    t_model = _best(lambda: ac.preetham_sky(d, br.SUN, 3.0), rep)
    t_conv = _best(lambda: ac.XYZ_to_linear_rgb(xyz).astype(np.float32), rep)
    overhead = (t_eval - t_conv) / (t_model + t_conv)
    sign = f"{overhead * 100:+.1f}".replace("-", "−")
    _write(out, "render_overhead.md",
           f"The evaluator alone (a model that costs nothing, same float32 RGB output, its own "
           f"XYZ → RGB step included): {_fmt_t(t_eval)} per {_pow10(n)} caller-given "
           f"directions.  A direct call: `preetham_sky` {_fmt_t(t_model)}, then "
           f"`XYZ_to_linear_rgb` and the float32 cast {_fmt_t(t_conv)}.  The overhead as "
           f"`benchmarks/bench_render.py::test_evaluator_overhead` defines it, (evaluator − "
           f"direct conversion) / direct call: {sign} % (target < 10 %, asserted there)."
           + (" Negative: the evaluator alone took less time than the direct call's "
              "conversion step (or the machine's load changed between the separately timed "
              "pieces)." if overhead < 0 else "")
           + "\n\n"
           + _timing_note("render_overhead").replace("best of the repeats stated",
                                                      f"best of {rep} each"))


def aerial(out: Path, quick: bool) -> None:
    """``aerial_perspective`` on a depth buffer (``benchmarks/bench_analytic.py``'s case)."""
    import atmoscatter as ac

    sys.path.insert(0, str(ROOT / "benchmarks"))
    import bench_analytic as ba

    H, W = (135, 240) if quick else (1080, 1920)
    rng = np.random.default_rng(0)
    L0 = rng.uniform(0.0, 2e3, (H, W, 3)).astype(np.float32)
    depth = rng.uniform(0.0, 3e4, (H, W))
    rep = 2 if quick else 5
    t = _best(lambda: ac.aerial_perspective(L0, depth, np.array([0.0, 1.0, 0.05]), ba.SUN), rep)
    _write(out, "aerial_speed.md",
           f"Measured: {W} × {H} depth buffer with one view direction, float32 `L0`: "
           f"{_fmt_t(t)} ({_rate(H * W / t)} pixels/s).\n\n"
           + _timing_note("aerial").replace("best of the repeats stated",
                                            f"best of {rep} after a warm-up"))


SECTIONS = {"integrals": integrals, "analytic": analytic, "sun": sun, "sun_table1": sun_table1,
            "sun_speed": sun_speed, "oracle": oracle, "render": render,
            "render_overhead": render_overhead, "aerial": aerial}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="small problems (CI smoke run)")
    ap.add_argument("--out", default=None, help="output directory (default docs/numbers)")
    ap.add_argument("--only", nargs="+", choices=sorted(SECTIONS), help="run only these")
    args = ap.parse_args(argv)
    if args.quick and not args.out:
        ap.error("--quick writes only into --out (its numbers are not for publishing)")
    out = Path(args.out) if args.out else OUT
    for name in args.only or SECTIONS:
        t0 = time.perf_counter()
        saved = os.environ.get("ATMOSCATTER_CACHE_DIR")  # sections point it at temp dirs
        try:
            SECTIONS[name](out, args.quick)
        finally:
            if saved is None:
                os.environ.pop("ATMOSCATTER_CACHE_DIR", None)
            else:
                os.environ["ATMOSCATTER_CACHE_DIR"] = saved
        print(f"{name}: {time.perf_counter() - t0:.1f} s", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())

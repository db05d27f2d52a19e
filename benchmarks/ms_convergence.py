"""Error against run time of multiple scattering (issue 10, part 4).

Usage (from the repository root)::

    PYTHONPATH=. python benchmarks/ms_convergence.py            # full study -> docs/convergence/
    PYTHONPATH=. python benchmarks/ms_convergence.py --quick    # smoke run (tiny grids) -> a temp dir

For canonical scenes, :func:`atmoscatter.multiple_scattering` on its default grid
(:data:`~atmoscatter.sky.multiple.MULTIPLE_SCATTERING_GRID`) and on grids that vary one
knob at a time is compared with the *same method on a much finer grid* (the reference;
its independence from our code is established by the DISORT and Monte Carlo tests,
``tests/test_rt_benchmarks.py`` and ``tests/test_montecarlo.py``, whose tables
``scripts/ms_reference_check.py`` prints).

The field of a grid over every sun (``sun_nodes="all"``, the ``table`` grid and the
reference) depends only on (atmosphere, grid, ground albedo, orders/tolerance), so it is
built once per atmosphere and every scene of that atmosphere is evaluated from it; a grid
centred on the scene's sun (the default) builds one field per scene, and its build time is
the slowest scene's (:func:`evaluate`).  The on-disk cache is disabled
(``ATMOSCATTER_CACHE_DIR=off``) and the in-process caches are cleared before every
build, so the build time is that of a first call.

Writes ``ms_convergence.csv``, ``ms_convergence_table.md`` and ``ms_convergence.png``; the
full run also replaces the generated block of ``docs/convergence.md`` (with the worst
default-grid errors per sun / observer regime).  The reference is the one of
``benchmarks/ms_accurate_grid.py`` (which measures the figures the EXR header quotes,
``atmoscatter/data/ms_accuracy.json``): finer than every named grid and every value of
the sweep in every knob but one — in daylight its solar-zenith nodes are farther apart
than those of the grids centred on the scene's sun (:data:`REFERENCE_NOTE`).  Its radiances
are kept in ``docs/convergence/ms_reference_values.npz`` (:func:`reference_values`), so the
full run takes a few minutes on the 2-core machine while the method is unchanged (about
30 minutes more when the reference must be built again); ``--quick`` (tiny grids, two
scenes) well under a minute.
"""

from __future__ import annotations

import os

os.environ["ATMOSCATTER_CACHE_DIR"] = "off"  # honest timings: no persistent cache

import argparse  # noqa: E402
import csv  # noqa: E402
import sys  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402
from dataclasses import replace  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

import atmoscatter  # noqa: E402
from atmoscatter import earth_turbidity_atmosphere, mars_atmosphere  # noqa: E402
from atmoscatter.sky import multiple as ms  # noqa: E402
from atmoscatter.sky.multiple import MultipleScatteringGrid  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]

ATMOSPHERES = {
    "earth_t1.5": lambda: earth_turbidity_atmosphere(1.5),
    "earth_t2.5": lambda: earth_turbidity_atmosphere(2.5),
    "earth_t6": lambda: earth_turbidity_atmosphere(6.0),
    "earth_t10": lambda: earth_turbidity_atmosphere(10.0),
    "mars": lambda: mars_atmosphere(),
}

_GROUND_ZENITH = (0, 15, 30, 45, 60, 70, 78, 84, 87, 88.5, 89.3, 89.8)
_ELEVATED_ZENITH = (0, 20, 40, 60, 75, 85, 89, 91, 93, 95, 100, 120)
# from 500 km: the top of the atmosphere (60 km) is tangent at zenith 110.7°, the
# ground at 112.0°; rays from 110.8° to 111.9° cross the limb, beyond hit the planet
_LIMB_ZENITH = (110.8, 110.9, 111.0, 111.1, 111.2, 111.35, 111.5, 111.65, 111.8, 111.9,
                112.1, 112.5)
AZIMUTHS = (0, 36, 72, 108, 144, 180)  # [deg] from the solar vertical (symmetric sky)

#: scene -> (atmosphere, sun elevation [deg], observer altitude [m], view zenith angles [deg])
SCENES = {
    "clear_noon": ("earth_t2.5", 60.0, 0.0, _GROUND_ZENITH),
    "clear_t1.5_low_sun": ("earth_t1.5", 5.0, 0.0, _GROUND_ZENITH),
    "hazy_t6": ("earth_t6", 45.0, 0.0, _GROUND_ZENITH),
    "hazy_t10": ("earth_t10", 20.0, 0.0, _GROUND_ZENITH),
    "sunset": ("earth_t2.5", 2.0, 0.0, _GROUND_ZENITH),
    "civil_twilight": ("earth_t2.5", -6.0, 0.0, _GROUND_ZENITH),
    "nautical_twilight": ("earth_t2.5", -10.0, 0.0, _GROUND_ZENITH),
    "deep_twilight": ("earth_t2.5", -15.0, 0.0, _GROUND_ZENITH),
    "observer_12km": ("earth_t2.5", 30.0, 12e3, _ELEVATED_ZENITH),
    "space_limb": ("earth_t2.5", 10.0, 500e3, _LIMB_ZENITH),
    # the sun high seen from space (its grid takes space_day_n_sun)
    "space_limb_day": ("earth_t2.5", 45.0, 500e3, _LIMB_ZENITH),
    "mars": ("mars", 30.0, 0.0, _GROUND_ZENITH),
    # the sun at the terminator, seen from the ground, from 12 km and from space: measured
    # on the default grid (and the named grids of ms_accurate_grid.py), not swept
    "sun_at_horizon": ("earth_t2.5", 0.0, 0.0, _GROUND_ZENITH),
    "early_civil_twilight": ("earth_t2.5", -3.0, 0.0, _GROUND_ZENITH),
    "observer_12km_sunset": ("earth_t2.5", 2.0, 12e3, _ELEVATED_ZENITH),
    "space_limb_twilight": ("earth_t2.5", -4.0, 500e3, _LIMB_ZENITH),
    # the ends of nautical and astronomical twilight (the bounds stop at −12°; the
    # error from −12° to −18° is published): measured on the default grid, not swept
    "nautical_twilight_end": ("earth_t2.5", -12.0, 0.0, _GROUND_ZENITH),
    "astronomical_twilight_end": ("earth_t2.5", -18.0, 0.0, _GROUND_ZENITH),
}
#: the scenes of the one-knob sweep (the others: default grid only, the table's row
#: ``default``)
SWEEP_SCENES = ("clear_noon", "sunset", "civil_twilight", "nautical_twilight", "deep_twilight",
                "observer_12km", "space_limb", "space_limb_day")

DEFAULT = (ms.MULTIPLE_SCATTERING_GRID, ms.DEFAULT_ORDER_TOLERANCE)
#: finer than every named grid in every knob but the solar zenith in daylight (see
#: REFERENCE_NOTE), and than every value of the sweep: shared with ``ms_accurate_grid.py``
REFERENCE = (MultipleScatteringGrid(n_altitude=36, n_sun=64, n_mu=40, n_phi=25, order=4), 1e-5)
def _reference_note(reference=REFERENCE[0], grids=(ms.MULTIPLE_SCATTERING_GRID,
                                                   ms.ACCURATE_MULTIPLE_SCATTERING_GRID)) -> str:
    """What the reference is finer in, with the solar-zenith spacings computed from the
    grids: the reference's nodes cover every sun, dense at twilight but sparse in daylight
    (solar zenith below 50°), where the grids centred on the sun are denser at it (the
    spacings within 6° of suns 5–60° high; the n_sun sweep shows what that knob moves)."""
    ref = np.degrees(reference.sun_zenith_nodes())
    mid = 0.5 * (ref[1:] + ref[:-1])
    ref_day = float(np.max(np.diff(ref)[mid < 50.0]))
    near = []
    for g in grids:
        for zenith in (30.0, 45.0, 60.0, 70.0, 85.0):
            n = np.degrees(g.for_sun(zenith).sun_zenith_nodes())
            m = 0.5 * (n[1:] + n[:-1])
            near.extend(np.diff(n)[np.abs(m - zenith) < 6.0])
    return ("finer than every named grid in altitude, view zenith, azimuth and Gauss "
            f"order; in solar zenith finer at twilight, but {ref_day:.2g}° apart in daylight "
            f"where the grids centred on the sun are {min(near):.2g}–{max(near):.2g}° apart "
            "at it")


#: scenes with the sun at or below this elevation [deg] are measured against a reference
#: centred on their own sun (REFERENCE's other knobs and tolerance, CENTRED_N_SUN solar-zenith
#: nodes within its sun_width): there the nodes of REFERENCE, which cover every sun, are
#: 1.1–2.9° apart, and it was 0.8 %, 1.7 % and 12 % off at sun −12°, −15° and −18°, where
#: centred references with 48 and 64 nodes agree to 0.2 % (docs/convergence/ms_deep_twilight.md)
CENTRED_BELOW = -12.0
CENTRED_N_SUN = 64


def centred(reference, n_sun):
    """The reference ``(grid, tolerance)`` with its solar-zenith nodes centred on the
    scene's sun: ``n_sun`` of them for a sun near the horizon."""
    grid, tol = reference
    return replace(grid, sun_nodes="scene", n_sun=n_sun, horizon_n_sun=n_sun), tol


REFERENCE_NOTE = (_reference_note() + f"; for a sun at or below {CENTRED_BELOW:g}° the same "
                  f"knobs centred on the scene's sun, {CENTRED_N_SUN} solar-zenith nodes")
#: the reference radiances of the full run's scenes, kept between runs (the reference
#: does not depend on the grids measured against it; about 30 minutes of builds): a run
#: reuses them while the method (field version), the reference grid, the atmospheres and
#: the scene geometry are unchanged, and recomputes and stores them otherwise
REFERENCE_STORE = ROOT / "docs" / "convergence" / "ms_reference_values.npz"
#: values around the default grid (centred on the scene's sun: n_sun counts the nodes of
#: one sun's field); none equals the reference's (a knob equal to it would show no error)
KNOBS = {
    "n_sun": (10, 16, 24),
    "n_mu": (24, 32, 36),
    "n_phi": (13, 17, 19, 21),
    "space_n_mu": (32, 36),
    "space_day_n_sun": (10, 16),
    "horizon_n_sun": (16, 24),
    "horizon_n_phi": (13, 17, 19, 21),
    "n_altitude": (24, 32),
    "order": (2, 3),
    "order_tolerance": (1e-2, 1e-3, 1e-4),
    # orders ≥ 3 only in the band of sun nodes around the scene's sun (the default), or
    # every order at every node ("off")
    "band_orders_from": (3, "off"),
    # half-width of that band [deg] (the default: 6; below TWILIGHT_BAND_ELEVATION the
    # grid's sun_width, 12, whatever this says)
    "band_width": (6, 12),
}


def _near_horizon(name):
    """Whether scene ``name``'s grid takes the default's ``horizon_*`` knobs (an observer
    inside the atmosphere, the sun within ``HORIZON_SUN_ELEVATION``)."""
    _, elevation, altitude, _ = SCENES[name]
    lo, hi = ms.HORIZON_SUN_ELEVATION
    return altitude <= 100e3 and lo <= elevation <= hi


#: knobs that change only some scenes' grids: the other scenes are not recomputed for them
#: (their values are the default's; the table shows "—"); n_sun and n_phi do not reach the
#: scenes near the horizon, whose grids take horizon_n_sun and horizon_n_phi instead, nor
#: n_mu the observers above the atmosphere (space_n_mu), nor n_sun those with the sun
#: high (space_day_n_sun)
def _space_day(name):
    """Whether scene ``name``'s grid takes the default's ``space_day_n_sun`` (an observer
    above the atmosphere, the sun at least ``SPACE_DAY_ELEVATION`` up)."""
    _, elevation, altitude, _ = SCENES[name]
    return altitude > 100e3 and elevation >= ms.SPACE_DAY_ELEVATION


KNOB_SCENES = {
    "n_sun": lambda name: not (_near_horizon(name) or _space_day(name)),
    "space_day_n_sun": _space_day,
    "n_phi": lambda name: not _near_horizon(name),
    "n_mu": lambda name: SCENES[name][2] <= 100e3,
    "space_n_mu": lambda name: SCENES[name][2] > 100e3,
    "horizon_n_sun": _near_horizon,
    "horizon_n_phi": _near_horizon,
    # (from space both widen by the observer's dip: MultipleScatteringGrid.for_sun)
    "band_width": lambda name: SCENES[name][1] >= ms.TWILIGHT_BAND_ELEVATION,
}
#: atmospheres of the one-knob sweep in the full run (the others: default grid only)
SWEEP_ATMOSPHERES = ("earth_t2.5",)

QUICK_DEFAULT = (MultipleScatteringGrid(n_altitude=4, n_sun=6, n_mu=4, n_phi=3, order=2,
                                        sun_nodes="scene"), 1e-2)
QUICK_REFERENCE = (MultipleScatteringGrid(n_altitude=6, n_sun=10, n_mu=6, n_phi=5, order=2), 1e-3)
QUICK_KNOBS = {"n_sun": (4, 6), "n_mu": (4, 6)}

FLOOR = 1e-6  # directions whose total is below FLOOR x the scene maximum are ignored

#: regimes of the EXR header's statement (sun elevation [deg]; observer)
SUN_REGIMES = {
    "above_10": "sun more than 10° above the horizon",
    "0_to_10": "sun 0–10° above the horizon",
    "0_to_-6": "sun 0–6° below the horizon",
    "-6_to_-12": "sun 6–12° below the horizon",
    "below_-12": "sun more than 12° below the horizon",
}
OBSERVER_REGIMES = {
    "ground": "observer on the ground",
    "elevated": "observer inside the atmosphere above the ground",
    "space": "observer above the atmosphere",
}


def sun_regime(elevation_deg: float) -> str:
    """Sun regime of an elevation [deg] (boundaries belong to the regime nearer 0°)."""
    e = float(elevation_deg)
    if e > 10.0:
        return "above_10"
    if e > 0.0:
        return "0_to_10"
    if e >= -6.0:
        return "0_to_-6"
    if e >= -12.0:
        return "-6_to_-12"
    return "below_-12"


def observer_regime(altitude_m: float, top_altitude_m: float) -> str:
    """Observer regime: ground (< 1 m), elevated (below the top), space."""
    if altitude_m < 1.0:
        return "ground"
    return "elevated" if altitude_m < top_altitude_m else "space"


def scene_geometry(name):
    _, elev, alt, zeniths = SCENES[name]
    e = np.radians(elev)
    sun = np.array([0.0, np.cos(e), np.sin(e)])
    th = np.radians(np.asarray(zeniths, float))[:, None]
    ph = np.radians(np.asarray(AZIMUTHS, float))[None, :]
    v = np.stack([np.sin(th) * np.sin(ph), np.sin(th) * np.cos(ph), np.cos(th) + 0 * ph], -1)
    return v.reshape(-1, 3), sun, alt


def clear_caches():
    ms._clear_process_caches(single=False)


def evaluate(atm, scenes, config):
    """Build the field of ``config`` (timed: first call) and evaluate every scene.

    A grid over every sun (``sun_nodes="all"``) builds one field for all the scenes: the
    build time is the first call's.  A grid centred on the scene's sun
    (``sun_nodes="scene"``) builds a field per scene, so every call is a first call
    (caches cleared before each): the build time is the slowest of them."""
    grid, tol = config
    per_scene = grid.sun_nodes == "scene"
    clear_caches()
    out, build, evals = {}, None, {}
    for name in scenes:
        v, sun, alt = scene_geometry(name)
        if per_scene:
            clear_caches()
        t0 = time.perf_counter()
        try:
            out[name] = ms.multiple_scattering(atm, v, sun, altitude=alt, grid=grid,
                                               order_tolerance=tol)
        except ms.GridTooCoarseError:
            # the grid cannot resolve this scene (an order came out brighter than the one
            # before): no radiance, the tables say so (_fmt of NaN)
            out[name] = np.full((len(v), len(atm.wavelengths)), np.nan)
        dt = time.perf_counter() - t0
        if build is None or per_scene:
            # the first call builds the field (and gathers 72 directions)
            build = dt if build is None else max(build, dt)
        evals[name] = dt
    clear_caches()
    return out, build, evals


STORE_NOTE = ("The reference radiances are kept in `ms_reference_values.npz` (next to the "
              "tables) and reused by later runs while the method (field version), the reference grid, "
              "the atmospheres and the scenes are unchanged; the build time is that of the "
              "run that computed them.")


def _reference_key(atm, names, reference) -> str:
    """Fingerprint of everything the reference radiances of ``names`` depend on."""
    from atmoscatter import cache

    grid, tol = reference
    geometry = [[n, *scene_geometry(n)] for n in names]
    return cache.fingerprint("ms_reference", ms._FIELD_VERSION, atm, _grid_settings(grid),
                             float(tol), geometry)[:16]


def _grid_settings(grid) -> dict:
    """The fields of ``grid`` that differ from the dataclass defaults (nested for
    ``high_orders``): a new grid field with a default that leaves the method unchanged
    does not change the reference's fingerprint, so the stored values stay valid."""
    from dataclasses import fields as _fields

    out = {}
    for f in _fields(grid):
        v = getattr(grid, f.name)
        if v != f.default:
            out[f.name] = _grid_settings(v) if isinstance(v, MultipleScatteringGrid) else v
    return out


def reference_values(atm, names, reference, store=None, progress=print):
    """``({scene: radiance}, build [s], note)`` of the reference for ``names``.

    With ``store`` (an ``.npz`` path), values stored there by an earlier run for the same
    fingerprint (:func:`_reference_key`: field version, reference grid and tolerance,
    atmosphere, scene geometry) are read back, with the build time and date of the run
    that computed them (``note``); otherwise they are computed as any grid is
    (:func:`evaluate`) and added to the store (written atomically)."""
    out, build, note = _reference_values(atm, names, reference, store, progress)
    if reference == REFERENCE:
        for n in names:
            if SCENES[n][1] <= CENTRED_BELOW:
                out[n] = _reference_values(atm, [n], centred(reference, CENTRED_N_SUN), store,
                                           progress)[0][n]
    return out, build, note


def _reference_values(atm, names, reference, store=None, progress=print):
    """:func:`reference_values` for one reference grid."""
    key = _reference_key(atm, names, reference)
    data = {}
    if store is not None and Path(store).exists():
        with np.load(store) as z:
            data = {k: z[k] for k in z.files}
    if f"{key}/build_s" in data:
        out = {n: data[f"{key}/{n}"] for n in names}
        note = str(data[f"{key}/note"])
        progress(f"reference read from {store} ({note})")
        return out, float(data[f"{key}/build_s"]), note
    out, build, _ = evaluate(atm, names, reference)
    note = f"computed {time.strftime('%Y-%m-%d')}"
    if store is not None:
        data.update({f"{key}/{n}": out[n] for n in names})
        data[f"{key}/build_s"] = np.array(build)
        data[f"{key}/note"] = np.array(note)
        Path(store).parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(dir=Path(store).parent, suffix=".npz")
        os.close(fd)
        np.savez_compressed(tmp, **data)
        os.replace(tmp, store)
    return out, build, note


def errors(total, ref, single):
    """(max rel. error of the total, of the MS part) over directions above the floor."""
    keep = ref >= FLOOR * np.max(ref, axis=0, keepdims=True)
    ms_ref = ref - single
    d = np.abs(total - ref)
    e_tot = np.max(np.where(keep, d / np.where(keep, ref, 1.0), 0.0))
    keep_ms = keep & (ms_ref > 0)
    e_ms = np.max(np.where(keep_ms, d / np.where(keep_ms, ms_ref, 1.0), 0.0))
    return float(e_tot), float(e_ms)


def configs(knobs, default):
    grid0, tol0 = default
    for knob, values in knobs.items():
        for val in values:
            if knob == "order_tolerance":
                yield knob, val, (grid0, float(val))
            elif knob == "band_width":
                yield knob, val, (replace(grid0, band_width=float(val)), tol0)
            elif knob == "band_orders_from":
                yield knob, val, (replace(grid0, band_orders_from=None if val == "off" else int(val)),
                                  tol0)
            else:
                yield knob, val, (replace(grid0, **{knob: int(val)}), tol0)


def by_atmosphere(scenes) -> dict:
    """``{atmosphere key: [scene names]}`` in the order of ``scenes``."""
    out = {}
    for s in scenes:
        out.setdefault(SCENES[s][0], []).append(s)
    return out


def warm_up():
    """Compile the kernels and fill import-time tables outside any timed call."""
    v, sun, _ = scene_geometry("clear_noon")
    ms.multiple_scattering(ATMOSPHERES["mars"](), v[:2], sun, grid=QUICK_DEFAULT[0],
                           order_tolerance=1e-2)


def single_of(atm, names) -> dict:
    """Single scattering (exact, order 1) of each scene: the MS part is total − this."""
    out = {}
    for n in names:
        v, sun, alt = scene_geometry(n)
        out[n] = atmoscatter.single_scattering(atm, v, sun, altitude=alt)
    return out


def machine_text() -> str:
    return (f"{os.cpu_count()} CPUs (shared with other jobs, so times are noisy), "
            f"{ms._THREADS} threads")


def study(scenes, knobs, default, reference, sweep_atms, progress=print, on_atmosphere=None,
          store=None, sweep_scenes=SWEEP_SCENES):
    """Every config of the sweep on the ``sweep_scenes`` of the ``sweep_atms`` (empty: every
    scene), the default grid on every scene."""
    records, refinfo = [], {}
    warm_up()
    for akey, names in by_atmosphere(scenes).items():
        atm = ATMOSPHERES[akey]()
        single = single_of(atm, names)
        ref, t_ref, _ = reference_values(atm, names, reference, store, progress)
        refinfo[akey] = t_ref
        progress(f"{akey}: reference built in {t_ref:.1f} s")
        done = {}
        swept = [n for n in names if n in sweep_scenes or len(sweep_scenes) == 0]
        todo = [("default", "", default)]
        if akey in sweep_atms:
            todo += list(configs(knobs, default))
            if set(names) <= set(swept):  # every scene swept: the default is a knob row
                todo = todo[1:]
        for knob, val, cfg in todo:
            pick = KNOB_SCENES.get(knob, lambda _: True)
            sel = [n for n in (names if knob == "default" else swept) if pick(n)]
            if not sel:
                continue
            key = next((k for k in done if k[:2] == (cfg[0], cfg[1]) and set(sel) <= set(k[2])),
                       None)
            if key is None:
                key = (cfg[0], cfg[1], tuple(sel))
                done[key] = evaluate(atm, sel, cfg)
                progress(f"{akey}: {knob}={val}: built in {done[key][1]:.1f} s")
            out, build, evals = done[key]
            for n in sel:
                e_tot, e_ms = errors(out[n], ref[n], single[n])
                records.append({
                    "knob": knob, "value": val, "is_default": cfg == default,
                    "atmosphere": akey, "scene": n, "build_s": round(build, 3),
                    "eval_s": round(evals[n], 4), "max_rel_total": e_tot, "max_rel_ms": e_ms,
                })
        if on_atmosphere is not None:  # write what is done so far (a long run may be cut)
            on_atmosphere(records, refinfo)
    return records, refinfo


# ----------------------------------------------------------------------------------------
# outputs
# ----------------------------------------------------------------------------------------
def study_command_line(script: str, doc: str, quick_help: str, argv=None) -> dict:
    """The command line shared by the studies that read this study's reference
    (``--quick``: tiny grids into a temp dir; ``--out``): ``{"quick", "out", "store",
    "command", "official"}`` — the output directory, the reference store to read, the
    command to quote on the page, and whether the run writes the committed outputs."""
    ap = argparse.ArgumentParser(description=doc.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help=quick_help)
    ap.add_argument("--out", default=None, help="output directory (default docs/convergence)")
    args = ap.parse_args(argv)
    name = Path(script).name
    if args.quick:
        out = Path(args.out or tempfile.mkdtemp(prefix=f"atmoscatter-{Path(script).stem}-"))
        store = out / REFERENCE_STORE.name
    else:
        out = Path(args.out or ROOT / "docs" / "convergence")
        store = REFERENCE_STORE
    return {"quick": args.quick, "out": out, "store": store,
            "command": f"PYTHONPATH=. python benchmarks/{name}" + (" --quick" if args.quick else ""),
            "official": not (args.quick or args.out)}


def page_footer(grid, machine: str, command: str) -> list[str]:
    """The closing lines of a study page: the grid, the machine and the command."""
    return ["", f"Grid: {grid.describe()}.", "", f"Machine: {machine}.", "",
            f"Command: `{command}`."]


def study_main(script: str, doc: str, page: str, quick, full, run, markdown, argv=None) -> int:
    """The ``main`` of a study that compares grids scene by scene: ``quick`` and ``full``
    are ``(scenes, grid)``; ``run(scenes, grid)`` measures the rows and
    ``markdown(rows, grid, machine, command)`` makes ``page`` of them, written into the
    output directory of :func:`study_command_line`."""
    cl = study_command_line(script, doc, "tiny grid, two scenes, temp dir", argv)
    scenes, grid = quick if cl["quick"] else full
    t0 = time.perf_counter()
    rows = run(scenes, grid)
    write_study_page(cl["out"], page, markdown(rows, grid, machine_text(), cl["command"]), t0)
    return 0


def write_study_page(out: Path, name: str, text: str, t0: float) -> None:
    """Write a study's page ``out/name`` atomically (creating ``out``), print it and say
    how long the run took since ``t0`` (``time.perf_counter``)."""
    out.mkdir(parents=True, exist_ok=True)
    _atomic_write(out / name, text)
    print(text)
    print(f"wrote {out / name} in {time.perf_counter() - t0:.0f} s")


def _atomic_write(path: Path, text: str):
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=path.name + ".", suffix=".tmp")
    with os.fdopen(fd, "w", encoding="utf-8") as f:
        f.write(text)
    os.replace(tmp, path)


def _fmt(x):
    # NaN: the grid raised GridTooCoarseError for the scene (evaluate)
    return "too coarse" if x != x else f"{x:.1e}"


def default_rows(records):
    seen, rows = set(), []
    for r in records:
        if r["is_default"] and r["scene"] not in seen:
            seen.add(r["scene"])
            rows.append(r)
    return rows


def table_markdown(records, refinfo, scenes, default, reference, machine):
    atms = list(dict.fromkeys(SCENES[s][0] for s in scenes))
    lines = [
        f"Max relative error (total / multiple-scattering part) against the reference grid "
        f"{_grid_text(reference)}; directions whose total radiance is below {FLOOR:g} of the "
        "scene maximum (per wavelength) ignored.  Build = first call with empty caches [s]: "
        "the grids centred on the scene's sun build a field per scene and the column gives "
        "the slowest of the row's scenes of the atmosphere (a row measured on some scenes "
        "only, \"—\" elsewhere, times those; for turbidity 2.5 the observer in space, whose "
        "band of sun nodes is wider, is the slowest where it is measured; "
        "`ms_convergence.csv` has every scene's first call in "
        f"`eval_s`); {machine}.",
        "",
        "| knob | value | " + " | ".join(f"build {a} [s]" for a in atms) + " | "
        + " | ".join(scenes) + " |",
        "|---|---|" + "---:|" * len(atms) + "---|" * len(scenes),
    ]
    # a grid centred on the sun builds a field per scene: a row's build is the slowest first
    # call among its own scenes (the default's evaluation, reused by the bold rows of knobs
    # that reach some scenes only, covers more scenes than the row shows)
    per_scene = default[0].sun_nodes == "scene"
    rows = {}
    for r in records:
        k = (r["knob"], str(r["value"]))
        rows.setdefault(k, {"default": r["is_default"], "build": {}, "err": {}})
        t = float(r["eval_s"]) if per_scene else float(r["build_s"])
        a = r["atmosphere"]
        rows[k]["build"][a] = max(rows[k]["build"].get(a, t), t) if per_scene else t
        rows[k]["err"][r["scene"]] = (r["max_rel_total"], r["max_rel_ms"])
    for (knob, val), row in rows.items():
        b = " | ".join(f"{row['build'][a]:.1f}" if a in row["build"] else "—" for a in atms)
        e = " | ".join(f"{_fmt(row['err'][s][0])} / {_fmt(row['err'][s][1])}" if s in row["err"]
                       else "—" for s in scenes)
        mark = "**" if row["default"] else ""
        # the row of an atmosphere measured at the default grid only has no knob value
        shown = f"{mark}{val}{mark}" if val not in ("", "None") else "(default grid)"
        lines.append(f"| {knob} | {shown} | {b} | {e} |")
    lines += ["", "Reference build time [s]: " + ", ".join(
        f"{a} {t:.0f}" for a, t in refinfo.items()) + ".",
              "", STORE_NOTE]
    return "\n".join(lines) + "\n"


def _grid_text(cfg):
    g, tol = cfg

    def knobs(x):
        return (f"n_altitude {x.n_altitude}, n_sun {x.n_sun}, n_mu {x.n_mu}, n_phi {x.n_phi}, "
                f"order {x.order}")

    text = knobs(g)
    if g.sun_nodes == "scene":
        text += f", solar zenith centred on the sun (±{g.sun_width:g}°)"
        if g.band_orders_from is not None:
            text += (f", orders ≥ {g.band_orders_from} in the band of ±{g._band_width():g}° "
                     f"(±{g.sun_width:g}° below {ms.TWILIGHT_BAND_ELEVATION:g}°; both wider "
                     "by the dip from space)")
    if g.space_n_mu is not None:
        text += f", n_mu {g.space_n_mu} for an observer in space"
    if g.space_day_n_sun is not None:
        text += (f", n_sun {g.space_day_n_sun} for an observer in space with the sun "
                 f"{ms.SPACE_DAY_ELEVATION:g}° or more up")
    near = [f"{name} {value}" for name, value in (("n_sun", g.horizon_n_sun),
                                                  ("n_phi", g.horizon_n_phi))
            if value is not None]
    if near:
        lo, hi = ms.HORIZON_SUN_ELEVATION
        text += (f", {' and '.join(near)} for a sun {lo:g}° to {hi:+g}° from the horizon "
                 "(observer in the atmosphere)")
    if g.high_orders is not None:
        text += f" (orders ≥ {g.high_orders_from}: {knobs(g.high_orders)})"
    return f"{text}, order_tolerance {tol:g}"


def regime_summary(rows):
    """Worst errors per EXR-header regime of ``rows`` (one dict per scene with ``scene``,
    ``atmosphere``, ``max_rel_total``, ``max_rel_ms``): ``{"sun_regimes_ground_observer":
    …, "observer_regimes": …}`` (the layout of ``atmoscatter/data/ms_accuracy.json``,
    which ``benchmarks/ms_accurate_grid.py`` writes)."""
    top = {}
    for key in ATMOSPHERES:
        atm = ATMOSPHERES[key]()
        top[key] = atm.top_radius - atm.planet_radius

    def worst(sel):
        sel = list(sel)
        i = int(np.argmax([r["max_rel_total"] for r in sel]))
        return {"max_rel_total": max(r["max_rel_total"] for r in sel),
                "max_rel_ms": max(r["max_rel_ms"] for r in sel),
                "scenes": [r["scene"] for r in sel], "worst_scene": sel[i]["scene"]}

    obs = {r["scene"]: observer_regime(SCENES[r["scene"]][2], top[r["atmosphere"]]) for r in rows}
    sun_reg = {}
    for key in SUN_REGIMES:  # ground observers
        sel = [r for r in rows if obs[r["scene"]] == "ground" and sun_regime(SCENES[r["scene"]][1]) == key]
        if sel:
            sun_reg[key] = {"description": SUN_REGIMES[key], **worst(sel)}
    obs_reg = {}
    for key in OBSERVER_REGIMES:
        sel = [r for r in rows if obs[r["scene"]] == key]
        if sel:
            obs_reg[key] = {"description": OBSERVER_REGIMES[key],
                            "sun_elevations_deg": [SCENES[r["scene"]][1] for r in sel], **worst(sel)}
    return {"sun_regimes_ground_observer": sun_reg, "observer_regimes": obs_reg}


def _panel_time(rows) -> float:
    """First-call time [s] of a panel's point: the slowest first call of its scenes (each
    scene's ``eval_s`` with a grid centred on the sun builds that scene's field)."""
    return max(float(r["eval_s"]) for r in rows)


def plot(records, path, sweep_atm):
    """Worst error against build time, one curve per knob, in separate panels for the sun
    up (total, MS part), twilight and the space observer's limb, so that the larger
    errors of the hard scenes do not hide the rest."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    # the swept scenes' knob rows (the scenes measured on the default grid only are in
    # the table, not on the curves)
    rows = [r for r in records if r["atmosphere"] == sweep_atm and r["knob"] != "default"
            and r["scene"] in SWEEP_SCENES]
    inside = [r for r in rows if SCENES[r["scene"]][2] < 100e3]
    day = [r for r in inside if SCENES[r["scene"]][1] > 0]
    night = [r for r in inside if SCENES[r["scene"]][1] <= 0]
    limb = [r for r in rows if SCENES[r["scene"]][2] >= 100e3]
    panels = [(day, "max_rel_total", "sun up (ground, 12 km): total"),
              (day, "max_rel_ms", "sun up (ground, 12 km): MS part"),
              (night, "max_rel_total", "twilight (sun at or below 0°): total"),
              (limb, "max_rel_total", "space observer, limb: total")]
    panels = [p for p in panels if p[0]]
    fig, axes = plt.subplots(1, len(panels), figsize=(4.6 * len(panels), 4.4), squeeze=False)
    axes = axes[0]
    for ax, (sel_rows, k, title) in zip(axes, panels, strict=True):
        for knob in dict.fromkeys(r["knob"] for r in sel_rows):
            vals = list(dict.fromkeys(r["value"] for r in sel_rows if r["knob"] == knob))
            t, e = [], []
            for v in vals:
                sel = [r for r in sel_rows if r["knob"] == knob and r["value"] == v]
                t.append(_panel_time(sel))
                e.append(max(float(r[k]) for r in sel))
            ax.loglog(t, e, "o-", label=knob)
            for ti, ei, v in zip(t, e, vals, strict=True):
                ax.annotate(v if isinstance(v, str) else f"{float(v):g}", (ti, ei), fontsize=7,
                            xytext=(3, 3),
                            textcoords="offset points")
        d = [r for r in sel_rows if r["is_default"] in (True, "True")]
        if d:
            ax.loglog([_panel_time(d)], [max(float(r[k]) for r in d)], "k*", ms=14,
                      label="default", zorder=5)
        ax.set_xlabel("first call of the panel's slowest scene [s]")
        ax.set_ylabel("worst max relative error")
        ax.set_title(f"{sweep_atm}: {title}", fontsize=9)
        ax.grid(True, which="both", alpha=0.3)
    axes[0].legend(fontsize=8)
    fig.tight_layout()
    tmp = path.with_name(path.stem + ".tmp.png")
    fig.savefig(tmp, dpi=110)
    plt.close(fig)
    os.replace(tmp, path)


def replot(out: Path, official: bool):
    """Redraw the PNG and the table from an existing ``ms_convergence.csv`` (and, for the
    official run, the generated block of ``docs/convergence.md``) — with the code at hand,
    so only right for the same method.  The reference build times and the machine are
    read back from the existing ``ms_convergence_table.md``."""
    import re

    with open(out / "ms_convergence.csv", newline="", encoding="utf-8") as f:
        records = list(csv.DictReader(f))
    for r in records:
        r["is_default"] = r["is_default"] == "True"
        for k in ("build_s", "eval_s", "max_rel_total", "max_rel_ms"):
            r[k] = float(r[k])
    plot(records, out / "ms_convergence.png", SWEEP_ATMOSPHERES[0])
    old = (out / "ms_convergence_table.md").read_text(encoding="utf-8")
    machine = re.search(r"`eval_s`\); (.*)\.\n", old).group(1)
    line = re.search(r"Reference build time \[s\]: (.*)\.", old).group(1)
    refinfo = {a: float(t) for a, t in (item.rsplit(" ", 1) for item in line.split(", "))}
    scenes = [s for s in SCENES if any(r["scene"] == s for r in records)]
    table = table_markdown(records, refinfo, scenes, DEFAULT, REFERENCE, machine)
    _atomic_write(out / "ms_convergence_table.md", table)
    if official:
        splice_docs(ROOT / "docs" / "convergence.md", table, regime_summary(default_rows(records)))


BEGIN, END = "<!-- ms_convergence:begin (generated) -->", "<!-- ms_convergence:end -->"


def splice_docs(doc: Path, table: str, js: dict):
    """Replace the generated block of ``docs/convergence.md`` (between the markers)."""
    text = doc.read_text(encoding="utf-8")
    if BEGIN not in text or END not in text:
        return False
    summary = ["", "Default grid, worst over the scenes of each regime, against the reference "
               "(the same figures as the EXR header's, `atmoscatter/data/ms_accuracy.json`, "
               "measured by `benchmarks/ms_accurate_grid.py` against the same reference):", "",
               "| regime | scenes | max rel. error, total | of the MS part |", "|---|---|---:|---:|"]
    for group in ("sun_regimes_ground_observer", "observer_regimes"):
        for v in js[group].values():
            summary.append(f"| {v['description']} | {', '.join(v['scenes'])} | "
                           f"{_fmt(v['max_rel_total'])} | {_fmt(v['max_rel_ms'])} |")
    block = BEGIN + "\n\n" + table + "\n".join(summary) + "\n\n" + END
    head, rest = text.split(BEGIN, 1)
    _, tail = rest.split(END, 1)
    _atomic_write(doc, head + block + tail)
    return True


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default=None, help="output directory (default docs/convergence)")
    ap.add_argument("--quick", action="store_true", help="smoke run: tiny grids, 2 scenes")
    ap.add_argument("--scenes", nargs="*", default=None, choices=sorted(SCENES))
    ap.add_argument("--sweep-all", action="store_true",
                    help="one-knob sweep for every atmosphere (default: earth_t2.5 only)")
    ap.add_argument("--replot", action="store_true", help="only redraw the PNG from the CSV")
    args = ap.parse_args(argv)
    if args.replot:
        replot(Path(args.out or ROOT / "docs" / "convergence"), official=args.out is None)
        return 0
    if args.quick:
        scenes = args.scenes or ["clear_noon", "civil_twilight"]
        knobs, default, reference = QUICK_KNOBS, QUICK_DEFAULT, QUICK_REFERENCE
        out = Path(args.out or tempfile.mkdtemp(prefix="atmoscatter-ms-convergence-"))
        store = out / REFERENCE_STORE.name
    else:
        scenes = args.scenes or list(SCENES)
        knobs, default, reference = KNOBS, DEFAULT, REFERENCE
        out = Path(args.out or ROOT / "docs" / "convergence")
        store = REFERENCE_STORE
    sweep = tuple(ATMOSPHERES) if args.sweep_all else SWEEP_ATMOSPHERES
    machine = machine_text()
    t0 = time.perf_counter()
    state = {}

    def write(records, refinfo):
        state["paths"], state["table"] = write_outputs(
            records, refinfo, scenes, default, reference, machine, out, sweep,
            official=not (args.quick or args.out or args.scenes), quick=args.quick)

    study(scenes, knobs, default, reference, sweep, on_atmosphere=write, store=store)
    print(f"wrote {', '.join(str(p) for p in state['paths'])} in {time.perf_counter() - t0:.1f} s")
    print(state["table"])
    return 0


def write_outputs(records, refinfo, scenes, default, reference, machine, out, sweep, official, quick):
    done = [s for s in scenes if any(r["scene"] == s for r in records)]
    out.mkdir(parents=True, exist_ok=True)
    fields = list(records[0])
    with open(out / "ms_convergence.csv.tmp", "w", newline="", encoding="utf-8") as f:
        w = csv.DictWriter(f, fieldnames=fields)
        w.writeheader()
        w.writerows(records)
    os.replace(out / "ms_convergence.csv.tmp", out / "ms_convergence.csv")
    table = table_markdown(records, refinfo, done, default, reference, machine)
    _atomic_write(out / "ms_convergence_table.md", table)
    sweep_atm = next(a for a in dict.fromkeys(SCENES[s][0] for s in done) if a in sweep)
    plot(records, out / "ms_convergence.png", sweep_atm)
    js = regime_summary(default_rows(records))
    written = [out / n for n in ("ms_convergence.csv", "ms_convergence_table.md", "ms_convergence.png")]
    if official:
        if splice_docs(ROOT / "docs" / "convergence.md", table, js):
            written.append(ROOT / "docs" / "convergence.md")
    return written, table


if __name__ == "__main__":
    sys.exit(main())

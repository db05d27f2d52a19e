"""Observers above the atmosphere: the band of high orders and the solar-zenith nodes.

Usage (from the repository root)::

    PYTHONPATH=. python benchmarks/ms_space.py           # -> docs/convergence/ms_space.md
    PYTHONPATH=. python benchmarks/ms_space.py --quick   # tiny grid -> a temp dir

Seen from space (500 km here) the default grid's field differs from an observer's inside
the atmosphere in two fast paths this page checks, per sun, over the disc and across the
limb (:func:`directions`):

* the band of high orders (orders ≥ 3 only at the solar-zenith nodes near the sun,
  ``band_orders_from``) widened by the observer's dip
  (:meth:`~atmoscatter.sky.multiple.MultipleScatteringGrid.for_sun`), against the same
  grid computing every order at every node — the answer the band must give ("one
  answer", as ``ms_band_width.py`` checks it inside the atmosphere);
* ``space_day_n_sun`` (fewer solar-zenith nodes with the sun at least
  :data:`~atmoscatter.sky.multiple.SPACE_DAY_ELEVATION` up), against the same grid with
  the ground's ``n_sun`` (16), with ``space_day_n_sun`` at every sun and with 24 nodes,
  all before the widening: the solar-zenith part of the discretisation error, which the
  limit is chosen from (below it the default takes ``n_sun``; the ``space_day_n_sun``
  column shows what the fewer nodes would cost there).

Each value is the largest relative difference of the radiance (single + multiple
scattering) over the directions, those darker than 1e-3 of the scene's brightest
compared at that level; the first call of each grid (in-process and disk caches empty) is
in brackets.  These are comparisons of the method with itself; the limb's error against the
study's reference is in ``ms_convergence.py`` (scenes ``space_limb``, ``space_limb_day``,
``space_limb_twilight``).
"""

from __future__ import annotations

import sys
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

import ms_convergence as mc  # noqa: E402  (sets ATMOSCATTER_CACHE_DIR=off first)

from atmoscatter.sky import _quadrature as qd  # noqa: E402
from atmoscatter.sky import multiple as ms  # noqa: E402

ALTITUDE = 500e3
#: (atmosphere key, sun elevation [deg])
SCENES = (
    ("earth_t2.5", 60.0), ("earth_t2.5", 45.0), ("earth_t2.5", 30.0), ("earth_t2.5", 20.0),
    ("earth_t2.5", 10.0), ("earth_t2.5", 0.0), ("earth_t2.5", -4.0), ("earth_t2.5", -6.0),
    ("earth_t1.5", 30.0), ("earth_t10", 30.0),
)
QUICK_SCENES = (("earth_t2.5", 30.0), ("earth_t2.5", 0.0))
QUICK_GRID = ms.MultipleScatteringGrid(n_altitude=6, n_sun=8, n_mu=6, n_phi=5, order=2,
                                       sun_nodes="scene", band_orders_from=3, band_width=6.0,
                                       space_day_n_sun=6)
#: the columns: name -> how the default grid (specialised to the scene) is changed
VARIANTS = ("default", "every node", "n_sun", "day nodes", "24 nodes")


def directions() -> np.ndarray:
    """From 500 km: the top of the atmosphere is tangent at view zenith 110.7°, the ground
    at 112.0°; the disc (100°–110.5°, 112.2°–125°) and 14 zeniths across the limb, each at
    13 azimuths from the solar vertical (0–180°)."""
    th = np.radians(np.concatenate([np.linspace(100.0, 110.5, 5), np.linspace(110.7, 112.0, 14),
                                    np.linspace(112.2, 125.0, 8)]))
    ph = np.radians(np.linspace(0.0, 180.0, 13))
    t, p = np.meshgrid(th, ph, indexing="ij")
    return np.stack([np.sin(t) * np.sin(p), np.sin(t) * np.cos(p), np.cos(t)], -1).reshape(-1, 3)


def _grids(grid, atm, sun):
    """The grids of a scene, specialised to its sun and the observer's dip."""
    zenith, dip = ms._sun_centre(qd.prepare_atmosphere(atm), sun, ALTITUDE)
    default = grid.for_sun(zenith, dip)
    plain = replace(grid, space_day_n_sun=None)
    return {"default": default,
            "every node": replace(default, band_orders_from=None),
            "n_sun": plain.for_sun(zenith, dip),
            "day nodes": replace(plain, n_sun=grid.space_day_n_sun).for_sun(zenith, dip),
            "24 nodes": replace(plain, n_sun=24).for_sun(zenith, dip)}


def run(scenes, grid, progress=print):
    """``[{scene, variant: (max rel difference, first call [s]), nodes}]``: "every node"
    against the default, "default" and "n_sun" against "24 nodes"."""
    mc.warm_up()
    v = directions()
    rows = []
    for akey, elevation in scenes:
        atm = mc.ATMOSPHERES[akey]()
        e = np.radians(elevation)
        sun = np.array([0.0, np.cos(e), np.sin(e)])
        grids = _grids(grid, atm, sun)
        out = {}
        for name, g in grids.items():
            ms._clear_process_caches()
            t0 = time.perf_counter()
            out[name] = (ms.multiple_scattering(atm, v, sun, grid=g, altitude=ALTITUDE),
                         time.perf_counter() - t0)

        def diff(a, b):
            top = np.max(b, axis=0)
            return float(np.max(np.abs(a - b) / np.maximum(b, 1e-3 * top)))

        fine = out["24 nodes"][0]
        row = {"scene": (akey, elevation),
               "nodes": {n: g.n_sun for n, g in grids.items()},
               "band": diff(out["default"][0], out["every node"][0]),
               "default": diff(out["default"][0], fine),
               "n_sun": diff(out["n_sun"][0], fine),
               "day nodes": diff(out["day nodes"][0], fine),
               "time": {n: t for n, (_, t) in out.items()}}
        rows.append(row)
        progress(f"{akey} sun {elevation:+g}: band {row['band']:.1e}, default {row['default']:.1e}, "
                 f"n_sun {row['n_sun']:.1e}, day nodes {row['day nodes']:.1e}; "
                 + ", ".join(f"{n} {row['time'][n]:.1f} s" for n in VARIANTS))
    return rows


def markdown(rows, grid, machine, command) -> str:
    lim = ms.SPACE_DAY_ELEVATION
    lines = [
        "<!-- generated by benchmarks/ms_space.py: do not edit -->",
        "",
        f"Observer at {ALTITUDE / 1e3:g} km, over the disc and across the limb: the largest "
        "relative difference of the radiance (directions darker than 1e-3 of the scene's "
        "brightest compared at that level), first calls in brackets.  *Band*: the default "
        "grid (band of high orders widened by the dip) against the same grid computing every "
        "order at every node.  *Solar-zenith nodes*: the default grid and the grids with "
        f"the ground's n_sun ({grid.n_sun}) and with space_day_n_sun ({grid.space_day_n_sun}) "
        "at every sun against 24 nodes (all before the widening); the default takes "
        f"space_day_n_sun with the sun at or above {lim:g}° (**bold**), n_sun below.",
        "",
        "| atmosphere | sun [deg] | band: default vs every node | default vs 24 nodes "
        f"| n_sun {grid.n_sun} vs 24 | {grid.space_day_n_sun} nodes vs 24 "
        "| nodes after the widening (default / n_sun / space_day_n_sun / 24) |",
        "|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        akey, el = r["scene"]
        t = r["time"]
        band = f"{r['band']:.1e} ({t['default']:.1f} s / {t['every node']:.1f} s)"
        dflt = f"{r['default']:.1e} ({t['default']:.1f} s)"
        if el >= lim:
            dflt = f"**{dflt}**"
        nsun = f"{r['n_sun']:.1e} ({t['n_sun']:.1f} s)"
        day = f"{r['day nodes']:.1e} ({t['day nodes']:.1f} s)"
        nodes = " / ".join(str(r["nodes"][n]) for n in ("default", "n_sun", "day nodes", "24 nodes"))
        lines.append(f"| {akey} | {el:g} | {band} | {dflt} | {nsun} | {day} | {nodes} |")
    worst_band = max(r["band"] for r in rows)
    day = [r["default"] for r in rows if r["scene"][1] >= lim]
    lines += ["", f"Worst band difference: {worst_band:.1e}."]
    below = [r["day nodes"] for r in rows if r["scene"][1] < lim]
    if day:
        lines.append(f"Worst solar-zenith difference of the default with the sun at or above "
                     f"{lim:g}°: {max(day):.1e}.")
    if below:
        lines.append(f"Worst of {grid.space_day_n_sun} nodes below {lim:g}°, where the "
                     f"default does not take them: {max(below):.1e}.")
    lines += mc.page_footer(grid, machine, command)
    return "\n".join(lines) + "\n"


def main(argv=None) -> int:
    return mc.study_main(__file__, __doc__, "ms_space.md", (QUICK_SCENES, QUICK_GRID),
                         (SCENES, ms.MULTIPLE_SCATTERING_GRID), run, markdown, argv)


if __name__ == "__main__":
    sys.exit(main())

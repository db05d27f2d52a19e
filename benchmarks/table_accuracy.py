"""Error against run time of the single-scattering table path (issue 10).

For each table size (nodes in the horizon/zenith variable × nodes in azimuth) and each
scene (``earth_turbidity_atmosphere(T)``, ground observer, sun elevation), prints the
table build time (nodes + self-check), the cells that failed the self-check (integrated
directly), the time to evaluate the whole direction set through the table, and the
maximum relative error against ``method="reference"`` for directions brighter than
1e-3, 1e-6 (:data:`~atmoscatter.sky.single.TABLE_FLOOR`) and 1e-8 of the sky maximum
(per wavelength), with and without the self-check's direct fallback.

Run::

    PYTHONPATH=. python benchmarks/table_accuracy.py            # 64×32 lat-long, 6 scenes
    PYTHONPATH=. python benchmarks/table_accuracy.py --quick    # 32×16, 2 scenes, 2 sizes
"""

from __future__ import annotations

import argparse
import time

import numpy as np

import atmoscatter as ac
from atmoscatter.render.directions import LatLongDirections
from atmoscatter.sky import _quadrature as qd
from atmoscatter.sky import _single_rules, _single_table
from atmoscatter.sky import single as S

SIZES = [(65, 17), (97, 17), (129, 17), (129, 33), (193, 17)]
SCENES = [(1.5, 30.0), (3.0, 2.0), (6.0, 1.0), (10.0, 5.0), (10.0, 1.0), (10.0, 0.0)]


def _sun(elev):
    e = np.radians(elev)
    return np.array([0.0, np.cos(e), np.sin(e)])


def _radiance(table, a, v, s):
    J = np.zeros((len(a.profiles), v.shape[0], a.n_wavelengths))
    J[table.groups] = table.J(v)
    return _single_rules._radiance_from_J(a, J, v, s)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true")
    args = ap.parse_args(argv)
    sizes, scenes, (w, h) = SIZES, SCENES, (64, 32)
    if args.quick:
        sizes, scenes, (w, h) = [(65, 17), (129, 17)], [(3.0, 2.0), (10.0, 1.0)], (32, 16)
    d = LatLongDirections(w, h)
    v, _ = d.directions(0, d.size)
    print(f"{len(v)} lat-long directions; errors = max relative vs method='reference' above "
          "floor × sky max (per wavelength)")
    print("T     sun   n_u n_phi  build[s] bad/cells lookup[s] | 1e-3    1e-6    1e-8   "
          "| unchecked 1e-6")
    for T, elev in scenes:
        atm = ac.earth_turbidity_atmosphere(T)
        a = qd.prepare_atmosphere(atm)
        s = _sun(elev)
        ref = S.single_scattering(atm, v, s, method="reference")
        mx = ref.max(axis=0)
        for n_u, n_phi in sizes:
            t0 = time.perf_counter()
            tab = _single_table._LogSkyTable(a, a.planet_radius, s, n_u, n_phi, 4)
            t1 = time.perf_counter()
            got = _radiance(tab, a, v, s)
            t2 = time.perf_counter()
            rel = np.abs(got - ref) / np.maximum(ref, 1e-300)
            errs = [rel[ref >= f * mx].max() for f in (1e-3, 1e-6, 1e-8)]
            for cells in tab.bad_cells.values():
                cells[:] = False  # the same interpolant without the direct fallback
            raw = _radiance(tab, a, v, s)
            rel_raw = (np.abs(raw - ref) / np.maximum(ref, 1e-300))[ref >= 1e-6 * mx].max()
            print(f"{T:<5} {elev:5.1f} {n_u:4d} {n_phi:4d} {t1 - t0:9.2f} {tab.n_bad:4d}/{tab.n_cells:<5d}"
                  f"{t2 - t1:8.2f}  | " + "  ".join(f"{e:.1e}" for e in errs)
                  + f" | {rel_raw:.1e}", flush=True)


if __name__ == "__main__":
    main()

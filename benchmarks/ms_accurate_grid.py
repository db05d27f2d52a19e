"""Default against accurate multiple-scattering grid, both against a grid refined beyond them.

Usage (from the repository root)::

    PYTHONPATH=. python benchmarks/ms_accurate_grid.py           # -> docs/convergence/ms_accurate_grid.md
                                                                 #    and atmoscatter/data/ms_accuracy.json
    PYTHONPATH=. python benchmarks/ms_accurate_grid.py --quick   # tiny grids -> a temp dir

The scenes, the error measure and the timing rules are those of
``benchmarks/ms_convergence.py`` (every scene of :data:`ms_convergence.SCENES`); the
reference here is finer than :data:`~atmoscatter.sky.multiple.ACCURATE_MULTIPLE_SCATTERING_GRID`
in *every* knob (a reference equal to a grid in some knob would report no error from
that knob), so it also checks the default grid against more than the study's reference.
The full run also writes ``atmoscatter/data/ms_accuracy.json``: the worst errors of both
grids per sun / observer regime, which the renderer quotes in the EXR header for the
grid a scene uses (``Scene.ms_grid``).  The reference is the same method refined: its agreement with outside answers is the
subject of ``scripts/ms_reference_check.py`` (DISORT, Monte Carlo).
"""

from __future__ import annotations

import json
import sys
import time
from dataclasses import asdict, replace
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

import ms_convergence as mc  # noqa: E402  (sets ATMOSCATTER_CACHE_DIR=off first)

from atmoscatter.sky import multiple as ms  # noqa: E402
from atmoscatter.sky.multiple import MultipleScatteringGrid  # noqa: E402

REFERENCE = mc.REFERENCE
GRIDS = {"default": mc.DEFAULT,
         "accurate": (ms.ACCURATE_MULTIPLE_SCATTERING_GRID, ms.DEFAULT_ORDER_TOLERANCE),
         "table": (ms.TABLE_MULTIPLE_SCATTERING_GRID, ms.DEFAULT_ORDER_TOLERANCE)}
#: grids measured beside the named ones (rows of the table, not in ms_accuracy.json)
CANDIDATES = {
    # the default grid before 36 view cosines from space, 24 solar-zenith nodes and 19
    # azimuths near the horizon (CHANGELOG) and 10 solar-zenith nodes from space with the
    # sun high: what those knobs bought, at sunset, near the terminator and across the limb
    "former default": (
        replace(ms.MULTIPLE_SCATTERING_GRID, space_n_mu=None, horizon_n_sun=None,
                horizon_n_phi=None, space_day_n_sun=None),
        ms.DEFAULT_ORDER_TOLERANCE),
}
QUICK_REFERENCE = mc.QUICK_REFERENCE
_QUICK_ACC = MultipleScatteringGrid(n_altitude=5, n_sun=8, n_mu=4, n_phi=3, order=2,
                                    sun_nodes="scene")
QUICK_GRIDS = {"default": mc.QUICK_DEFAULT, "accurate": (_QUICK_ACC, 1e-2),
               "table": (MultipleScatteringGrid(n_altitude=4, n_sun=10, n_mu=4, n_phi=3, order=2),
                         1e-2)}
QUICK_CANDIDATES = {"accurate, orders ≥ 3 on n_mu 2": (
    replace(_QUICK_ACC, high_orders=replace(_QUICK_ACC, n_mu=2)), 1e-2)}

def run(scenes, grids, reference, progress=print, store=None):
    mc.warm_up()
    rows, builds, t_ref = {}, {}, {}
    for akey, names in mc.by_atmosphere(scenes).items():
        atm = mc.ATMOSPHERES[akey]()
        single = mc.single_of(atm, names)
        ref, t_ref[akey], _ = mc.reference_values(atm, names, reference, store, progress)
        progress(f"{akey}: reference built in {t_ref[akey]:.0f} s")
        for g, cfg in grids.items():
            out, builds[(akey, g)], _ = mc.evaluate(atm, names, cfg)
            progress(f"{akey}: {g} built in {builds[(akey, g)]:.1f} s")
            for n in names:
                rows[(n, g)] = mc.errors(out[n], ref[n], single[n])
    return rows, builds, t_ref


def markdown(scenes, grids, reference, rows, builds, t_ref, machine, command):
    atms = list(dict.fromkeys(mc.SCENES[s][0] for s in scenes))
    lines = [
        "Max relative error of the total / of the multiple-scattering part against the grid "
        f"{mc._grid_text(reference)} ({mc.REFERENCE_NOTE}); directions below "
        f"{mc.FLOOR:g} of the scene maximum ignored; scenes as in the study above.",
        "",
        "| grid | " + " | ".join(f"first call {a} [s]" for a in atms) + " | "
        + " | ".join(scenes) + " |",
        "|---|" + "---:|" * len(atms) + "---|" * len(scenes),
    ]
    for g, cfg in grids.items():
        b = " | ".join(f"{builds[(a, g)]:.1f}" for a in atms)
        e = " | ".join(f"{mc._fmt(rows[(s, g)][0])} / {mc._fmt(rows[(s, g)][1])}" for s in scenes)
        lines.append(f"| {g} ({mc._grid_text(cfg)}) | {b} | {e} |")
    worst = {g: max(rows[(s, g)][0] for s in scenes if mc.SCENES[s][1] >= -12.0) for g in grids}
    lines += ["", "Worst total error down to sun −12°: " + ", ".join(
        f"{g} {100 * w:.2g} %" for g, w in worst.items()) + ".  Reference first call: "
        + ", ".join(f"{a} {t:.0f} s" for a, t in t_ref.items()) + ".", "", mc.STORE_NOTE, "",
        f"*{machine}, {time.strftime('%Y-%m-%d')}; `{command}`.*"]
    return "\n".join(lines) + "\n"


def accuracy_json(scenes, grids, reference, rows, machine, command):
    """The content of ``atmoscatter/data/ms_accuracy.json``: per named grid, the worst
    errors per EXR-header regime (:func:`ms_convergence.regime_summary`) against the
    finer reference, with the grid's fields (the renderer checks them before quoting the
    figures)."""
    out = {}
    for g, (grid, tol) in grids.items():
        sel = [{"scene": s, "atmosphere": mc.SCENES[s][0], "max_rel_total": rows[(s, g)][0],
                "max_rel_ms": rows[(s, g)][1]} for s in scenes]
        out[g] = {"grid": mc._grid_text((grid, tol)),
                  "grid_fields": {**asdict(grid), "order_tolerance": tol},
                  **mc.regime_summary(sel)}
    return {
        "what": "worst max relative error of atmoscatter.multiple_scattering (orders=None, "
                "ground_albedo 0) on each named grid against the same method on a finer grid "
                "(" + mc.REFERENCE_NOTE + "), per regime; generated by benchmarks/ms_accurate_grid.py "
                "(docs/convergence.md, 'The accurate grid')",
        "reference_grid": mc._grid_text(reference),
        # what the renderer checks before quoting the figures (stale after a method change)
        "field_version": ms._FIELD_VERSION,
        "floor": mc.FLOOR, "machine": machine, "command": command, "grids": out,
    }


def main(argv=None) -> int:
    cl = mc.study_command_line(__file__, __doc__, "tiny grids, two scenes, temp dir", argv)
    if cl["quick"]:
        scenes, grids, reference = ["clear_noon", "civil_twilight"], QUICK_GRIDS, QUICK_REFERENCE
        candidates = QUICK_CANDIDATES
    else:
        scenes, grids, reference = list(mc.SCENES), GRIDS, REFERENCE
        candidates = CANDIDATES
    out, command = cl["out"], cl["command"]
    t0 = time.perf_counter()
    rows, builds, t_ref = run(scenes, {**grids, **candidates}, reference, store=cl["store"])
    machine = mc.machine_text()
    text = markdown(scenes, {**grids, **candidates}, reference, rows, builds, t_ref, machine,
                    command)
    mc._atomic_write(out / "ms_accurate_grid.md", text)
    js = accuracy_json(scenes, grids, reference, rows, machine, command)
    js_path = (mc.ROOT / "atmoscatter" / "data" if cl["official"] else out) / "ms_accuracy.json"
    mc._atomic_write(js_path, json.dumps(js, indent=1) + "\n")
    print(text)
    print(f"wrote {out / 'ms_accurate_grid.md'} and {js_path} in {time.perf_counter() - t0:.0f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())

"""One-off check, not a generator of published files: the default and accurate grids'
error at sun −12° and −18° (ground observer, ``earth_turbidity_atmosphere(2.5)``) against
the reference grid of ``ms_convergence.py`` (same 72 directions, same floor).  These two
suns are not scenes of the study yet; the figures it printed on 2026-12-07 are quoted in
the issue-10 note, not in the docs.

Run:  PYTHONPATH=. python benchmarks/ms_deep_twilight_check.py   (about 15 min)
"""

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

import ms_convergence as mc  # noqa: E402

from atmoscatter.sky import multiple as ms  # noqa: E402

NAMES = []
for elevation in (-18.0, -12.0):
    name = f"sun_{elevation:g}"
    mc.SCENES[name] = ("earth_t2.5", elevation, 0.0, mc._GROUND_ZENITH)
    NAMES.append(name)
mc.warm_up()
atm = mc.ATMOSPHERES["earth_t2.5"]()
single = mc.single_of(atm, NAMES)
ref, t_ref, _ = mc.evaluate(atm, NAMES, mc.REFERENCE)
print(f"reference built in {t_ref:.0f} s", flush=True)
for label, cfg in [("default", mc.DEFAULT),
                   ("accurate", (ms.ACCURATE_MULTIPLE_SCATTERING_GRID, ms.DEFAULT_ORDER_TOLERANCE))]:
    out, _, first = mc.evaluate(atm, NAMES, cfg)
    for n in NAMES:
        e_tot, e_ms = mc.errors(out[n], ref[n], single[n])
        print(f"{label} {n}: total {e_tot:.2e}, MS part {e_ms:.2e}, first call {first[n]:.1f} s",
              flush=True)

"""Error against run time of the single-scattering methods (issue 5).

Usage (from the repository root)::

    PYTHONPATH=. python benchmarks/convergence.py            # full study -> docs/convergence/
    PYTHONPATH=. python benchmarks/convergence.py --quick    # tiny smoke run -> a temp dir

Writes ``convergence.csv``, ``convergence_table.md``, ``seed002_claim.md`` and
``convergence.png`` (included by ``docs/convergence.md``).  The full run takes a few
minutes on a 2-core machine.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path

from atmoscatter.convergence import CANONICAL_SCENES, convergence_study, write_report


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default=None, help="output directory (default docs/convergence)")
    ap.add_argument("--quick", action="store_true", help="smoke run: 2 scenes, few samples")
    ap.add_argument("--scenes", nargs="*", default=None, choices=sorted(CANONICAL_SCENES))
    ap.add_argument("--repeat", type=int, default=2, help="timing repetitions (best kept)")
    args = ap.parse_args(argv)
    if args.quick:
        scenes = args.scenes or ["clear_noon", "twilight_4deg"]
        samples = {"keller_bohn": (4, 8), "midpoint": (4, 8), "gauss_legendre": (4,), "graded": (3, 5)}
        kw = {"n_zenith": 4, "n_azimuth": 3, "reference_rtol": 1e-6, "repeat": 1}
        out = Path(args.out or tempfile.mkdtemp(prefix="atmoscatter-convergence-"))
    else:
        scenes = args.scenes
        samples = None
        kw = {"repeat": args.repeat}
        out = Path(args.out or Path(__file__).resolve().parents[1] / "docs" / "convergence")
    t0 = time.perf_counter()
    records, refs = convergence_study(scenes, samples, progress=print, **kw)
    paths = write_report(records, refs, out)
    print(f"wrote {', '.join(str(p) for p in paths.values())} in {time.perf_counter() - t0:.1f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())

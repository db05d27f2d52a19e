"""Print the multiple-scattering reference comparison tables (issue 10) for the docs.

Usage::

    PYTHONPATH=. python scripts/ms_reference_check.py [--mc-scale S] [--no-mc]

Part 1: plane-parallel DISORT benchmarks (``tests/test_rt_benchmarks.py``; published
correct answers of DISOTEST.f v2.1).  Part 2: sunset/twilight against the independent Monte
Carlo tracer of ``tests/test_montecarlo.py``; ``--mc-scale`` multiplies the path counts the
tests use (1 = the test's precision, hours for the deep-twilight cases; 0.01 for a look).
"""

from __future__ import annotations

import argparse
import os
import sys


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--mc-scale", type=float, default=0.01)
    ap.add_argument("--no-mc", action="store_true")
    args = ap.parse_args(argv)
    sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "tests"))
    import test_rt_benchmarks as pp

    print("| case | regime | level | UMU | reference [sr^-1] | ours | ours/ref |")
    print("|---|---|---|---|---|---|---|")
    for case, label, level, u, ref, ours, ratio in pp.benchmark_table():
        print(f"| {case} | {label} | {level} | {u:+.6f} | {ref:.5e} | {ours:.5e} | {ratio:.4f} |")
    if args.no_mc:
        return 0
    import test_montecarlo as mc

    print()
    print("| case | paths | MC [sr^-1] | ours | ours/MC | σ/MC | MS ours/MC | σ_MS/MS |")
    print("|---|---|---|---|---|---|---|---|")
    for name, n, ref, ours, ratio, rs, msr, msrs in mc.twilight_table(args.mc_scale):
        print(f"| {name} | {n} | {ref:.4e} | {ours:.4e} | {ratio:.4f} | {rs:.4f} | {msr:.4f} "
              f"| {msrs:.4f} |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

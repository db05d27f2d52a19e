"""Error against run time of the single-scattering methods (issue 5).

Usage (from the repository root)::

    PYTHONPATH=. python benchmarks/convergence.py            # full study -> docs/convergence/
    PYTHONPATH=. python benchmarks/convergence.py --quick    # tiny smoke run -> a temp dir

Writes ``convergence.csv``, ``convergence_table.md``, ``seed002_claim.md`` and
``convergence.png`` (:func:`atmoscatter.convergence.write_report`), plus three fragments
that ``docs/convergence.md`` includes:

* ``convergence_worst.md`` — worst case over the scenes per method and sample count;
* ``convergence_reference_check.md`` — the study's reference (``method="reference"``,
  ``rtol=1e-8``) and the default against an independent adaptive quadrature (SciPy
  ``quad_vec``, the ``_quad_single`` of ``tests/test_single.py``, which shares no code
  with the package's integrator) on the test module's cases;
* ``convergence_run.md`` — machine, date and command of the run.

The full run takes a few minutes on a 2-core machine.
"""

from __future__ import annotations

import argparse
import datetime
import os
import platform
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from atmoscatter.convergence import CANONICAL_SCENES, convergence_study, write_report

ROOT = Path(__file__).resolve().parents[1]
#: sample counts of the published rules shown in the worst-case table (their largest)
_WORST_OTHERS = ("gauss_legendre", "keller_bohn", "midpoint")


def _machine() -> str:
    try:
        load = f"load average {os.getloadavg()[0]:.1f} at the end"
    except OSError:  # pragma: no cover - not on every platform
        load = "load not known"
    cpu = platform.machine()
    try:
        with open("/proc/cpuinfo", encoding="utf-8") as f:
            cpu = next(ln.split(":", 1)[1].strip() for ln in f if ln.startswith("model name"))
    except (OSError, StopIteration):  # pragma: no cover - not Linux
        pass
    return f"{cpu}, {os.cpu_count()} CPUs (shared with other jobs: times are noisy), {load}"


def worst_case_table(records) -> str:
    """Markdown: per method and sample count, the worst max relative error over the scenes."""
    from atmoscatter.sky.single import (
        DEFAULT_SINGLE_SCATTERING_METHOD as DM,
    )
    from atmoscatter.sky.single import (
        DEFAULT_SINGLE_SCATTERING_SAMPLES as DS,
    )

    scenes = sorted({r.scene for r in records})
    lines = [f"Worst case over the {len(scenes)} scenes ({', '.join(scenes)}); the default "
             "method and sample count in bold.", "",
             "| method | samples | worst max rel. error | scene of the worst case "
             "| µs / direction (range over scenes) |", "|---|---:|---:|---|---|"]
    keys = list(dict.fromkeys((r.method, r.samples) for r in records if r.method != "table"))
    graded = sorted(k for k in keys if k[0] == DM)
    others = [max((k for k in keys if k[0] == m), key=lambda k: k[1])
              for m in _WORST_OTHERS if any(k[0] == m for k in keys)]
    for m, n in graded + others:
        rows = [r for r in records if r.method == m and r.samples == n]
        w = max(rows, key=lambda r: r.max_rel_error)
        us = [r.seconds_per_direction * 1e6 for r in rows]
        default = m == DM and n == DS[DM]
        b = "**" if default else ""
        lines.append(f"| {b}`{m}`{' (default)' if default else ''}{b} | {b}{n}{b} | "
                     f"{b}{w.max_rel_error:.1e}{b} | {w.scene} | {min(us):.0f}–{max(us):.0f} |")
    return "\n".join(lines) + "\n"


def reference_check(quick: bool) -> str:
    """Markdown: the reference and the default against the independent SciPy quadrature."""
    sys.path.insert(0, str(ROOT / "tests"))
    import test_single as T  # noqa: PLC0415 — the independent integrator lives with its tests

    from atmoscatter.sky.single import single_scattering  # noqa: PLC0415

    cases = T._CASES[:2] if quick else T._CASES
    lines = ["Independent check of the reference: `method=\"reference\"` (`rtol=1e-8`, the "
             "study's reference) and the default against SciPy's adaptive quadrature "
             "(`quad_vec`, `epsrel=1e-10`; `_quad_single` of `tests/test_single.py`, own "
             "geometry and optical lengths, no code shared with the package), max relative "
             "error over the case's directions and wavelengths.", "",
             "| case | observer altitude [m] | sun elevation [°] | directions "
             "| reference vs SciPy | default vs SciPy |", "|---|---:|---:|---:|---:|---:|"]
    for name, kw, alt, elev, dirs in cases:
        atm = T._exp_atmosphere(**kw)
        v = np.array([T._dir(*d) for d in dirs])
        s = T._sun(elev)
        q = np.array([T._quad_single(atm, vi, s, alt) for vi in v])
        ref = single_scattering(atm, v, s, altitude=alt, method="reference", rtol=1e-8)
        dflt = single_scattering(atm, v, s, altitude=alt)
        lines.append(f"| {name} | {alt:g} | {elev:g} | {len(v)} | {T._max_rel(ref, q):.1e} | "
                     f"{T._max_rel(dflt, q):.1e} |")
    return "\n".join(lines) + "\n"


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
        out = Path(args.out or ROOT / "docs" / "convergence")
    t0 = time.perf_counter()
    c0 = time.process_time()
    records, refs = convergence_study(scenes, samples, progress=print, **kw)
    paths = write_report(records, refs, out)
    (out / "convergence_worst.md").write_text(worst_case_table(records), encoding="utf-8")
    (out / "convergence_reference_check.md").write_text(reference_check(args.quick),
                                                        encoding="utf-8")
    cmd = "PYTHONPATH=. python benchmarks/convergence.py" + (" --quick" if args.quick else "")
    if args.scenes:
        cmd += " --scenes " + " ".join(args.scenes)
    (out / "convergence_run.md").write_text(
        f"Generated by `{cmd}` on {datetime.date.today().isoformat()}, {_machine()}, "
        f"Python {platform.python_version()}: {time.perf_counter() - t0:.0f} s wall, "
        f"{time.process_time() - c0:.0f} s CPU; timings are the best of "
        f"{kw['repeat']} run(s), single process.  Do not edit the tables by hand.\n",
        encoding="utf-8")
    print(f"wrote {', '.join(str(p) for p in paths.values())} and the convergence_*.md fragments "
          f"in {time.perf_counter() - t0:.1f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())

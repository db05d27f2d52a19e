"""Regenerate every published number: one entry point for all committed generators.

Usage (from the repository root)::

    python scripts/make_docs_data.py                  # full: rewrite docs/, atmoscatter/data/, notebooks/
    python scripts/make_docs_data.py --with-ms-study  # also the multiple-scattering studies
    python scripts/make_docs_data.py --quick --out DIR  # CI: every generator's quick mode, into DIR
    python scripts/make_docs_data.py --list           # the generators, their outputs and cost
    python scripts/make_docs_data.py --only gallery convergence  # a subset (full or quick)

Each generator is a committed script of ``scripts/`` or ``benchmarks/``, run in a
subprocess with the repository first on ``PYTHONPATH`` (so this checkout's package is the
one measured).  The full mode writes the files listed per generator (the pages include
them as generated fragments, see ``docs/`` and ``tests/test_docs_numbers.py``); the quick
mode runs the same scripts on tiny problems and writes only into ``--out`` (a temporary
directory by default), to prove in CI that they still work — its numbers are not for
publishing.

The multiple-scattering convergence study (``benchmarks/ms_convergence.py``), the
measurement of the named grids against a finer reference (``benchmarks/ms_accurate_grid.py``;
it rewrites ``atmoscatter/data/ms_accuracy.json``, the renderer's error statement) and the
twilight refinement of ``benchmarks/ms_deep_twilight.py`` run in
the full mode only with ``--with-ms-study``: minutes while their stored reference
(``docs/convergence/ms_reference_values.npz``) is current, half an hour more when the
method changed.  The quick mode always runs its smoke test.  The spectral-sampling study (~20 min) rewrites
``atmoscatter/data/spectral_sampling.json`` (the rule of ``sampling="auto"``); skip it with
``--skip spectral_sampling`` when only the pages are wanted.

``tests/test_docs_numbers.py`` checks that every script which writes a published file is
listed here.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


@dataclass(frozen=True)
class Generator:
    """One committed generator: how to run it in full and in quick mode, and what it writes."""

    name: str
    script: str  # path relative to the repository root
    full: tuple[str, ...]  # arguments of the full run
    quick: tuple[str, ...]  # arguments of the quick run; "{out}" = this generator's temp dir
    outputs: tuple[str, ...]  # files the full run writes (relative to the root)
    cost: str  # wall time of the full run on the shared 2-core development machine
    full_needs: str | None = None  # the flag that enables the full run (None: always)
    notes: str = field(default="")


GENERATORS: tuple[Generator, ...] = (
    Generator(
        "cmf_table", "scripts/make_cmf_table.py", (), ("--out", "{out}/cie1931_2deg_cmf.csv"),
        ("atmoscatter/data/cie1931_2deg_cmf.csv",), "seconds",
        notes="CIE 1931 2° colour-matching functions from colour-science"),
    Generator(
        "colourspace_table", "scripts/make_colourspace_table.py", (),
        ("--out", "{out}/colourspaces.json"), ("atmoscatter/data/colourspaces.json",), "seconds",
        notes="RGB colourspaces from colour-science"),
    Generator(
        "spa_nodes", "scripts/make_spa_nodes.py", (), ("--out", "{out}/spa_nodes.npz"),
        ("atmoscatter/data/spa_nodes.npz",), "seconds",
        notes="SPA time terms at 2-day nodes, 1900-2100"),
    Generator(
        "ms_references", "scripts/ms_reference_check.py",
        ("--out", "docs/validation/ms_references.md"),
        ("--quick", "--out", "{out}/ms_references.md"),
        ("docs/validation/ms_references.md",), "~10 min",
        notes="multiple scattering against DISORT's published answers and the Monte Carlo tracer"),
    Generator(
        "convergence", "benchmarks/convergence.py", (), ("--quick", "--out", "{out}"),
        tuple(f"docs/convergence/{n}" for n in (
            "convergence.csv", "convergence_table.md", "seed002_claim.md", "convergence.png",
            "convergence_worst.md", "convergence_reference_check.md", "convergence_run.md")),
        "~3 min", notes="single scattering: error against run time"),
    Generator(
        "table_accuracy", "benchmarks/table_accuracy.py",
        ("--out", "docs/convergence/table_accuracy.md"),
        ("--quick", "--out", "{out}/table_accuracy.md"),
        ("docs/convergence/table_accuracy.md",), "~5 min",
        notes="single-scattering table path: size against error and build time"),
    Generator(
        "spectral_sampling", "benchmarks/spectral_sampling.py", (), ("--quick", "--out", "{out}"),
        ("docs/convergence/spectral_sampling.md", "docs/convergence/spectral_sampling.csv",
         "atmoscatter/data/spectral_sampling.json", "docs/numerical_scattering.md"),
        "~20 min", notes="3 wavelengths against a spectrum; the rule of sampling='auto'"),
    Generator(
        "ms_convergence", "benchmarks/ms_convergence.py", (), ("--quick", "--out", "{out}"),
        ("docs/convergence/ms_convergence.csv", "docs/convergence/ms_convergence_table.md",
         "docs/convergence/ms_convergence.png", "docs/convergence.md",
         "docs/convergence/ms_reference_values.npz"),
        "~3 min (+30 when the stored reference is stale)", full_needs="--with-ms-study",
        notes="multiple scattering: error against build time per grid knob"),
    Generator(
        "ms_accurate_grid", "benchmarks/ms_accurate_grid.py", (), ("--quick", "--out", "{out}"),
        ("docs/convergence/ms_accurate_grid.md", "atmoscatter/data/ms_accuracy.json",
         "docs/convergence/ms_reference_values.npz"), "~3 min (+30 when the stored reference is stale)",
        full_needs="--with-ms-study",
        notes="multiple scattering: default and accurate grid against a grid finer in every "
              "knob; the EXR header's figures"),
    Generator(
        "ms_deep_twilight", "benchmarks/ms_deep_twilight.py", (), ("--quick", "--out", "{out}"),
        ("docs/convergence/ms_deep_twilight.md",), "~6 min", full_needs="--with-ms-study",
        notes="multiple scattering: the default grid's horizon_n_sun refined in twilight, "
              "against the study's stored reference (run after ms_convergence)"),
    Generator(
        "ms_band_width", "benchmarks/ms_band_width.py", (), ("--quick", "--out", "{out}"),
        ("docs/convergence/ms_band_width.md",), "~15 min", full_needs="--with-ms-study",
        notes="multiple scattering: the band of high orders, narrow and full, against every "
              "node computed (one answer)"),
    Generator(
        "ms_space", "benchmarks/ms_space.py", (), ("--quick", "--out", "{out}"),
        ("docs/convergence/ms_space.md",), "~6 min", full_needs="--with-ms-study",
        notes="multiple scattering from space: the band widened by the dip against every "
              "node, and space_day_n_sun against more solar-zenith nodes"),
    Generator(
        "startup", "benchmarks/bench_startup.py", ("--write",), ("--quick",),
        ("docs/cli.md",), "~1 min", notes="start-up and first-render times of the CLI"),
    Generator(
        "memory", "benchmarks/bench_memory.py", ("--out", "docs/theory/render_memory.md"),
        ("--quick", "--out", "{out}/render_memory.md"), ("docs/theory/render_memory.md",),
        "~5 min", notes="peak memory of 8192 x 4096 renders against their output"),
    Generator(
        "docs_numbers", "scripts/docs_numbers.py", (), ("--quick", "--out", "{out}"),
        ("docs/numbers/*.md",), "~10 min",
        notes="measured numbers of the integrals, analytic-sky, sun, oracle and render pages"),
    Generator(
        "validation_report", "scripts/validation_report.py", (), ("--quick", "--out", "{out}"),
        ("docs/validation.md", "docs/validation/models.csv", "docs/validation/brightness.csv",
         "docs/validation/*.png"),
        "~60 min", notes="analytic models against the physical reference; sun against pvlib"),
    Generator(
        "gallery", "scripts/gallery.py", (), ("--quick", "--out", "{out}"),
        ("docs/gallery.md", "docs/gallery/*.png"), "~20 min CPU",
        notes="the gallery at physical exposure (quick: one tiny frame per series; its cost "
              "is the multiple-scattering field builds not yet in the disk cache)"),
    Generator(
        "user_guide_images", "scripts/user_guide_images.py", (), ("--quick", "--out", "{out}"),
        ("docs/images/*.png",), "~10 min",
        notes="the pictures of the user guide (projections, one exposure for every model)"),
    Generator(
        "daylighting", "scripts/daylighting_radiance.py", ("--write",), (),
        ("docs/daylighting.md",), "~1 min",
        notes="CIE standard and Perez all-weather skies against Radiance (needs pyradiance)"),
    Generator(
        "weather_year", "benchmarks/bench_weather.py", ("--write",), ("--quick",),
        ("docs/daylighting.md",), "~5 min",
        notes="a year of Perez skies from the test EPW at 256x128: run time (needs pvlib)"),
    Generator(
        "notebooks", "scripts/run_notebooks.py", (), ("--quick", "--out", "{out}"),
        ("notebooks/*.ipynb",), "~15 min",
        notes="executes notebooks/*.ipynb and stores their outputs (quick: the cheap ones)"),
)


def _selected(args) -> list[Generator]:
    names = {g.name for g in GENERATORS}
    for n in (args.only or []) + (args.skip or []):
        if n not in names:
            raise SystemExit(f"unknown generator {n!r}; known: {', '.join(sorted(names))}")
    gens = [g for g in GENERATORS if (not args.only or g.name in args.only)
            and g.name not in (args.skip or [])]
    if not args.quick:
        flags = {"--with-ms-study": args.with_ms_study}
        gens = [g for g in gens if g.full_needs is None or flags[g.full_needs]
                or (args.only and g.name in args.only)]
    return gens


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true",
                    help="quick mode of every generator, into --out (CI); nothing in docs/ changes")
    ap.add_argument("--out", default=None, help="output directory of --quick (default: a temp dir)")
    ap.add_argument("--with-ms-study", action="store_true",
                    help="full mode: also run the multiple-scattering studies")
    ap.add_argument("--only", nargs="+", metavar="NAME", help="run only these generators")
    ap.add_argument("--skip", nargs="+", metavar="NAME", help="do not run these generators")
    ap.add_argument("--list", action="store_true", help="list the generators and exit")
    ap.add_argument("--keep-going", action="store_true",
                    help="run the remaining generators after a failure (exit status still 1)")
    args = ap.parse_args(argv)
    if args.out and not args.quick:
        ap.error("--out is for --quick (the full mode writes into docs/ and atmoscatter/data/)")
    if args.list:
        for g in GENERATORS:
            gate = f" (full run only with {g.full_needs})" if g.full_needs else ""
            print(f"{g.name:18s} {g.script:34s} {g.cost:>8s}{gate}\n{'':18s} {g.notes}\n"
                  f"{'':18s} writes: {', '.join(g.outputs)}")
        return 0
    gens = _selected(args)
    base = Path(args.out or tempfile.mkdtemp(prefix="atmoscatter-docs-data-")) if args.quick else None
    env = dict(os.environ, MPLBACKEND="Agg",
               PYTHONPATH=os.pathsep.join([str(ROOT)] + [p for p in os.environ.get(
                   "PYTHONPATH", "").split(os.pathsep) if p]))
    failed, summary = [], []
    for g in gens:
        if args.quick:
            out = base / g.name
            out.mkdir(parents=True, exist_ok=True)
            cmd_args = [a.replace("{out}", str(out)) for a in g.quick]
        else:
            cmd_args = list(g.full)
        cmd = [sys.executable, str(ROOT / g.script), *cmd_args]
        print(f"== {g.name}: {' '.join([g.script, *cmd_args])}", flush=True)
        t0 = time.perf_counter()
        log = (base / g.name / "log.txt") if args.quick else None
        with open(log, "w", encoding="utf-8") if log else open(os.devnull, "w") as sink:
            proc = subprocess.run(cmd, cwd=ROOT, env=env, stdout=sink if args.quick else None,
                                  stderr=subprocess.STDOUT if args.quick else None, check=False)
        dt = time.perf_counter() - t0
        summary.append((g.name, proc.returncode, dt))
        if proc.returncode:
            failed.append(g.name)
            if log:
                sys.stdout.write(log.read_text(encoding="utf-8")[-4000:])
            print(f"!! {g.name} failed (exit {proc.returncode}) after {dt:.0f} s", flush=True)
            if not args.keep_going:
                break
    print("\n".join(f"{n:18s} {'ok' if rc == 0 else f'FAILED ({rc})':12s} {dt:7.1f} s"
                    for n, rc, dt in summary))
    if args.quick:
        print(f"quick outputs in {base}")
    elif not args.with_ms_study and not args.only:
        print("ms_convergence not run: add --with-ms-study to regenerate it")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())

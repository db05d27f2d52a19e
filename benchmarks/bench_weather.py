"""A year of skies from a weather file: every daylit hour of a TMY3 EPW at 256×128.

Run:   python -m pytest benchmarks/bench_weather.py --benchmark-only
Quick: python -m pytest benchmarks/bench_weather.py --benchmark-disable   (CI: runs once)

By default (the quick pass) a few hours of one day are rendered; ``ATMOSCATTER_BENCH_FULL=1``
renders the whole year.  As a script it measures the whole year once and, with ``--write``,
puts the result into ``docs/daylighting.md`` (generated block ``weather_year``); ``--quick``
renders a few hours and only prints::

    PYTHONPATH=. python benchmarks/bench_weather.py --write     # ~5 min on 2 loaded cores
    PYTHONPATH=. python benchmarks/bench_weather.py --quick

The batch is the one ``atmoscatter batch --weather tests/data/…epw --set width=256 --set
height=128 --workers 2`` runs (model ``perez_all_weather``, RGB float EXR files); wall time
and CPU time (this process and its workers) are reported, with the load average, since the
development machine is shared.
"""

from __future__ import annotations

import argparse
import datetime
import os
import platform
import resource
import sys
import tempfile
import time
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
EPW = ROOT / "tests" / "data" / "USA_IL_Chicago-OHare.Intl.AP.725300_TMY3.epw"
DOC = ROOT / "docs" / "daylighting.md"
FULL = os.environ.get("ATMOSCATTER_BENCH_FULL") == "1"
SIZE = (256, 128)
#: the quick selection: every third hour of the summer solstice
QUICK_HOURS, QUICK_EVERY = "6/21", 3


def _cpu() -> float:
    own = resource.getrusage(resource.RUSAGE_SELF)
    kids = resource.getrusage(resource.RUSAGE_CHILDREN)
    return own.ru_utime + own.ru_stime + kids.ru_utime + kids.ru_stime


def year_of_skies(out_dir, *, hours=None, every=1, workers=2) -> dict:
    """Render the selected daylit hours of the test EPW; wall and CPU time [s] and counts."""
    from atmoscatter.batch import run_batch, weather_batch  # noqa: PLC0415

    load0 = os.getloadavg()[0]
    t0, c0 = time.perf_counter(), _cpu()
    wb = weather_batch(EPW, hours=hours, every=every,
                       overrides={"width": SIZE[0], "height": SIZE[1]})
    summary = run_batch(wb.items, out_dir, workers=workers, progress=False,
                        rejected=wb.rejected)
    wall, cpu = time.perf_counter() - t0, _cpu() - c0
    return {"skies": summary.count("done"), "failed": summary.count("failed"),
            "night": wb.night, "selected": len(wb.table["row"]), "wall": wall, "cpu": cpu,
            "workers": workers, "load": (load0, os.getloadavg()[0]), "site": wb.site.name}


def fragment(r: dict) -> str:
    """The Markdown block of docs/daylighting.md."""
    per = r["wall"] / max(r["skies"], 1)
    return "\n".join([
        f"Measured on {datetime.date.today().isoformat()}, {platform.machine()}, "
        f"{os.cpu_count()} CPUs shared with other jobs (load average {r['load'][0]:.1f} at "
        f"the start, {r['load'][1]:.1f} at the end), `--workers {r['workers']}`:",
        "",
        "| weather file | hours | skies rendered | night (skipped) | size | wall time | "
        "CPU time | wall per sky |",
        "|---|---|---|---|---|---|---|---|",
        f"| {r['site']} TMY3 | {r['selected']} | {r['skies']} | {r['night']} | "
        f"{SIZE[0]}×{SIZE[1]} | {r['wall']:.0f} s | {r['cpu']:.0f} s | {per * 1e3:.0f} ms |",
    ])


@pytest.mark.skipif(not EPW.exists(), reason="the test EPW file is not in this checkout")
def test_weather_year(benchmark, tmp_path):
    pytest.importorskip("pvlib")
    hours, every = (None, 1) if FULL else (QUICK_HOURS, QUICK_EVERY)
    runs = iter(range(10**6))

    def go():
        return year_of_skies(tmp_path / f"run{next(runs)}", hours=hours, every=every)

    r = benchmark.pedantic(go, rounds=1, iterations=1)
    benchmark.extra_info.update(skies=r["skies"], cpu_seconds=round(r["cpu"], 1))
    assert r["failed"] == 0 and r["skies"] > 0


def _replace(text: str, key: str, body: str) -> str:
    import re  # noqa: PLC0415

    pat = re.compile(rf"(<!-- {key}:begin[^\n]*-->\n).*?(<!-- {key}:end -->)", re.S)
    if not pat.search(text):
        raise SystemExit(f"markers {key}:begin/end not found in {DOC}")
    return pat.sub(lambda m: m.group(1) + body + "\n" + m.group(2), text)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--write", action="store_true", help="update docs/daylighting.md")
    ap.add_argument("--quick", action="store_true", help="a few hours (smoke test), print only")
    ap.add_argument("--workers", type=int, default=2, help="local processes (default 2)")
    args = ap.parse_args(argv)
    hours, every = (QUICK_HOURS, QUICK_EVERY) if args.quick else (None, 1)
    with tempfile.TemporaryDirectory(prefix="atmoscatter-weather-") as tmp:
        r = year_of_skies(tmp, hours=hours, every=every, workers=args.workers)
    text = fragment(r)
    print(text)
    if r["failed"]:
        print(f"{r['failed']} hours failed", file=sys.stderr)
        return 1
    if args.write and not args.quick:
        from atmoscatter.exr import atomic_write  # noqa: PLC0415

        page = _replace(DOC.read_text(encoding="utf-8"), "weather_year", text)
        with atomic_write(DOC) as tmp, open(tmp, "w", encoding="utf-8") as fh:
            fh.write(page)
    return 0


if __name__ == "__main__":
    sys.exit(main())

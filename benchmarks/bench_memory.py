"""Peak memory of big renders against the size of their output (issue 11, deliverable 3).

Run:   python benchmarks/bench_memory.py            (8192 × 4096: RGB, RGBA, half RGB; minutes)
Docs:  python benchmarks/bench_memory.py --out docs/theory/render_memory.md   (the fragment
       docs/theory/render.md includes; scripts/make_docs_data.py runs it)
Quick: python benchmarks/bench_memory.py --quick    (2048 × 1024; CI runs it through pytest:
       python -m pytest benchmarks/bench_memory.py --benchmark-disable)

Each case is ``atmoscatter render --set width=W --set height=H [...] -o map.exr`` in its own
process; its peak resident set size is the child's ``ru_maxrss`` (``os.wait4``).  It is set
against

* the output: the float32 layers the render returns, one W × H plane per EXR channel
  (channels × W × H × 4 bytes, whatever the file's pixel type), which it has to hold;
* the process's fixed footprint: the same command at 64 × 32 (interpreter, NumPy, numba and
  its compiled kernels, OpenEXR), which does not grow with the map.

What is left, ``peak − output − fixed``, is the render's size-dependent working set: the
evaluated-sky mask (1 byte a pixel), the half-float planes of a ``precision=half`` file (2 bytes
a pixel and channel; OpenEXR's Python bindings write whole channels, so they cannot be
converted a batch at a time) and the bounded per-batch temporaries.
"""

import os
import subprocess
import sys
import tempfile

import pytest

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
MIB = 2.0**20

#: (label, extra ``--set`` assignments) of the measured renders.
CASES = [("RGB float", []), ("RGBA float", ["alpha=true"]), ("RGB half", ["precision=half"])]


def _env():
    return dict(os.environ, PYTHONPATH=os.pathsep.join([ROOT, os.environ.get("PYTHONPATH", "")]))


def _maxrss_bytes(ru) -> int:
    # Linux reports kibibytes, macOS bytes
    return int(ru.ru_maxrss) * (1 if sys.platform == "darwin" else 1024)


def _float32_bytes(path) -> int:
    """Bytes of one float32 W × H plane per channel of an EXR file (from its header)."""
    import OpenEXR  # noqa: PLC0415

    with OpenEXR.File(path, header_only=True) as f:
        h = dict(f.header())  # (leaving the block clears the dict the bindings return)
    lo, hi = h["dataWindow"]
    n = int(hi[0] - lo[0] + 1) * int(hi[1] - lo[1] + 1)
    return n * len(h["channels"]) * 4


def peak_rss(width: int, height: int, sets=(), workers: int = 2):
    """``(peak RSS [bytes], output [bytes])`` of ``atmoscatter render`` in a child process:
    the child's ``ru_maxrss`` and one float32 plane per channel of the EXR it wrote."""
    with tempfile.TemporaryDirectory() as tmp:
        out = os.path.join(tmp, "map.exr")
        args = [sys.executable, "-m", "atmoscatter", "render", "--quiet", "--workers",
                str(workers), "--set", f"width={width}", "--set", f"height={height}"]
        for s in sets:
            args += ["--set", s]
        proc = subprocess.Popen([*args, "-o", out], env=_env(), cwd=tmp, stdout=subprocess.DEVNULL,
                                stderr=subprocess.PIPE)
        _, status, ru = os.wait4(proc.pid, 0)
        proc.returncode = os.waitstatus_to_exitcode(status)
        err = proc.stderr.read().decode(errors="replace")
        proc.stderr.close()
        if proc.returncode != 0:
            raise RuntimeError(f"{' '.join(args)} failed ({proc.returncode}): {err}")
        return _maxrss_bytes(ru), _float32_bytes(out)


def measure(width: int, height: int, cases=CASES):
    """One row per case: label, peak, output, fixed footprint and the size-dependent rest."""
    rows = []
    for label, sets in cases:
        fixed, _ = peak_rss(64, 32, sets)
        peak, output = peak_rss(width, height, sets)
        rows.append({"case": label, "peak": peak, "output": output, "fixed": fixed,
                     "working": peak - output - fixed, "pixels": width * height})
    return rows


def table(width: int, height: int, cases=CASES) -> str:
    """Markdown table of :func:`measure`, with the machine, date and command."""
    import datetime  # noqa: PLC0415
    import platform  # noqa: PLC0415

    rows = measure(width, height, cases)
    load = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")
    lines = [f"Peak RSS of `atmoscatter render --set width={width} --set height={height} "
             f"[--set …] -o map.exr --workers 2`, {datetime.date.today().isoformat()}, "
             f"{platform.machine()}, {os.cpu_count()} CPUs, load average {load:.1f}, "
             f"Python {platform.python_version()} (`python benchmarks/bench_memory.py`; "
             f"generated, do not edit):",
             "", "| case | peak RSS | output (float32 planes) | peak / output | fixed footprint "
             "(64 × 32) | size-dependent rest | per pixel |",
             "| --- | --- | --- | --- | --- | --- | --- |"]
    for r in rows:
        lines.append(f"| {r['case']} | {r['peak'] / MIB:.0f} MiB | {r['output'] / MIB:.0f} MiB | "
                     f"{r['peak'] / r['output']:.2f} | {r['fixed'] / MIB:.0f} MiB | "
                     f"{r['working'] / MIB:.0f} MiB | {r['working'] / r['pixels']:.2f} B |")
    return "\n".join(lines)


def test_peak_memory_quick():
    """CI smoke run at 2048 × 1024 (RGB float): the script works and the size-dependent rest
    stays a few bytes a pixel (the mask's 1 byte plus batch temporaries; an interleaved copy
    of the map would add 12)."""
    if not hasattr(os, "wait4"):
        pytest.skip("needs os.wait4 (POSIX) for the child's peak RSS")
    (row,) = measure(2048, 1024, CASES[:1])
    print(f"\n{row['case']} 2048x1024: peak {row['peak'] / MIB:.0f} MiB, output "
          f"{row['output'] / MIB:.0f} MiB, fixed {row['fixed'] / MIB:.0f} MiB")
    assert row["output"] == 2048 * 1024 * 3 * 4
    assert row["working"] < 6.0 * row["pixels"], row


def main(argv=None) -> int:
    """Print the table (8192 × 4096, or 2048 × 1024 with ``--quick``)."""
    import argparse  # noqa: PLC0415

    ap = argparse.ArgumentParser(description=main.__doc__)
    ap.add_argument("--quick", action="store_true", help="2048 x 1024 (smoke test)")
    ap.add_argument("--size", nargs=2, type=int, metavar=("W", "H"), default=None)
    ap.add_argument("--out", default=None,
                    help="also write the table to this Markdown file (the docs fragment)")
    args = ap.parse_args(argv)
    w, h = args.size or ((2048, 1024) if args.quick else (8192, 4096))
    text = table(w, h)
    print(text)
    if args.out:
        os.makedirs(os.path.dirname(os.path.abspath(args.out)), exist_ok=True)
        with open(args.out, "w", encoding="utf-8") as f:
            f.write(text + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())

"""Execute the example notebooks and store their outputs, so the committed notebooks show
what the current package prints and plots.

Usage (from the repository root)::

    python scripts/run_notebooks.py                    # every notebooks/*.ipynb, in place
    python scripts/run_notebooks.py quickstart models  # some of them (file stems)
    python scripts/run_notebooks.py --quick --out DIR  # CI: the cheap ones, into DIR
    python scripts/run_notebooks.py --list             # the notebooks and their cost class

Each notebook runs top to bottom in a fresh kernel (nbclient) with this checkout first on
``PYTHONPATH``, in a temporary working directory (files a notebook writes never land in
``notebooks/``), with a fresh empty ``ATMOSCATTER_CACHE_DIR`` (so a multiple-scattering
field is built, as a new user's first run builds it) and ``PYTHONHASHSEED=0``.  Figures
are captured by the inline backend (rendered with matplotlib's Agg) as PNG at 80 dpi; the
kernel's IPython configuration comes from a temporary ``IPYTHONDIR``, so the user's own
profile never changes the stored outputs.

What is stored is made reproducible: execution timestamps (``metadata.execution``) are not
recorded, the notebook metadata is reduced to the kernel spec and the language name (no
Python version), and cells without an id get ``cell-<index>``.  Outputs that measure run
time (``error_vs_runtime``) change from run to run by nature; everything else is the same
on every run on the same versions of the package and its dependencies.

A notebook whose metadata has ``"atmoscatter": {"extended": true}`` takes long (more than
~10 s): ``tests/test_notebooks.py`` executes it only in the ``extended`` test step, and
``--quick`` leaves it out unless ``--all`` is given.  ``"atmoscatter": {"slow": true}``
(minutes: ``error_vs_runtime`` times whole multiple-scattering fields) executes only with
``-m slow`` and in this script's full mode; CI checks its stored outputs (cheap) and runs
the studies behind it in their quick modes.  ``--quick`` never writes into
``notebooks/``; it stores the executed copies in ``--out`` (a temp dir by default).
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
NOTEBOOKS = ROOT / "notebooks"

#: Inline-backend settings of the kernel: small PNG figures (file sizes stay modest)
KERNEL_CONFIG = """\
c.InlineBackend.figure_formats = {"png"}
c.InlineBackend.rc = {"figure.dpi": 80, "savefig.dpi": 80, "figure.figsize": (6.0, 4.0),
                      "figure.facecolor": "white", "figure.edgecolor": "white"}
"""

#: The kernel spec written into every notebook (the language version is not stored)
KERNELSPEC = {"display_name": "Python 3", "language": "python", "name": "python3"}

TIMEOUT = 1800  # [s] per cell: a multiple-scattering field build on a loaded 2-core machine


def notebook_paths(names=None) -> list[Path]:
    """The notebooks of ``notebooks/`` (sorted), or those whose stems are ``names``."""
    paths = sorted(NOTEBOOKS.glob("*.ipynb"))
    if names:
        known = {p.stem: p for p in paths}
        unknown = [n for n in names if n not in known]
        if unknown:
            raise SystemExit(f"unknown notebook(s) {unknown}; known: {', '.join(sorted(known))}")
        paths = [known[n] for n in names]
    return paths


def tier(path) -> str:
    """``"quick"``, ``"extended"`` or ``"slow"`` (``metadata.atmoscatter``; see above)."""
    meta = json.loads(Path(path).read_text(encoding="utf-8")).get("metadata", {})
    flags = meta.get("atmoscatter", {})
    if flags.get("slow", False):
        return "slow"
    return "extended" if flags.get("extended", False) else "quick"


def is_extended(path) -> bool:
    """Whether the notebook is marked long-running (extended or slow)."""
    return tier(path) != "quick"


def kernel_env(scratch: Path) -> dict:
    """Environment of the kernel: this checkout first on the path, inline PNG figures,
    a fresh cache and IPython profile under ``scratch``, fixed hash seed."""
    ipy = scratch / "ipython"
    (ipy / "profile_default").mkdir(parents=True, exist_ok=True)
    (ipy / "profile_default" / "ipython_kernel_config.py").write_text(KERNEL_CONFIG)
    (scratch / "cache").mkdir(exist_ok=True)
    env = dict(os.environ)
    env.update(
        PYTHONPATH=os.pathsep.join([str(ROOT)] + [p for p in os.environ.get(
            "PYTHONPATH", "").split(os.pathsep) if p]),
        MPLBACKEND="module://matplotlib_inline.backend_inline",
        IPYTHONDIR=str(ipy),
        ATMOSCATTER_CACHE_DIR=str(scratch / "cache"),
        PYTHONHASHSEED="0",
    )
    env.pop("JPY_PARENT_PID", None)
    return env


def clean(nb) -> None:
    """Make the stored notebook reproducible (in place): no timestamps, fixed metadata,
    deterministic cell ids, no outputs of markdown cells."""
    extra = nb.metadata.get("atmoscatter")
    nb.metadata = {"kernelspec": dict(KERNELSPEC), "language_info": {"name": "python"}}
    if extra is not None:
        nb.metadata["atmoscatter"] = extra
    for i, cell in enumerate(nb.cells):
        cell.metadata.pop("execution", None)
        cell.metadata.pop("ExecuteTime", None)
        if not cell.get("id"):
            cell["id"] = f"cell-{i}"


def execute(path, workdir=None, *, timeout=TIMEOUT):
    """Execute the notebook at ``path`` in a fresh kernel; return the executed notebook
    (outputs cleaned by :func:`clean`) and the kernel's CPU time [s] and wall time [s].

    ``workdir`` (default: a temporary directory) is the kernel's working directory.
    """
    import nbclient  # noqa: PLC0415
    import nbformat  # noqa: PLC0415

    nb = nbformat.read(str(path), as_version=4)
    for cell in nb.cells:
        if cell.cell_type == "code":
            cell.outputs, cell.execution_count = [], None
    scratch = Path(tempfile.mkdtemp(prefix="atmoscatter-nb-"))
    try:
        work = Path(workdir) if workdir is not None else scratch / "work"
        work.mkdir(parents=True, exist_ok=True)
        # the last cell reports the kernel's CPU time; it is removed before storing
        nb.cells.append(nbformat.v4.new_code_cell(
            "import resource as _r, json as _j\n_u = _r.getrusage(_r.RUSAGE_SELF)\n"
            "print(_j.dumps(_u.ru_utime + _u.ru_stime))"))
        client = nbclient.NotebookClient(
            nb, timeout=timeout, kernel_name="python3", record_timing=False,
            resources={"metadata": {"path": str(work)}})
        t0 = time.perf_counter()
        client.execute(env=kernel_env(scratch))
        wall = time.perf_counter() - t0
    finally:
        shutil.rmtree(scratch, ignore_errors=True)
    probe = nb.cells.pop()
    cpu = float(probe.outputs[0]["text"]) if probe.outputs else float("nan")
    clean(nb)
    return nb, cpu, wall


def errors(nb) -> list[str]:
    """The error outputs of an executed notebook (``ename: evalue`` per error)."""
    return [f"{o.get('ename')}: {o.get('evalue')}" for c in nb.cells if c.cell_type == "code"
            for o in c.get("outputs", []) if o.get("output_type") == "error"]


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("names", nargs="*", help="notebook stems (default: every notebook)")
    ap.add_argument("--quick", action="store_true",
                    help="execute into --out instead of writing back (CI); leaves out the "
                    "extended notebooks unless --all")
    ap.add_argument("--all", action="store_true", help="with --quick: the extended ones too")
    ap.add_argument("--out", default=None, help="directory of --quick (default: a temp dir)")
    ap.add_argument("--list", action="store_true", help="list the notebooks and exit")
    args = ap.parse_args(argv)
    if args.out and not args.quick:
        ap.error("--out is for --quick (the full mode rewrites notebooks/ in place)")
    paths = notebook_paths(args.names)
    if args.list:
        for p in paths:
            print(f"{p.stem:20s} {tier(p)}")
        return 0
    if args.quick and not args.all and not args.names:
        paths = [p for p in paths if not is_extended(p)]
    import nbformat  # noqa: PLC0415

    out = Path(args.out or tempfile.mkdtemp(prefix="atmoscatter-notebooks-")) if args.quick else None
    if out is not None:
        out.mkdir(parents=True, exist_ok=True)
    failed = []
    for p in paths:
        print(f"== {p.name}", flush=True)
        try:
            nb, cpu, wall = execute(p)
        except Exception as exc:  # noqa: BLE001 - nbclient's CellExecutionError and timeouts
            print(f"   FAILED: {type(exc).__name__}: {str(exc)[-2000:]}", flush=True)
            failed.append(p.stem)
            continue
        bad = errors(nb)
        print(f"   {cpu:.1f} s CPU (kernel), {wall:.1f} s wall"
              + (f"; ERRORS: {bad}" if bad else ""), flush=True)
        if bad:
            failed.append(p.stem)
            continue  # a failed run never replaces the committed outputs
        target = (out / p.name) if out is not None else p
        nbformat.write(nb, str(target))
    if out is not None:
        print(f"executed notebooks in {out}")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())

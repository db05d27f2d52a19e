"""Many scenes: tables, sweeps, progress, resume, failure isolation, local processes or Dask.

Public objects
--------------
:func:`load_batch`
    Read the scenes of a batch from a CSV table (a header of scene fields plus a
    ``name`` column giving each output's file stem) or a TOML file (``[base]``
    fields, ``[[scene]]`` entries and/or a ``[sweep]`` of parameter values).
:func:`expand_sweep`
    Cartesian product of parameter lists and ranges (e.g. every hour of a year).
:func:`run_batch`
    Render every scene to ``DIR/<name>.exr``: complete outputs are skipped
    (resume), partial ones redone, a failing scene is reported without losing
    the others, and a summary is returned and written to
    ``DIR/batch_summary.json``.  Runs in this process, in ``workers`` local
    processes, or on a Dask distributed cluster (``client=`` or
    ``scheduler=`` address; optional extra ``atmoscatter[dask]``).
:class:`BatchResult`, :class:`BatchSummary`
"""

from __future__ import annotations

import csv
import datetime as _dt
import glob
import itertools
import json
import os
import re
import sys
import time
from concurrent.futures import ProcessPoolExecutor, as_completed
from dataclasses import asdict, dataclass, field

import numpy as np

__all__ = ["load_batch", "expand_sweep", "run_batch", "BatchResult", "BatchSummary"]

_NAME_RE = re.compile(r"^[A-Za-z0-9._+-]+$")


@dataclass
class BatchResult:
    """Outcome of one scene: ``status`` is ``done``, ``skipped`` (already complete) or ``failed``."""

    name: str
    path: str
    status: str
    seconds: float = 0.0
    error: str = ""


@dataclass
class BatchSummary:
    """All results of a batch, with counts and a readable report."""

    results: list = field(default_factory=list)
    seconds: float = 0.0

    def count(self, status: str) -> int:
        return sum(r.status == status for r in self.results)

    @property
    def failed(self) -> list:
        return [r for r in self.results if r.status == "failed"]

    @property
    def ok(self) -> bool:
        return not self.failed

    def text(self) -> str:
        lines = [
            f"{len(self.results)} scenes: {self.count('done')} rendered, "
            f"{self.count('skipped')} already complete (skipped), {self.count('failed')} failed "
            f"in {self.seconds:.1f} s"
        ]
        for r in self.failed:
            lines.append(f"  FAILED {r.name}: {r.error}")
        return "\n".join(lines)

    def to_dict(self) -> dict:
        return {"seconds": self.seconds, "done": self.count("done"),
                "skipped": self.count("skipped"), "failed": self.count("failed"),
                "results": [asdict(r) for r in self.results]}


# ----------------------------------------------------------------------------
# reading batches
# ----------------------------------------------------------------------------
_STEP_RE = re.compile(r"^\s*([0-9.]+)\s*(s|sec|min|m|h|d)\s*$")
_UNITS = {"s": 1, "sec": 1, "min": 60, "m": 60, "h": 3600, "d": 86400}


def _range_values(key, spec):
    if not isinstance(spec, dict) or not {"start", "stop", "step"} <= set(spec):
        raise ValueError(f"sweep {key}: a range needs start, stop and step, got {spec!r}")
    start, stop, step = spec["start"], spec["stop"], spec["step"]
    if key == "time" or isinstance(start, (str, _dt.datetime)):
        from .scene import parse_time  # noqa: PLC0415

        t0, t1 = parse_time(start), parse_time(stop)
        m = _STEP_RE.match(str(step))
        if not m:
            raise ValueError(f"sweep {key}: step must look like '1h', '30min', '1d', got {step!r}")
        dt = _dt.timedelta(seconds=float(m.group(1)) * _UNITS[m.group(2)])
        if dt.total_seconds() <= 0:
            raise ValueError(f"sweep {key}: step must be positive, got {step!r}")
        out, t = [], t0
        while t <= t1:
            out.append(t.strftime("%Y-%m-%dT%H:%M:%SZ"))
            t += dt
        return out
    start, stop, step = float(start), float(stop), float(step)
    if step <= 0:
        raise ValueError(f"sweep {key}: step must be positive, got {step!r}")
    n = int(np.floor((stop - start) / step + 1e-9)) + 1
    return [start + i * step for i in range(max(n, 0))]


def expand_sweep(sweep: dict) -> list[dict]:
    """Cartesian product of a sweep table.

    Each key is a scene field whose value is a list of values or a range
    ``{start, stop, step}`` (numbers, or ISO times with a step such as
    ``"1h"``; ``stop`` included).  The optional key ``name`` is a
    :meth:`str.format` template over the fields and ``index`` (default
    ``"sky_{index:05d}"``).
    """
    sweep = dict(sweep)
    template = sweep.pop("name", "sky_{index:05d}")
    keys, values = [], []
    for k, v in sweep.items():
        keys.append(k)
        values.append(list(v) if isinstance(v, (list, tuple)) else _range_values(k, v))
    rows = []
    for i, combo in enumerate(itertools.product(*values)):
        row = dict(zip(keys, combo, strict=True))
        fmt = {k: _safe(v) for k, v in row.items()}
        try:
            name = template.format(index=i, **fmt)
        except (KeyError, IndexError, ValueError) as exc:
            raise ValueError(f"sweep name template {template!r} cannot be filled: {exc}") from None
        row["name"] = name
        rows.append(row)
    return rows


def _safe(v):
    if isinstance(v, str):
        return re.sub(r"[^A-Za-z0-9.+-]", "", v.replace(":", ""))
    return v


def load_batch(path, *, overrides: dict | None = None) -> list[tuple[str, dict]]:
    """Read a batch file into ``[(name, fields), ...]`` (fields not yet validated).

    CSV: one scene per row; the header names scene fields and a ``name``
    column (file stem; default ``scene_<row>``).  Empty cells keep the
    default.  TOML: ``[base]`` (shared fields), ``[[scene]]`` (one table per
    scene, with ``name``) and/or ``[sweep]`` (see :func:`expand_sweep`).
    ``overrides`` (e.g. the CLI's ``--set``) apply to every scene.

    Unknown columns and duplicate names raise :class:`ValueError`; bad *values*
    are reported per scene when the batch runs.
    """
    from .scene import Scene  # noqa: PLC0415

    path = os.fspath(path)
    if not os.path.exists(path):
        raise ValueError(f"batch file {path!r} does not exist")
    ext = os.path.splitext(path)[1].lower()
    rows: list[dict] = []
    base: dict = {}
    if ext == ".csv":
        with open(path, newline="", encoding="utf-8") as fh:
            reader = csv.DictReader(fh)
            if not reader.fieldnames:
                raise ValueError(f"{path}: empty CSV (expected a header of scene fields)")
            cols = [c.strip() for c in reader.fieldnames]
            for i, raw in enumerate(reader):
                row = {k.strip(): (v or "").strip() for k, v in raw.items() if k is not None}
                if not row.get("name"):
                    row["name"] = f"scene_{i:05d}"
                rows.append(row)
    elif ext == ".toml":
        from .scene import _load_toml  # noqa: PLC0415

        data = _load_toml(path)
        base = dict(data.get("base", {}))
        for entry in data.get("scene", []):
            rows.append(dict(entry))
        if "sweep" in data:
            rows.extend(expand_sweep(data["sweep"]))
        for i, r in enumerate(rows):
            r.setdefault("name", f"scene_{i:05d}")
        cols = sorted({k for r in rows for k in r} | set(base))
    else:
        raise ValueError(f"batch file {path!r}: expected a .csv or .toml file")
    valid = set(Scene.field_names())
    unknown = [c for c in cols if c != "name" and c not in valid]
    if unknown:
        raise ValueError(
            f"{path}: unknown scene field {unknown[0]!r}; valid fields are name, "
            + ", ".join(Scene.field_names())
        )
    out, seen = [], set()
    for r in rows:
        name = str(r.pop("name"))
        if not _NAME_RE.match(name):
            raise ValueError(f"{path}: name {name!r} is not a valid file stem (letters, digits, . _ + -)")
        if name in seen:
            raise ValueError(f"{path}: duplicate name {name!r}")
        seen.add(name)
        fields = {**base, **r, **(overrides or {})}
        fields["name"] = name
        out.append((name, fields))
    if not out:
        raise ValueError(f"{path}: no scenes")
    return out


# ----------------------------------------------------------------------------
# running
# ----------------------------------------------------------------------------
def _render_one(name: str, fields: dict, out_path: str, threads: int = 1,
                batch_size: int | None = None) -> BatchResult:
    """Render one scene to ``out_path``; never raises (errors become a failed result)."""
    t0 = time.perf_counter()
    try:
        from .exr import write_exr  # noqa: PLC0415
        from .render import render  # noqa: PLC0415
        from .scene import Scene  # noqa: PLC0415

        scene = Scene.from_dict(fields)
        img = render(scene, workers=threads, batch_size=batch_size)
        write_exr(out_path, img)
        return BatchResult(name, out_path, "done", time.perf_counter() - t0)
    except Exception as exc:  # failure isolation: report and carry on
        msg = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        return BatchResult(name, out_path, "failed", time.perf_counter() - t0,
                           f"{type(exc).__name__}: {msg}")


class _Progress:
    def __init__(self, total, stream):
        self.total, self.stream, self.k, self.t0 = total, stream, 0, time.perf_counter()

    def update(self, r: BatchResult):
        self.k += 1
        if self.stream is None:
            return
        width = 24
        filled = int(width * self.k / max(self.total, 1))
        bar = "#" * filled + "-" * (width - filled)
        el = time.perf_counter() - self.t0
        eta = el / self.k * (self.total - self.k)
        extra = f" ({r.error})" if r.status == "failed" else ""
        print(f"[{bar}] {self.k}/{self.total} {r.name}: {r.status}{extra} "
              f"| {el:.1f} s elapsed, ~{eta:.0f} s left", file=self.stream, flush=True)


def run_batch(items, out_dir, *, workers: int = 1, client=None, scheduler: str | None = None,
              resume: bool = True, progress=True, batch_size: int | None = None) -> BatchSummary:
    """Render ``items`` (``[(name, fields)]`` from :func:`load_batch`) into ``out_dir``.

    Parameters
    ----------
    items : list of (str, dict)
        Scene names (file stems) and fields.
    out_dir : str
        Output directory (created); scene ``name`` goes to ``out_dir/name.exr``.
    workers : int
        Local processes (1 = this process).
    client : dask.distributed.Client, optional
        Run on this Dask cluster.
    scheduler : str, optional
        Address of a Dask scheduler to connect to (``tcp://host:8786``).
    resume : bool
        Skip scenes whose output is already a complete EXR.  Leftover temporary
        files of interrupted writes are removed; truncated outputs are redone.
    progress : bool or file
        Print a progress line per finished scene (to stderr, or to the file given).
    batch_size : int, optional
        Directions per model call inside each render.

    Returns
    -------
    BatchSummary
        Also written to ``out_dir/batch_summary.json``.
    """
    from .exr import atomic_write, is_complete_exr  # noqa: PLC0415

    t0 = time.perf_counter()
    out_dir = os.fspath(out_dir)
    os.makedirs(out_dir, exist_ok=True)
    for tmp in glob.glob(os.path.join(out_dir, ".*.exr.*.tmp")):  # interrupted writes
        try:
            os.remove(tmp)
        except OSError:  # pragma: no cover
            pass
    stream = sys.stderr if progress is True else (progress or None)
    results: dict[str, BatchResult] = {}
    todo = []
    for name, fields in items:
        path = os.path.join(out_dir, f"{name}.exr")
        if resume and is_complete_exr(path):
            results[name] = BatchResult(name, path, "skipped")
        else:
            todo.append((name, fields, path))
    bar = _Progress(len(items), stream)
    for r in results.values():
        bar.update(r)

    if client is None and scheduler:
        try:
            from dask.distributed import Client  # noqa: PLC0415
        except ImportError as exc:
            raise ImportError(
                "running on a Dask cluster needs the optional extra: pip install 'atmoscatter[dask]'"
            ) from exc
        client = Client(scheduler)
        own_client = True
    else:
        own_client = False

    try:
        if client is not None:
            from dask.distributed import as_completed as dask_completed  # noqa: PLC0415

            names, futures = {}, []
            for n, f, p in todo:
                fut = client.submit(_render_one, n, f, p, 1, batch_size, pure=False)
                names[fut.key] = (n, p)
                futures.append(fut)
            for fut in dask_completed(futures):
                n, p = names[fut.key]
                try:
                    r = fut.result()
                except Exception as exc:  # worker lost, etc.
                    r = BatchResult(n, p, "failed", 0.0, f"{type(exc).__name__}: {exc}")
                results[r.name] = r
                bar.update(r)
        elif workers > 1 and len(todo) > 1:
            with ProcessPoolExecutor(max_workers=workers) as ex:
                futs = {ex.submit(_render_one, n, f, p, 1, batch_size): (n, p) for n, f, p in todo}
                for fut in as_completed(futs):
                    n, p = futs[fut]
                    try:
                        r = fut.result()
                    except Exception as exc:  # a crashed worker process
                        r = BatchResult(n, p, "failed", 0.0, f"{type(exc).__name__}: {exc}")
                    results[n] = r
                    bar.update(r)
        else:
            for n, f, p in todo:
                r = _render_one(n, f, p, None, batch_size)
                results[n] = r
                bar.update(r)
    finally:
        if own_client:
            client.close()

    ordered = [results[n] for n, _ in items if n in results]
    summary = BatchSummary(ordered, time.perf_counter() - t0)
    with atomic_write(os.path.join(out_dir, "batch_summary.json")) as tmp:
        with open(tmp, "w", encoding="utf-8") as fh:
            json.dump(summary.to_dict(), fh, indent=1)
    return summary

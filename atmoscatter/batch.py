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

import contextlib
import csv
import datetime as _dt
import glob
import hashlib
import itertools
import json
import os
import re
import signal
import sys
import threading
import time
from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait
from dataclasses import asdict, dataclass, field

import numpy as np

__all__ = ["load_batch", "expand_sweep", "run_batch", "BatchResult", "BatchSummary",
           "BatchInterrupted", "scene_fingerprint"]

_NAME_RE = re.compile(r"^[A-Za-z0-9._+-]+$")


@dataclass
class BatchResult:
    """Outcome of one scene: ``status`` is ``done``, ``skipped`` (already complete and up to
    date), ``failed`` or ``unfinished`` (the batch was interrupted before it finished).

    Parameters
    ----------
    name : str
        Scene name (the output's file stem).
    path : str
        Output EXR path.
    status : {"done", "skipped", "failed", "unfinished"}
        Outcome.
    seconds : float
        Wall time spent on the scene [s].
    error : str
        One-line error message of a failed scene (empty otherwise).
    """

    name: str
    path: str
    status: str
    seconds: float = 0.0
    error: str = ""


@dataclass
class BatchSummary:
    """All results of a batch, with counts and a readable report.

    Parameters
    ----------
    results : list of BatchResult
        One entry per scene, in batch order.
    seconds : float
        Wall time of the whole batch [s].
    interrupted : str
        ``""``, or the signal that stopped the batch (``"SIGINT"``, ``"SIGTERM"``).
    """

    results: list = field(default_factory=list)
    seconds: float = 0.0
    #: ``""``, or the signal that stopped the batch (``"SIGINT"``, ``"SIGTERM"``)
    interrupted: str = ""

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
        if self.interrupted:
            lines.append(f"interrupted by {self.interrupted}: {self.count('unfinished')} scenes "
                         "not finished (no partial files); run the same command again to resume")
        for r in self.failed:
            lines.append(f"  FAILED {r.name}: {r.error}")
        return "\n".join(lines)

    def to_dict(self) -> dict:
        return {"seconds": self.seconds, "done": self.count("done"),
                "skipped": self.count("skipped"), "failed": self.count("failed"),
                "unfinished": self.count("unfinished"), "interrupted": self.interrupted,
                "results": [asdict(r) for r in self.results]}


class BatchInterrupted(KeyboardInterrupt):
    """Raised by :func:`run_batch` when SIGINT (Ctrl-C) or SIGTERM stopped it.

    The workers have been stopped and no partial file is left; :attr:`summary` says what
    finished (also written to ``batch_summary.json``) and :attr:`signal_name` what stopped it.
    """

    def __init__(self, summary: BatchSummary, signal_name: str):
        super().__init__(f"batch interrupted by {signal_name}")
        self.summary = summary
        self.signal_name = signal_name


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

    Parameters
    ----------
    sweep : dict
        The ``[sweep]`` table: scene fields mapped to lists or ``{start, stop, step}`` ranges,
        plus the optional ``name`` template.

    Returns
    -------
    list of dict
        One mapping of scene fields per combination, each with its ``name``.
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


def _read_csv(path) -> tuple[list, list]:
    """(header, rows) of a batch CSV; every malformed line is an error naming it.

    UTF-8 with or without a byte-order mark (as Excel writes it).  Every row must have as
    many cells as the header (a line of empty cells is skipped); column names must be unique.
    """
    try:
        with open(path, newline="", encoding="utf-8-sig") as fh:
            lines = list(csv.reader(fh))
    except UnicodeDecodeError as exc:
        raise ValueError(f"{path}: not UTF-8 text ({exc.reason} at byte {exc.start}); save the "
                         "table as CSV UTF-8") from None
    except csv.Error as exc:
        raise ValueError(f"{path}: not a valid CSV file ({exc})") from None
    if not lines or not any(c.strip() for c in lines[0]):
        raise ValueError(f"{path}: empty CSV (expected a header of scene fields)")
    cols = [c.strip() for c in lines[0]]
    for j, c in enumerate(cols):
        if not c:
            raise ValueError(f"{path}: line 1 (header): column {j + 1} has no name")
        if c in cols[:j]:
            raise ValueError(f"{path}: line 1 (header): duplicate column {c!r} "
                             f"(columns {cols.index(c) + 1} and {j + 1})")
    rows = []
    for lineno, cells in enumerate(lines[1:], start=2):
        if not any(c.strip() for c in cells):
            continue  # blank line
        if len(cells) != len(cols):
            what = "more" if len(cells) > len(cols) else "fewer"
            raise ValueError(f"{path}: line {lineno} has {len(cells)} cells, {what} than the "
                             f"{len(cols)} columns of the header")
        row = {k: v.strip() for k, v in zip(cols, cells, strict=True)}
        if not row.get("name"):
            row["name"] = f"scene_{len(rows):05d}"
        rows.append(row)
    return cols, rows


def load_batch(path, *, overrides: dict | None = None) -> list[tuple[str, dict]]:
    """Read a batch file into ``[(name, fields), ...]`` (fields not yet validated).

    CSV: one scene per row; the header names scene fields and a ``name``
    column (file stem; default ``scene_<row>``).  Empty cells keep the
    default.  TOML: ``[base]`` (shared fields), ``[[scene]]`` (one table per
    scene, with ``name``) and/or ``[sweep]`` (see :func:`expand_sweep`).
    ``overrides`` (e.g. the CLI's ``--set``) apply to every scene.

    Unknown or duplicate columns, rows with more or fewer cells than the header,
    non-UTF-8 text and duplicate names raise :class:`ValueError` naming the file
    (and the line); bad *values* are reported per scene when the batch runs.

    Parameters
    ----------
    path : str or path-like
        A ``.csv`` or ``.toml`` batch file.
    overrides : dict, optional
        Scene fields set in every scene (after the file's values).

    Returns
    -------
    list of (str, dict)
        ``(name, fields)`` per scene, in file order; ``fields`` are raw scene-field values
        (validated by :class:`Scene` when the scene is rendered).
    """
    from .scene import Scene  # noqa: PLC0415

    path = os.fspath(path)
    if not os.path.exists(path):
        raise ValueError(f"batch file {path!r} does not exist")
    ext = os.path.splitext(path)[1].lower()
    rows: list[dict] = []
    base: dict = {}
    if ext == ".csv":
        cols, rows = _read_csv(path)
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
#: EXR header attribute holding :func:`scene_fingerprint` of the scene a batch file was
#: rendered from; resume re-renders a file whose fingerprint differs (or is missing).
FINGERPRINT_KEY = "atmoscatter:scene_hash"


def _numerical_defaults(model: str) -> dict:
    """The numerical defaults a physical model's values depend on (a change of the default
    multiple-scattering grid, say, must re-render files made with the old one)."""
    if model not in ("single_scattering", "multiple_scattering"):
        return {}
    from .sky import multiple, single  # noqa: PLC0415

    out = {"single": [single.DEFAULT_SINGLE_SCATTERING_METHOD,
                      single.DEFAULT_SINGLE_SCATTERING_SAMPLES, single.TABLE_THRESHOLD,
                      single.TWILIGHT_TABLE_THRESHOLD, single.TABLE_FLOOR]}
    if model == "multiple_scattering":
        out["multiple"] = [repr(multiple.MULTIPLE_SCATTERING_GRID), multiple._FIELD_VERSION]
    return out


def scene_fingerprint(scene) -> str:
    """SHA-256 over what a rendered file depends on: every scene field, the package
    version, the model's registration (name, description), the measured defaults of
    ``sampling = "auto"`` and, for the physical models, their numerical defaults (the
    multiple-scattering grid and field version, the single-scattering table settings);
    for a custom atmosphere file, its bytes.

    Batch resume keeps an existing output only when the fingerprint stored in its header
    (:data:`FINGERPRINT_KEY`) equals that of the scene asked for now.

    Parameters
    ----------
    scene : Scene
        The scene of one output.

    Returns
    -------
    str
        Hexadecimal SHA-256 digest.
    """
    from . import __version__  # noqa: PLC0415
    from .render.models import MODELS  # noqa: PLC0415
    from .render.plan import auto_sampling_rule  # noqa: PLC0415
    from .scene import is_atmosphere_file  # noqa: PLC0415

    adapter = MODELS.get(scene.model)
    payload = {"scene": scene.to_strings(), "version": __version__,
               "model": [scene.model, getattr(adapter, "description", "")],
               "auto_sampling": auto_sampling_rule(),
               "numerics": _numerical_defaults(scene.model)}
    if is_atmosphere_file(scene.atmosphere):
        try:
            with open(scene.atmosphere, "rb") as fh:
                payload["atmosphere_file"] = hashlib.sha256(fh.read()).hexdigest()
        except OSError:
            payload["atmosphere_file"] = "unreadable"
    text = json.dumps(payload, sort_keys=True, default=str)
    return hashlib.sha256(text.encode("utf-8")).hexdigest()


def _render_one(name: str, fields: dict, out_path: str, threads: int | None = 1,
                batch_size: int | None = None) -> BatchResult:
    """Render one scene to ``out_path``; never raises (errors become a failed result)."""
    t0 = time.perf_counter()
    try:
        from .exr import write_exr  # noqa: PLC0415
        from .render import render  # noqa: PLC0415
        from .scene import Scene  # noqa: PLC0415

        scene = Scene.from_dict(fields)
        img = render(scene, workers=threads, batch_size=batch_size)
        img.metadata[FINGERPRINT_KEY] = scene_fingerprint(scene)
        write_exr(out_path, img)
        return BatchResult(name, out_path, "done", time.perf_counter() - t0)
    except Exception as exc:  # failure isolation: report and carry on
        msg = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        return BatchResult(name, out_path, "failed", time.perf_counter() - t0,
                           f"{type(exc).__name__}: {msg}")


def _up_to_date(path: str, fields: dict) -> bool:
    """True if ``path`` is a complete EXR rendered from exactly this scene (fingerprint)."""
    from .exr import read_exr  # noqa: PLC0415
    from .scene import Scene  # noqa: PLC0415

    if not os.path.isfile(path):
        return False
    try:
        img = read_exr(path)
        if not img.channels:
            return False
        return img.header.get(FINGERPRINT_KEY) == scene_fingerprint(Scene.from_dict(fields))
    except Exception:  # unreadable, truncated, or a scene that no longer validates
        return False


# --- worker processes ---------------------------------------------------------
_TERMINATING = False


def _worker_sigterm(signum, frame):
    """SIGTERM in a worker: abort the current render (its temporary file is removed on the
    way out) and leave the process."""
    global _TERMINATING
    _TERMINATING = True
    raise SystemExit(128 + signum)


def _watch_parent(parent_pid: int, poll: float = 0.25, grace: float = 3.0) -> None:
    """Thread in each worker: if the parent process dies (even by SIGKILL), stop too."""
    while os.getppid() == parent_pid:
        time.sleep(poll)
    with contextlib.suppress(OSError):
        os.kill(os.getpid(), signal.SIGTERM)  # cleans up via _worker_sigterm
    time.sleep(grace)
    os._exit(1)  # the main thread was stuck in a long C call


def _worker_init(parent_pid: int) -> None:
    # Ctrl-C reaches the whole process group: the parent alone decides (it stops the
    # workers with SIGTERM), so a worker does not turn it into a failed scene and go on.
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, _worker_sigterm)
    threading.Thread(target=_watch_parent, args=(parent_pid,), daemon=True,
                     name="atmoscatter-parent-watch").start()


def _render_in_worker(*args) -> BatchResult:
    try:
        return _render_one(*args)
    except BaseException:
        if _TERMINATING:
            os._exit(143)  # not back to the executor's loop: no further scene
        raise


def _stop_pool(ex: ProcessPoolExecutor, timeout: float = 2.0) -> None:
    """Cancel what has not started, SIGTERM the workers, wait ≤ ``timeout``, then SIGKILL."""
    procs = list((getattr(ex, "_processes", None) or {}).values())
    ex.shutdown(wait=False, cancel_futures=True)
    for p in procs:
        with contextlib.suppress(Exception):
            p.terminate()
    deadline = time.monotonic() + timeout
    for p in procs:
        with contextlib.suppress(Exception):
            p.join(max(deadline - time.monotonic(), 0.0))
    for p in procs:
        with contextlib.suppress(Exception):
            if p.is_alive():
                p.kill()
                p.join(1.0)
    # let the executor's management thread see its dead workers and close its wake-up
    # pipe now: if it is still doing so when the interpreter exits, concurrent.futures'
    # exit hook writes to that pipe as it closes ("Bad file descriptor" traceback)
    manager = getattr(ex, "_executor_manager_thread", None)
    if manager is not None:
        with contextlib.suppress(Exception):
            manager.join(timeout)


class _Stop(KeyboardInterrupt):
    def __init__(self, signum):
        super().__init__(signal.Signals(signum).name)
        self.signum = signum


@contextlib.contextmanager
def _stop_on_signals():
    """Turn SIGINT and SIGTERM into :class:`_Stop` in the main thread while a batch runs."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return

    def handler(signum, frame):
        raise _Stop(signum)

    old = {}
    for sig in (signal.SIGINT, signal.SIGTERM):
        try:
            old[sig] = signal.signal(sig, handler)
        except (ValueError, OSError):  # pragma: no cover - not settable here
            pass
    try:
        yield
    finally:
        for sig, h in old.items():
            signal.signal(sig, h)


def _remove_temporaries(out_dir: str) -> None:
    for tmp in glob.glob(os.path.join(glob.escape(out_dir), ".*.exr.*.tmp")):
        with contextlib.suppress(OSError):
            os.remove(tmp)


# --- progress -----------------------------------------------------------------
class _Progress:
    """A tqdm bar on a terminal; one line per scene on an explicitly given non-terminal
    stream; nothing when ``stream`` is None."""

    def __init__(self, total, stream, *, lines: bool):
        self.total, self.stream, self.k, self.t0 = total, stream, 0, time.perf_counter()
        self.bar = None
        self.lines = lines and stream is not None
        if stream is not None and _isatty(stream):
            try:
                from tqdm import tqdm  # noqa: PLC0415

                self.bar = tqdm(total=total, file=stream, unit="scene", dynamic_ncols=True,
                                desc="batch")
                self.lines = False
            except ImportError:  # pragma: no cover - tqdm is a dependency
                self.lines = True

    def update(self, r: BatchResult):
        self.k += 1
        if self.bar is not None:
            if r.status == "failed":
                self.bar.write(f"FAILED {r.name}: {r.error}", file=self.stream)
            self.bar.set_postfix_str(f"{r.name}: {r.status}", refresh=False)
            self.bar.update(1)
            return
        if not self.lines:
            return
        width = 24
        filled = int(width * self.k / max(self.total, 1))
        bar = "#" * filled + "-" * (width - filled)
        el = time.perf_counter() - self.t0
        eta = el / self.k * (self.total - self.k)
        extra = f" ({r.error})" if r.status == "failed" else ""
        print(f"[{bar}] {self.k}/{self.total} {r.name}: {r.status}{extra} "
              f"| {el:.1f} s elapsed, ~{eta:.0f} s left", file=self.stream, flush=True)

    def close(self):
        if self.bar is not None:
            self.bar.close()


def _isatty(stream) -> bool:
    try:
        return bool(stream.isatty())
    except (AttributeError, ValueError):
        return False


def run_batch(items, out_dir, *, workers: int = 1, client=None, scheduler: str | None = None,
              resume: bool = True, progress=True, batch_size: int | None = None) -> BatchSummary:
    """Render ``items`` (``[(name, fields)]`` from :func:`load_batch`) into ``out_dir``.

    Parameters
    ----------
    items : list of (str, dict)
        Scene names (file stems) and fields.
    out_dir : str
        Output directory (created; checked to be writable before anything is rendered);
        scene ``name`` goes to ``out_dir/name.exr``.
    workers : int
        Local processes (1 = this process), ≥ 1.
    client : dask.distributed.Client, optional
        Run on this Dask cluster.
    scheduler : str, optional
        Address of a Dask scheduler to connect to (``tcp://host:8786``).
    resume : bool
        Skip scenes whose output is a complete EXR rendered from the same scene: its
        header's :func:`scene_fingerprint` (scene fields, package version, model
        defaults) must match, so a row whose values changed is rendered again.
        Leftover temporary files of interrupted writes are removed; truncated outputs
        are redone.
    progress : bool or file
        ``True``: a progress bar (tqdm) on stderr when stderr is a terminal, nothing
        otherwise.  A file: the bar if it is a terminal, else one line per finished
        scene.  ``False``/``None``: silent.
    batch_size : int, optional
        Directions per model call inside each render.

    Returns
    -------
    BatchSummary
        Also written to ``out_dir/batch_summary.json``.

    Raises
    ------
    BatchInterrupted
        SIGINT (Ctrl-C) or SIGTERM arrived (main thread only): scenes not yet started
        are cancelled, running workers are stopped within about two seconds, no partial
        file is left, and the exception's ``summary`` (also written to
        ``batch_summary.json``) says what finished.  Worker processes also stop by
        themselves if this process dies.
    """
    from ._validate import check_count, check_writable_dir  # noqa: PLC0415

    t0 = time.perf_counter()
    if client is None and not scheduler:
        workers = check_count(workers, "workers")
    out_dir = check_writable_dir(os.fspath(out_dir), name="output directory")
    _remove_temporaries(out_dir)  # interrupted writes of an earlier run
    stream = sys.stderr if progress is True else (progress or None)
    results: dict[str, BatchResult] = {}
    todo = []
    bar = _Progress(len(items), stream, lines=progress is not True)
    stopped = ""
    try:
        with _stop_on_signals():
            for name, fields in items:
                path = os.path.join(out_dir, f"{name}.exr")
                if resume and _up_to_date(path, fields):
                    results[name] = BatchResult(name, path, "skipped")
                else:
                    todo.append((name, fields, path))
            for r in results.values():
                bar.update(r)

            def record(r):
                results[r.name] = r
                bar.update(r)

            _run(todo, record, workers=workers, client=client, scheduler=scheduler,
                 batch_size=batch_size)
    except _Stop as exc:
        stopped = signal.Signals(exc.signum).name
    except KeyboardInterrupt:
        stopped = "SIGINT"
    finally:
        bar.close()
    if stopped:
        _remove_temporaries(out_dir)  # every worker is gone: nothing is being written
        for name, fields in items:
            if name not in results:
                # a worker may have finished the file just before it was stopped
                path = os.path.join(out_dir, f"{name}.exr")
                results[name] = BatchResult(
                    name, path, "done" if _up_to_date(path, fields) else "unfinished")

    ordered = [results[n] for n, _ in items if n in results]
    summary = BatchSummary(ordered, time.perf_counter() - t0, interrupted=stopped)
    from .exr import atomic_write  # noqa: PLC0415

    with atomic_write(os.path.join(out_dir, "batch_summary.json")) as tmp:
        with open(tmp, "w", encoding="utf-8") as fh:
            json.dump(summary.to_dict(), fh, indent=1)
    if stopped:
        raise BatchInterrupted(summary, stopped)
    return summary


def _run(todo, record, *, workers, client, scheduler, batch_size) -> None:
    """Render ``todo`` here, in local processes or on Dask; ``record`` each result."""
    own_client = False
    if client is None and scheduler:
        try:
            from dask.distributed import Client  # noqa: PLC0415
        except ImportError as exc:
            raise ImportError(
                "running on a Dask cluster needs the optional extra: pip install 'atmoscatter[dask]'"
            ) from exc
        client = Client(scheduler)
        own_client = True
    try:
        if client is not None:
            _run_dask(todo, record, client, batch_size)
        elif workers > 1 and len(todo) > 1:
            _run_processes(todo, record, workers, batch_size)
        else:
            for n, f, p in todo:
                record(_render_one(n, f, p, None, batch_size))
    finally:
        if own_client:
            client.close()


def _run_dask(todo, record, client, batch_size) -> None:
    from dask.distributed import as_completed as dask_completed  # noqa: PLC0415

    names, futures = {}, []
    for n, f, p in todo:
        fut = client.submit(_render_one, n, f, p, 1, batch_size, pure=False)
        names[fut.key] = (n, p)
        futures.append(fut)
    try:
        for fut in dask_completed(futures):
            n, p = names[fut.key]
            try:
                r = fut.result()
            except Exception as exc:  # worker lost, etc.
                r = BatchResult(n, p, "failed", 0.0, f"{type(exc).__name__}: {exc}")
            record(r)
    except BaseException:
        with contextlib.suppress(Exception):
            client.cancel(futures)
        raise


def _run_processes(todo, record, workers, batch_size) -> None:
    ex = ProcessPoolExecutor(max_workers=min(workers, len(todo)), initializer=_worker_init,
                             initargs=(os.getpid(),))
    try:
        futs = {ex.submit(_render_in_worker, n, f, p, 1, batch_size): (n, p) for n, f, p in todo}
        pending = set(futs)
        while pending:
            done, pending = wait(pending, timeout=0.5, return_when=FIRST_COMPLETED)
            for fut in done:
                n, p = futs[fut]
                try:
                    r = fut.result()
                except Exception as exc:  # a crashed worker process
                    r = BatchResult(n, p, "failed", 0.0, f"{type(exc).__name__}: {exc}")
                record(r)
    except BaseException:
        _stop_pool(ex)
        raise
    ex.shutdown(wait=True)

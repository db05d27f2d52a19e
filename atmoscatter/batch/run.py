"""Running a batch: in this process, in local worker processes or on a Dask cluster, with
progress, resume, failure isolation and a clean stop on SIGINT/SIGTERM (workers included, no
partial files)."""

from __future__ import annotations

import contextlib
import glob
import json
import os
import signal
import sys
import threading
import time
from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait

from .job import _render_one, _up_to_date
from .results import BatchInterrupted, BatchResult, BatchSummary

__all__ = ["run_batch"]



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


#: distinct suns (of one atmosphere) from which a batch of ``multiple_scattering`` scenes on
#: the default grid is told about ``ms_grid = "table"`` (:func:`ms_grid_hint`): a field per
#: sun costs several seconds each (``benchmarks/bench_multiple.py``), the table grid's one
#: field about as much as ten of them, and a new sun on it its sky tables only
MS_TABLE_HINT_SUNS = 10

#: the scene fields that fix a multiple-scattering field's sun and atmosphere
_SUN_FIELDS = ("time", "sun_elevation_deg", "sun_azimuth_deg", "latitude", "longitude",
               "altitude")
_ATMOSPHERE_FIELDS = ("atmosphere", "turbidity", "ground_albedo", "orders", "sampling",
                      "wavelength_step")


def ms_grid_hint(items) -> str | None:
    """A one-line suggestion, or ``None``: when at least :data:`MS_TABLE_HINT_SUNS` scenes
    of one atmosphere use ``model = "multiple_scattering"`` on the default grid
    (``ms_grid`` unset) with distinct suns, each builds its own field, and ``ms_grid =
    "table"`` would build one for all of them (less accurate per sky: the measured
    figures are in ``docs/convergence.md``).  The batch keeps the grid it was given; the
    choice between the two is the user's.

    ``items``: ``[(name, fields, ...)]`` as :func:`run_batch` takes them.
    """
    suns: dict = {}
    for item in items:
        fields = item[1]
        if fields.get("model") != "multiple_scattering" or fields.get("ms_grid") not in (None, ""):
            continue
        atm = tuple(str(fields.get(k, "")) for k in _ATMOSPHERE_FIELDS)
        suns.setdefault(atm, set()).add(tuple(str(fields.get(k, "")) for k in _SUN_FIELDS))
    n = max((len(v) for v in suns.values()), default=0)
    if n < MS_TABLE_HINT_SUNS:
        return None
    return (f"note: {n} multiple_scattering scenes of one atmosphere on the default grid build "
            "a field per sun; ms_grid=table builds one field for every sun (faster for "
            "series, less accurate per sky: docs/convergence.md)")


def run_batch(items, out_dir, *, workers: int = 1, client=None, scheduler: str | None = None,
              resume: bool = True, progress=True, batch_size: int | None = None,
              rejected=()) -> BatchSummary:
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
    rejected : sequence of BatchResult, optional
        Scenes refused before rendering (e.g. weather hours with missing values,
        :func:`~atmoscatter.batch.weather.weather_batch`): reported as given (``failed``)
        after the rendered ones, in the summary and ``batch_summary.json``; never rendered.

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
    from .._validate import check_count, check_writable_dir  # noqa: PLC0415

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
            hint = ms_grid_hint(todo)
            if hint and stream is not None:
                print(hint, file=stream, flush=True)

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

    ordered = [results[n] for n, _ in items if n in results] + list(rejected)
    summary = BatchSummary(ordered, time.perf_counter() - t0, interrupted=stopped)
    from ..exr import atomic_write  # noqa: PLC0415

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


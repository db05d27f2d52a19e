"""The inter-process :func:`lock` on an entry and the load-or-compute helper :func:`cached`.

Public objects
--------------
- :func:`lock`: a lock file beside the entry, against duplicate work (timeouts, stale locks
  broken; correctness never depends on it, since stores are atomic).
- :func:`cached`: load, or compute under :func:`lock` and store (the usual pattern).
"""

from __future__ import annotations

import contextlib
import json
import os
import socket
import time
import uuid

import numpy as np

from .settings import FORMAT_VERSION, _check_kind_key, _unwritable, cache_dir
from .storage import load, store

__all__ = ["lock", "cached"]


def _pid_alive(pid: int) -> bool:
    if os.name != "posix":  # os.kill(pid, 0) would terminate the process on Windows
        return True
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except (PermissionError, OSError):
        return True
    return True


def _lock_is_stale(path: str, stale_after: float) -> bool:
    try:
        age = time.time() - os.stat(path).st_mtime
    except OSError:
        return False  # released meanwhile: just retry
    if age > stale_after:
        return True
    try:
        with open(path, encoding="utf-8") as fh:
            info = json.loads(fh.read())
    except (OSError, ValueError):  # gone, or being written right now
        return False
    if not isinstance(info, dict):
        return False
    pid = info.get("pid")
    return (info.get("host") == socket.gethostname() and isinstance(pid, int)
            and not _pid_alive(pid))


@contextlib.contextmanager
def lock(kind: str, key: str, *, timeout: float = 600.0, stale_after: float = 3600.0):
    """Inter-process lock on ``(kind, key)`` so that one process computes an entry.

    A lock file ``<key>.v<FORMAT_VERSION>.lock`` beside the entry is created exclusively
    (``O_CREAT | O_EXCL``) and removed on exit.  The lock only avoids duplicate work:
    correctness never depends on it (stores are atomic), so it never deadlocks —

    - waiting ends after ``timeout`` [s] and the block runs without the lock;
    - a lock older than ``stale_after`` [s], or held by a dead process on this host, is
      broken.

    Yields
    ------
    bool
        True if this process holds the lock; False if caching is off, the directory is
        unwritable or the wait timed out.

    Examples
    --------
    ``cached`` is built on it::

        with lock(kind, key):
            arrays = load(kind, key)  # filled by another process while we waited?
            if arrays is None:
                arrays = compute()
                store(kind, key, arrays)
    """
    _check_kind_key(kind, key)
    root = cache_dir()
    if root is None or root in _unwritable:
        yield False
        return
    path = os.path.join(root, kind, f"{key}.v{FORMAT_VERSION}.lock")
    token = uuid.uuid4().hex
    held = False
    deadline = time.monotonic() + max(float(timeout), 0.0)
    delay = 0.02
    try:
        os.makedirs(os.path.dirname(path), exist_ok=True)
    except OSError:
        yield False  # unwritable: store() will warn and fall back to memory
        return
    while True:
        try:
            fd = os.open(path, os.O_CREAT | os.O_EXCL | os.O_WRONLY, 0o644)
        except FileExistsError:
            if _lock_is_stale(path, stale_after):
                with contextlib.suppress(OSError):
                    os.remove(path)
                continue
            if time.monotonic() >= deadline:
                break
            time.sleep(min(delay, max(deadline - time.monotonic(), 0.0)))
            delay = min(delay * 1.5, 0.5)
            continue
        except OSError:
            break  # unwritable (or gone): run unlocked
        with os.fdopen(fd, "w", encoding="utf-8") as fh:
            json.dump({"host": socket.gethostname(), "pid": os.getpid(), "token": token,
                       "time": time.time()}, fh)
        held = True
        break
    try:
        yield held
    finally:
        if held:
            with contextlib.suppress(OSError, ValueError):
                with open(path, encoding="utf-8") as fh:
                    mine = json.loads(fh.read()).get("token") == token
                if mine:  # not broken as stale and re-taken by another process meanwhile
                    os.remove(path)


def cached(kind: str, key: str, compute, *, meta: dict | None = None,
           timeout: float = 600.0) -> dict[str, np.ndarray]:
    """``load(kind, key)``, or ``compute()`` under :func:`lock` and :func:`store` it.

    Parameters
    ----------
    kind, key : str
        As for :func:`load`.
    compute : callable
        ``compute() -> dict[str, ndarray]``, called at most once, only on a miss.
    meta : dict, optional
        Stored with the entry (see :func:`store`).
    timeout : float
        Longest wait [s] for another process computing the same entry; then compute anyway.

    Returns
    -------
    dict of str to ndarray
        The cached or freshly computed arrays.
    """
    arrays = load(kind, key)
    if arrays is not None:
        return arrays
    with lock(kind, key, timeout=timeout):
        arrays = load(kind, key)
        if arrays is None:
            arrays = compute()
            store(kind, key, arrays, meta)
    return arrays

"""Load and store entries, list and clear them; the in-memory fallback.

Public objects
--------------
- :func:`load`, :func:`store`: read / write one entry (``dict`` of NumPy arrays + metadata).
- :func:`entries`, :func:`clear`: list and remove entries.
- :class:`CacheEntry`: one entry on disk, as listed by :func:`entries`.

When the directory is unwritable the arrays are kept in memory for the process (bounded by
:data:`~atmoscatter.cache.MEMORY_MAX_BYTES`), with one :class:`~atmoscatter.cache.CacheWarning`.
"""

from __future__ import annotations

import contextlib
import json
import os
import time
import warnings
from collections import OrderedDict
from typing import NamedTuple

import numpy as np

from .files import (
    _CHECKSUM,
    _FILE_RE,
    _HEADER,
    _TMP_MAX_AGE,
    _check_arrays,
    _Corrupt,
    _digest,
    _discard,
    _evict,
    _json_default,
    _read_entry,
    _read_meta,
    _scan,
    _write_entry,
)
from .settings import (
    ENV_DIR,
    ENV_MAX_BYTES,
    FORMAT_VERSION,
    MEMORY_MAX_BYTES,
    CacheWarning,
    _check_kind_key,
    _entry_path,
    _state_lock,
    _unwritable,
    _warn_once,
    cache_dir,
    max_bytes,
)

__all__ = ["CacheEntry", "load", "store", "entries", "clear"]

_memory: OrderedDict = OrderedDict()  # (root, kind, key) -> (arrays, meta, nbytes)


class CacheEntry(NamedTuple):
    """One entry on disk, as listed by :func:`entries`."""

    kind: str
    """Kind (sub-directory), e.g. ``"multiple_scattering"``."""
    key: str
    """Key (a :func:`fingerprint` hex digest)."""
    size: int
    """File size [bytes]."""
    mtime: float
    """Time of the last store or hit [s since the epoch] (the LRU clock)."""
    meta: dict | None
    """The ``meta`` given to :func:`store` (``None`` if the header is unreadable)."""
    path: str
    """Absolute path of the file."""


# ---------------------------------------------------------------------------------------
# memory fallback
# ---------------------------------------------------------------------------------------
def _memory_store(root, kind, key, arrays, meta) -> None:
    nbytes = sum(a.nbytes for a in arrays.values())
    cap = min(MEMORY_MAX_BYTES, max_bytes())
    with _state_lock:
        _memory.pop((root, kind, key), None)
        if nbytes > cap:
            return
        _memory[root, kind, key] = ({k: a.copy() for k, a in arrays.items()}, meta, nbytes)
        total = sum(v[2] for v in _memory.values())
        while total > cap:
            _, (_, _, n) = _memory.popitem(last=False)
            total -= n


def _memory_load(root, kind, key):
    with _state_lock:
        item = _memory.get((root, kind, key))
        if item is None:
            return None
        _memory.move_to_end((root, kind, key))
        return {k: a.copy() for k, a in item[0].items()}


def _mark_unwritable(root: str, exc: BaseException) -> None:
    with _state_lock:
        first = root not in _unwritable
        _unwritable.add(root)
    if first:
        warnings.warn(
            f"atmoscatter cache: cannot write to the cache directory {root!r} "
            f"({type(exc).__name__}: {exc}); precomputed fields are kept in memory for this "
            f"process only. Set {ENV_DIR} to a writable directory, or to 'off'.",
            CacheWarning, stacklevel=4,
        )


# ---------------------------------------------------------------------------------------
# load / store
# ---------------------------------------------------------------------------------------
def load(kind: str, key: str) -> dict[str, np.ndarray] | None:
    """The arrays stored under ``(kind, key)``, or ``None`` on a miss.

    Parameters
    ----------
    kind : str
        Kind of entry = sub-directory (letters, digits, ``_``, ``-``), e.g.
        ``"multiple_scattering"``.
    key : str
        Entry key, normally a :func:`fingerprint`.

    Returns
    -------
    dict of str to ndarray or None
        Fresh arrays (the caller may modify them).  ``None`` if caching is off, the entry
        does not exist, or it is corrupt (then the file is deleted and one
        :class:`CacheWarning` is issued).  A hit marks the entry as recently used.
        Never raises for file-system problems.
    """
    _check_kind_key(kind, key)
    root = cache_dir()
    if root is None:
        return None
    path = _entry_path(root, kind, key)
    try:
        fh = open(path, "rb")
    except (FileNotFoundError, NotADirectoryError):  # a miss (the path cannot exist)
        return _memory_load(root, kind, key)
    except OSError as exc:
        _warn_once(f"read:{path}", f"atmoscatter cache: cannot read {path} ({exc}); ignoring it")
        return _memory_load(root, kind, key)
    with fh:
        st = os.fstat(fh.fileno())
        try:
            arrays, _meta = _read_entry(fh, kind, key)
        except _Corrupt as exc:
            bad = (st, str(exc))
        else:
            bad = None
    if bad is not None:
        _discard(path, *bad)
        return _memory_load(root, kind, key)
    with contextlib.suppress(OSError):
        os.utime(path)  # the LRU clock (atime is unreliable: noatime/relatime mounts)
    return arrays


def store(kind: str, key: str, arrays: dict[str, np.ndarray], meta: dict | None = None) -> str | None:
    """Store ``arrays`` under ``(kind, key)`` atomically; evict LRU entries over the cap.

    Parameters
    ----------
    kind, key : str
        As for :func:`load`.
    arrays : dict of str to array_like
        The data (any non-object dtype).  Names: letters, digits, ``_ . -``, not starting
        with ``__`` (reserved).
    meta : dict, optional
        JSON-serialisable description shown by ``atmoscatter cache list`` (e.g.
        ``{"atmosphere": atm.name, "wavelengths": atm.wavelengths}``); not part of the key.

    Returns
    -------
    str or None
        Path of the written file; ``None`` if caching is off, the directory is unwritable
        (the arrays are then kept in memory for this process) or the entry alone exceeds the
        size cap (not stored).

    Raises
    ------
    ValueError, TypeError
        For a bad ``kind``, ``key``, array name, object array or non-JSON ``meta``; never
        for file-system problems.
    """
    _check_kind_key(kind, key)
    arrays = _check_arrays(arrays)
    if meta is not None and not isinstance(meta, dict):
        raise TypeError(f"meta must be a dict or None, got {type(meta).__name__}")
    meta = json.loads(json.dumps(meta or {}, default=_json_default))
    root = cache_dir()
    if root is None:
        return None
    cap = max_bytes()
    nbytes = sum(a.nbytes for a in arrays.values())
    if nbytes > cap:
        _warn_once(f"big:{kind}:{key}",
                   f"atmoscatter cache: a {kind} entry of {nbytes} bytes exceeds the cache size cap "
                   f"({cap} bytes, {ENV_MAX_BYTES}); not stored")
        return None
    if root in _unwritable:
        _memory_store(root, kind, key, arrays, meta)
        return None
    header = {
        "format": "atmoscatter-cache", "version": FORMAT_VERSION, "kind": kind, "key": key,
        "meta": meta, "created": time.time(),
        "arrays": {n: [a.dtype.str, list(a.shape)] for n, a in sorted(arrays.items())},
    }
    header_text = json.dumps(header, sort_keys=True)
    members = {_HEADER: np.array(header_text), _CHECKSUM: np.array(_digest(header_text, arrays))}
    members.update(arrays)
    path = _entry_path(root, kind, key)
    try:
        _write_entry(path, members)
    except FileNotFoundError:
        return None  # our temporary file was removed under us (a concurrent clear)
    except OSError as exc:
        _mark_unwritable(root, exc)
        _memory_store(root, kind, key, arrays, meta)
        return None
    _evict(root, cap, keep=path)
    return path


# ---------------------------------------------------------------------------------------
# listing and clearing
# ---------------------------------------------------------------------------------------
def entries(kind: str | None = None) -> list[CacheEntry]:
    """The entries on disk (current format), most recently used first.

    Parameters
    ----------
    kind : str, optional
        Only this kind.

    Returns
    -------
    list of CacheEntry
        ``(kind, key, size, mtime, meta, path)``; empty if caching is off.
    """
    if kind is not None:
        _check_kind_key(kind, "x")
    root = cache_dir()
    if root is None:
        return []
    out = []
    for k, name, e in _scan(root, kind):
        m = _FILE_RE.match(name)
        if not m or int(m.group("version")) != FORMAT_VERSION:
            continue
        try:
            st = e.stat(follow_symlinks=False)
        except OSError:
            continue
        out.append(CacheEntry(k, m.group("key"), st.st_size, st.st_mtime, _read_meta(e.path), e.path))
    out.sort(key=lambda c: c.mtime, reverse=True)
    return out


def clear(kind: str | None = None) -> int:
    """Remove the cached entries (all kinds, or one); returns the number of bytes freed.

    Entries of every format version are removed, with temporary and lock files older than
    an hour (younger ones belong to work in progress), and the in-memory fallback is
    emptied.  An entry another process stores at the same moment may survive.
    """
    if kind is not None:
        _check_kind_key(kind, "x")
    root = cache_dir()
    if root is None:
        return 0
    with _state_lock:
        for k in [k for k in _memory if k[0] == root and (kind is None or k[1] == kind)]:
            del _memory[k]
    freed = 0
    now = time.time()
    for _k, name, e in _scan(root, kind):
        entry = bool(_FILE_RE.match(name))
        if not (entry or name.endswith((".tmp", ".lock"))):
            continue
        try:
            st = e.stat(follow_symlinks=False)
            if not entry and now - st.st_mtime < _TMP_MAX_AGE:
                continue  # a write or a computation in progress in another process
            size = st.st_size
            os.remove(e.path)
        except OSError:
            continue
        if entry:
            freed += size
    return freed

r"""Persistent on-disk cache of precomputed arrays (radiance fields, tables).

Some models precompute a field per atmosphere that costs tens of seconds (the successive
orders of :func:`atmoscatter.multiple_scattering`).  This module keeps such fields between
processes: one ``.npz`` file per entry, keyed by a stable :func:`fingerprint` of everything
the field depends on.

Public objects
--------------
- :func:`fingerprint`: stable SHA-256 hex digest of atmospheres and plain values.
- :func:`load`, :func:`store`: read / write one entry (``dict`` of NumPy arrays + metadata).
- :func:`cached`: load, or compute under a :func:`lock` and store (the usual pattern).
- :func:`lock`: inter-process lock against duplicate work (timeouts, stale locks broken).
- :func:`entries`, :func:`clear`: list and remove entries.
- :func:`cache_dir`, :func:`max_bytes`: the resolved settings.
- :class:`CacheEntry`, :class:`CacheWarning`, :data:`FORMAT_VERSION`,
  :data:`DEFAULT_MAX_BYTES`.

Settings (read at every call, so they can change at run time)
-------------------------------------------------------------
``ATMOSCATTER_CACHE_DIR``
    Directory of the cache; default ``platformdirs.user_cache_dir("atmoscatter")``
    (``~/.cache/atmoscatter`` on Linux).  ``off`` disables the cache: :func:`load` returns
    ``None`` and :func:`store` does nothing.
``ATMOSCATTER_CACHE_MAX_BYTES``
    Size cap of the directory, in bytes or with a binary suffix (``500M``, ``2G``,
    ``1.5GiB``); default 2 GiB.  After each store the least recently used entries are
    removed until the total is under the cap (a hit counts as a use).

Layout and guarantees
---------------------
Entry ``key`` of kind ``kind`` is the file ``<cache_dir>/<kind>/<key>.v<FORMAT_VERSION>.npz``:
an uncompressed NumPy ``.npz`` holding the caller's arrays plus two reserved members,
``__header__`` (JSON: format, version, kind, key, meta, array dtypes and shapes, creation
time) and ``__sha256__`` (SHA-256 of the header text and of every array's name, dtype, shape
and bytes).  It is read with ``allow_pickle=False`` (object arrays are refused on store).

- **Integrity**: the checksum, the zip CRCs and the header's kind/key/version are verified
  on load; a corrupt or truncated entry is never returned — it is deleted, one
  :class:`CacheWarning` is issued and :func:`load` returns ``None``.
- **Atomicity**: an entry is written to a temporary file in the same directory, flushed to
  disk and renamed over the final name (``os.replace``).  Several processes (or Dask
  workers) storing the same entry at once are safe: the last writer wins and a reader only
  ever sees a complete file.  :func:`lock` additionally avoids the duplicate work.
- **Failure**: an unwritable directory never raises; the process falls back to an in-memory
  cache (bounded by :data:`MEMORY_MAX_BYTES`) with one :class:`CacheWarning` naming the
  directory.  Missing files (removed by another process) are plain misses.

Fingerprint format
------------------
:func:`fingerprint` hashes (SHA-256, hex) the UTF-8 bytes of the compact JSON text
(``sort_keys``, separators ``,`` and ``:``, ASCII) of ``["atmoscatter-fingerprint", 1,
[part, ...]]`` where each part is encoded as:

- ``None``, ``True``, ``False`` → JSON ``null``, ``true``, ``false``;
- an integer, or a float with an integral value → ``"i:<decimal>"`` (so ``0`` and ``0.0``
  give the same key, as they compare equal);
- any other float → ``"f:" + float.hex(x)`` (exact: ``"f:0x1.3333333333333p-2"`` for 0.3;
  ``"f:nan"``, ``"f:inf"``, ``"f:-inf"``);
- a string → ``"s:<text>"``;
- a list or tuple → a JSON list of the encoded items;
- a dict with string keys → a JSON object of the encoded values;
- an :class:`~atmoscatter.Atmosphere` → ``{"atmosphere": <encoded atmosphere_to_dict(atm)
  without "name">}`` (the name labels, it is not physics);
- any other dataclass → ``{"dataclass": "<module>.<qualname>", "fields": {...}}`` over its
  compared fields;
- a NumPy array → ``{"ndarray": [shape], "dtype": "<f8"|"<i8"|"<u8"|"|b1"|"<c16",
  "sha256": <digest of the C-order bytes in that dtype>}`` (floats up to 64 bits are widened
  exactly); NumPy scalars → their Python value.

Every step is exact and independent of the process, the platform and the hash seed, so
the same inputs give the same key everywhere; any change of a value changes it.
"""

from __future__ import annotations

import contextlib
import dataclasses
import hashlib
import json
import math
import os
import re
import socket
import threading
import time
import uuid
import warnings
import zipfile
from collections import OrderedDict
from typing import Any, NamedTuple

import numpy as np

__all__ = [
    "FORMAT_VERSION",
    "DEFAULT_MAX_BYTES",
    "MEMORY_MAX_BYTES",
    "CacheEntry",
    "CacheWarning",
    "cache_dir",
    "max_bytes",
    "fingerprint",
    "load",
    "store",
    "cached",
    "lock",
    "entries",
    "clear",
]

FORMAT_VERSION: int = 1
"""Version of the entry format; part of every file name (old files are never read)."""

DEFAULT_MAX_BYTES: int = 2 * 1024**3
"""Default size cap of the cache directory [bytes] (2 GiB)."""

MEMORY_MAX_BYTES: int = 512 * 1024**2
"""Cap of the in-memory fallback used when the directory is unwritable [bytes] (512 MiB;
the smaller of this and :func:`max_bytes` applies)."""

ENV_DIR = "ATMOSCATTER_CACHE_DIR"
ENV_MAX_BYTES = "ATMOSCATTER_CACHE_MAX_BYTES"
_OFF_VALUES = ("off",)
_FINGERPRINT_TAG = "atmoscatter-fingerprint"
_FINGERPRINT_VERSION = 1
_HEADER = "__header__"
_CHECKSUM = "__sha256__"
_TMP_MAX_AGE = 3600.0  # [s] temporary files older than this are debris of a killed writer

_KIND_RE = re.compile(r"^[A-Za-z0-9][A-Za-z0-9_-]{0,63}$")
_KEY_RE = re.compile(r"^[A-Za-z0-9][A-Za-z0-9_-]{0,127}$")
_NAME_RE = re.compile(r"^[A-Za-z_][A-Za-z0-9_.-]{0,127}$")
_FILE_RE = re.compile(r"^(?P<key>[A-Za-z0-9][A-Za-z0-9_-]*)\.v(?P<version>[0-9]+)\.npz$")

_state_lock = threading.Lock()
_unwritable: set[str] = set()  # directories found unwritable (warned once each)
_warned: set[str] = set()  # other one-time warnings (corrupt paths, bad settings)
_memory: OrderedDict = OrderedDict()  # (root, kind, key) -> (arrays, meta, nbytes)


class CacheWarning(UserWarning):
    """Issued when the cache cannot be used as configured (never raised as an error)."""


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
# settings
# ---------------------------------------------------------------------------------------
def _warn_once(tag: str, message: str, stacklevel: int = 3) -> None:
    with _state_lock:
        if tag in _warned:
            return
        _warned.add(tag)
    warnings.warn(message, CacheWarning, stacklevel=stacklevel + 1)


def cache_dir() -> str | None:
    """The cache directory (absolute path), or ``None`` if caching is off.

    ``$ATMOSCATTER_CACHE_DIR`` if set (``off`` → ``None``), else
    ``platformdirs.user_cache_dir("atmoscatter")``.  The directory may not exist yet.
    """
    value = os.environ.get(ENV_DIR, "").strip()
    if value.lower() in _OFF_VALUES:
        return None
    if value:
        return os.path.abspath(os.path.expanduser(value))
    try:
        import platformdirs  # noqa: PLC0415
    except ImportError:  # pragma: no cover - a declared dependency
        base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
        return os.path.join(os.path.abspath(base), "atmoscatter")
    return os.path.abspath(platformdirs.user_cache_dir("atmoscatter"))


_SUFFIXES = {"": 1, "b": 1, "k": 1024, "kb": 1024, "kib": 1024, "m": 1024**2, "mb": 1024**2,
             "mib": 1024**2, "g": 1024**3, "gb": 1024**3, "gib": 1024**3, "t": 1024**4,
             "tb": 1024**4, "tib": 1024**4}


def _parse_size(text: str) -> int:
    m = re.fullmatch(r"\s*([0-9]+(?:\.[0-9]*)?)\s*([A-Za-z]*)\s*", text)
    if not m or m.group(2).lower() not in _SUFFIXES:
        raise ValueError(
            f"{ENV_MAX_BYTES} must be a size in bytes, optionally with a binary suffix "
            f"(K, M, G, T; e.g. 2G), got {text!r}"
        )
    return int(float(m.group(1)) * _SUFFIXES[m.group(2).lower()])


def max_bytes() -> int:
    """Size cap of the cache directory [bytes] (``$ATMOSCATTER_CACHE_MAX_BYTES``, default 2 GiB).

    An unparsable value gives one :class:`CacheWarning` and the default (the cache is an
    optimisation: a typo must not stop a long computation).
    """
    value = os.environ.get(ENV_MAX_BYTES, "").strip()
    if not value:
        return DEFAULT_MAX_BYTES
    try:
        return _parse_size(value)
    except ValueError as exc:
        _warn_once(f"max:{value}", f"{exc}; using the default {DEFAULT_MAX_BYTES} bytes")
        return DEFAULT_MAX_BYTES


def _check_kind_key(kind, key) -> None:
    if not isinstance(kind, str) or not _KIND_RE.match(kind):
        raise ValueError(
            f"kind must be 1-64 characters of letters, digits, '_' or '-' (starting with a "
            f"letter or digit), got {kind!r}"
        )
    if not isinstance(key, str) or not _KEY_RE.match(key):
        raise ValueError(
            f"key must be 1-128 characters of letters, digits, '_' or '-' (e.g. a "
            f"fingerprint() hex digest), got {key!r}"
        )


def _entry_path(root: str, kind: str, key: str) -> str:
    return os.path.join(root, kind, f"{key}.v{FORMAT_VERSION}.npz")


# ---------------------------------------------------------------------------------------
# fingerprint
# ---------------------------------------------------------------------------------------
_ARRAY_DTYPES = {"f": "<f8", "i": "<i8", "u": "<u8", "b": "|b1", "c": "<c16"}


def _encode_float(x: float):
    if math.isfinite(x) and x.is_integer():
        return f"i:{int(x)}"
    return "f:" + float.hex(x)


def _encode(obj, where: str):
    from ..atmosphere import Atmosphere, atmosphere_to_dict  # noqa: PLC0415

    if obj is None or isinstance(obj, bool | np.bool_):
        return None if obj is None else bool(obj)
    if isinstance(obj, np.generic) and not isinstance(obj, np.ndarray):
        if isinstance(obj, np.floating) and np.dtype(obj.dtype).itemsize > 8:
            raise TypeError(f"fingerprint: {where} is a {obj.dtype} scalar; use float64 or narrower")
        return _encode(obj.item(), where)
    if isinstance(obj, int):
        return f"i:{obj}"
    if isinstance(obj, float):
        return _encode_float(obj)
    if isinstance(obj, str):
        return "s:" + obj
    if isinstance(obj, list | tuple):
        return [_encode(v, f"{where}[{i}]") for i, v in enumerate(obj)]
    if isinstance(obj, dict):
        out = {}
        for k, v in obj.items():
            if not isinstance(k, str):
                raise TypeError(f"fingerprint: dict keys must be strings, got {k!r} in {where}")
            out[k] = _encode(v, f"{where}[{k!r}]")
        return out
    if isinstance(obj, Atmosphere):
        data = atmosphere_to_dict(obj)
        data.pop("name", None)
        return {"atmosphere": _encode(data, f"{where}.atmosphere")}
    if dataclasses.is_dataclass(obj) and not isinstance(obj, type):
        cls = type(obj)
        fields = {f.name: _encode(getattr(obj, f.name), f"{where}.{f.name}")
                  for f in dataclasses.fields(obj) if f.compare}
        return {"dataclass": f"{cls.__module__}.{cls.__qualname__}", "fields": fields}
    if isinstance(obj, np.ndarray):
        kind = obj.dtype.kind
        if kind not in _ARRAY_DTYPES or (kind in "fc" and obj.dtype.itemsize > {"f": 8, "c": 16}[kind]):
            raise TypeError(
                f"fingerprint: {where} is an array of dtype {obj.dtype}; supported are "
                f"bool, integer, float (<= 64 bit) and complex (<= 128 bit) arrays"
            )
        dt = _ARRAY_DTYPES[kind]
        data = np.asarray(obj, dtype=dt, order="C")
        return {"ndarray": list(obj.shape), "dtype": dt,
                "sha256": hashlib.sha256(data.tobytes()).hexdigest()}
    raise TypeError(
        f"fingerprint: cannot fingerprint {where} of type {type(obj).__name__}; supported are "
        f"Atmosphere, dataclasses, dicts, lists/tuples, numbers, strings, None and NumPy arrays"
    )


def fingerprint(*parts: Any) -> str:
    """Stable SHA-256 hex digest of an atmosphere and/or plain values.

    Parameters
    ----------
    *parts : Atmosphere, dataclass, dict, list, tuple, int, float, str, bool, None or ndarray
        Everything the cached quantity depends on, e.g.
        ``fingerprint("multiple_scattering", atmosphere, grid, albedo)``.  Nested freely.

    Returns
    -------
    str
        64 lowercase hex digits.  The same values give the same digest in every process and
        on every machine (see *Fingerprint format* in the module docstring); any change of
        a number (one ulp), string, structure or type changes it.  An atmosphere's ``name``
        does not enter (the same physical atmosphere under two names shares the entry).

    Raises
    ------
    TypeError
        For a value that has no canonical form (naming where it sits in ``parts``).

    Examples
    --------
    >>> from atmoscatter.cache import fingerprint
    >>> fingerprint({"albedo": 0.3}) == fingerprint({"albedo": 0.3})
    True
    >>> fingerprint(0.3) == fingerprint(0.30000000000000004)
    False
    >>> len(fingerprint(1, "x", (2.5, None)))
    64
    """
    tree = [_FINGERPRINT_TAG, _FINGERPRINT_VERSION,
            [_encode(p, f"parts[{i}]") for i, p in enumerate(parts)]]
    text = json.dumps(tree, sort_keys=True, separators=(",", ":"), ensure_ascii=True,
                      allow_nan=False)
    return hashlib.sha256(text.encode("utf-8")).hexdigest()


# ---------------------------------------------------------------------------------------
# entry files
# ---------------------------------------------------------------------------------------
def _json_default(o):
    if isinstance(o, np.generic):
        return o.item()
    if isinstance(o, np.ndarray):
        return o.tolist()
    if isinstance(o, tuple | set | frozenset):
        return list(o)
    raise TypeError(f"meta values must be JSON data (numbers, strings, lists, dicts), got {type(o).__name__}")


def _digest(header_text: str, arrays: dict[str, np.ndarray]) -> str:
    h = hashlib.sha256()
    h.update(header_text.encode("utf-8"))
    for name in sorted(arrays):
        a = np.asarray(arrays[name], order="C")  # (ascontiguousarray would make 0-d 1-d)
        h.update(b"\0" + name.encode("utf-8") + b"\0" + a.dtype.str.encode("ascii") + b"\0"
                 + repr(tuple(a.shape)).encode("ascii") + b"\0")
        h.update(a.tobytes() if a.ndim == 0 else memoryview(a.reshape(-1).view(np.uint8)))
    return h.hexdigest()


def _check_arrays(arrays) -> dict[str, np.ndarray]:
    if not isinstance(arrays, dict) or not arrays:
        raise TypeError(f"arrays must be a non-empty dict of name -> NumPy array, got {type(arrays).__name__}")
    out = {}
    for name, a in arrays.items():
        if not isinstance(name, str) or not _NAME_RE.match(name) or name.startswith("__"):
            raise ValueError(
                f"array names must be 1-128 characters of letters, digits, '_', '.' or '-', "
                f"not starting with a digit, '.', '-' or '__', got {name!r}"
            )
        a = np.asarray(a)
        if a.dtype.hasobject:
            raise TypeError(f"array {name!r} has dtype {a.dtype}; object arrays cannot be cached")
        out[name] = a
    return out


def _write_entry(path: str, members: dict[str, np.ndarray]) -> None:
    from ..exr import atomic_write  # noqa: PLC0415  (one atomic-write helper in the package)

    with atomic_write(path) as tmp:
        with open(tmp, "wb") as fh:
            with zipfile.ZipFile(fh, mode="w", compression=zipfile.ZIP_STORED, allowZip64=True) as zf:
                for name, a in members.items():
                    with zf.open(name + ".npy", "w", force_zip64=True) as f:
                        np.lib.format.write_array(f, np.asarray(a, order="C"), allow_pickle=False)
            fh.flush()
            os.fsync(fh.fileno())


class _Corrupt(Exception):
    pass


def _read_entry(fh, kind: str, key: str):
    """Read and verify an open entry file; (arrays, meta) or raise _Corrupt."""
    try:
        z = np.load(fh, allow_pickle=False)
        if not isinstance(z, np.lib.npyio.NpzFile):
            raise _Corrupt("not an .npz archive")
        with z:
            members = {name: z[name] for name in z.files}
    except _Corrupt:
        raise
    except Exception as exc:  # BadZipFile, CRC error, EOFError, ValueError, OSError, ...
        raise _Corrupt(f"unreadable: {type(exc).__name__}: {exc}") from None
    if _HEADER not in members or _CHECKSUM not in members:
        raise _Corrupt("header or checksum missing")
    header_text, checksum = members.pop(_HEADER), members.pop(_CHECKSUM)
    if header_text.shape != () or checksum.shape != () or header_text.dtype.kind != "U" \
            or checksum.dtype.kind != "U":
        raise _Corrupt("malformed header")
    header_text, checksum = header_text.item(), checksum.item()
    if _digest(header_text, members) != checksum:
        raise _Corrupt("SHA-256 checksum mismatch")
    try:
        header = json.loads(header_text)
    except ValueError:
        raise _Corrupt("header is not JSON") from None
    if (header.get("format") != "atmoscatter-cache" or header.get("version") != FORMAT_VERSION
            or header.get("kind") != kind or header.get("key") != key):
        raise _Corrupt("header does not match the file name")
    return members, header.get("meta") or {}


def _read_meta(path: str) -> dict | None:
    try:
        with np.load(path, allow_pickle=False) as z:
            return json.loads(z[_HEADER].item()).get("meta") or {}
    except Exception:
        return None


def _discard(path: str, st, reason: str) -> None:
    """Delete a corrupt entry (only if it is still the file we read) and warn once."""
    with contextlib.suppress(OSError):
        now = os.stat(path)
        if (now.st_ino, now.st_dev, now.st_size, now.st_mtime_ns) == (
                st.st_ino, st.st_dev, st.st_size, st.st_mtime_ns):
            os.remove(path)
    _warn_once(f"corrupt:{path}:{st.st_mtime_ns}",
               f"atmoscatter cache: discarded corrupt entry {path} ({reason}); it will be recomputed",
               stacklevel=4)


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


def _scan(root: str, kind: str | None = None):
    """Yield (kind, name, DirEntry) of the files under root (all kinds or one)."""
    try:
        kinds = [kind] if kind is not None else sorted(
            e.name for e in os.scandir(root) if e.is_dir(follow_symlinks=False) and _KIND_RE.match(e.name))
    except OSError:
        return
    for k in kinds:
        try:
            with os.scandir(os.path.join(root, k)) as it:
                files = list(it)
        except OSError:
            continue
        for e in files:
            yield k, e.name, e


def _evict(root: str, cap: int, keep: str | None = None) -> None:
    now = time.time()
    items = []
    for _k, name, e in _scan(root):
        try:
            st = e.stat(follow_symlinks=False)
        except OSError:
            continue
        if name.startswith(".") and name.endswith(".tmp"):
            if now - st.st_mtime > _TMP_MAX_AGE:
                with contextlib.suppress(OSError):
                    os.remove(e.path)
            continue
        if _FILE_RE.match(name):
            items.append((st.st_mtime_ns, e.path, st.st_size))
    total = sum(s for _, _, s in items)
    for _, p, s in sorted(items):
        if total <= cap:
            break
        if p == keep:
            continue
        with contextlib.suppress(OSError):
            os.remove(p)
            total -= s


# ---------------------------------------------------------------------------------------
# lock and the load-or-compute helper
# ---------------------------------------------------------------------------------------
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

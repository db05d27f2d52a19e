"""Entry files of the cache: the checksummed ``.npz`` format and the LRU eviction of the directory.

One entry is ``<cache_dir>/<kind>/<key>.v<FORMAT_VERSION>.npz``, an uncompressed ``.npz`` of
the caller's arrays plus ``__header__`` (JSON) and ``__sha256__`` (see *Layout and
guarantees* in :mod:`atmoscatter.cache`).  Written atomically (temporary file, ``fsync``,
``os.replace``), verified on reading; a corrupt entry raises ``_Corrupt`` here and is
discarded by :func:`~atmoscatter.cache.load`.  Nothing here is public API.
"""

from __future__ import annotations

import contextlib
import hashlib
import json
import os
import re
import time
import zipfile

import numpy as np

from .settings import _KIND_RE, FORMAT_VERSION, _warn_once

__all__: list[str] = []

_HEADER = "__header__"
_CHECKSUM = "__sha256__"
_TMP_MAX_AGE = 3600.0  # [s] temporary files older than this are debris of a killed writer

_NAME_RE = re.compile(r"^[A-Za-z_][A-Za-z0-9_.-]{0,127}$")
_FILE_RE = re.compile(r"^(?P<key>[A-Za-z0-9][A-Za-z0-9_-]*)\.v(?P<version>[0-9]+)\.npz$")


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
    from .._atomic import atomic_write  # noqa: PLC0415  (one atomic-write helper in the package)

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
# the directory: scan and least-recently-used eviction
# ---------------------------------------------------------------------------------------
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

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

The format of the keys is described in :mod:`atmoscatter.cache.keys`.

Modules
-------
settings
    The directory and the size cap (read from the environment at every call), the format
    version and :class:`CacheWarning`.
keys
    :func:`fingerprint`: the stable key of an atmosphere and plain values.
files
    The entry file format (write, read and verify a checksummed ``.npz``) and the LRU
    eviction of the directory.
storage
    :func:`load`, :func:`store`, :func:`entries`, :func:`clear` and the in-memory fallback
    used when the directory is unwritable.
locking
    :func:`lock` (inter-process, never deadlocks) and :func:`cached` (load or compute and
    store).

The public names are importable from ``atmoscatter.cache``.
"""

from .keys import fingerprint
from .locking import cached, lock
from .settings import (  # noqa: F401  (ENV_DIR, ENV_MAX_BYTES: importable as before the split)
    DEFAULT_MAX_BYTES,
    ENV_DIR,
    ENV_MAX_BYTES,
    FORMAT_VERSION,
    MEMORY_MAX_BYTES,
    CacheWarning,
    cache_dir,
    max_bytes,
)
from .storage import CacheEntry, clear, entries, load, store

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

"""Settings of the cache: its directory, its size cap, the entry format version.

Public objects
--------------
- :func:`cache_dir`, :func:`max_bytes`: the resolved settings (``$ATMOSCATTER_CACHE_DIR``,
  ``$ATMOSCATTER_CACHE_MAX_BYTES``), read at every call.
- :data:`FORMAT_VERSION`, :data:`DEFAULT_MAX_BYTES`, :data:`MEMORY_MAX_BYTES`.
- :class:`CacheWarning`: issued (once per cause) when the cache cannot be used as configured.

Also the process-wide state the other modules of :mod:`atmoscatter.cache` share: the lock
that guards it, the directories found unwritable and the warnings already issued.
"""

from __future__ import annotations

import os
import re
import threading
import warnings

__all__ = [
    "FORMAT_VERSION",
    "DEFAULT_MAX_BYTES",
    "MEMORY_MAX_BYTES",
    "CacheWarning",
    "cache_dir",
    "max_bytes",
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

_KIND_RE = re.compile(r"^[A-Za-z0-9][A-Za-z0-9_-]{0,63}$")
_KEY_RE = re.compile(r"^[A-Za-z0-9][A-Za-z0-9_-]{0,127}$")

_state_lock = threading.Lock()
_unwritable: set[str] = set()  # directories found unwritable (warned once each)
_warned: set[str] = set()  # other one-time warnings (corrupt paths, bad settings)


class CacheWarning(UserWarning):
    """Issued when the cache cannot be used as configured (never raised as an error)."""


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

"""Node values of the sky tables kept in the persistent cache (:mod:`atmoscatter.cache`).

A sky table (single scattering's :class:`~._single_table._LogSkyTable`, the
multiple-scattering part's :class:`~._sky_table._SkyTable`) evaluates its model at a fixed
set of node directions that depends only on the atmosphere, the observer, the sun and the
table's size — one to two seconds per 1024 × 512 render, the largest cost of a render that
finds its multiple-scattering field on disk.  :func:`memo_values` wraps such an evaluation
so that a later process rendering the same scene reads the node values back instead: the
stored values are the computed ones, bit for bit, so a table built from them is the table
built from scratch (one answer).  The key covers everything the values depend on: the
caller's ``parts`` (atmosphere, observer radius, sun vector, table size, rule), the node
directions themselves, :data:`VALUES_VERSION` and the package version.

Entries are small next to a field (``atmoscatter cache list`` shows both) and go through
the cache's size cap and least-recently-used eviction like the fields (a field is touched by every render that
uses it, a table only by renders of its own sun).
"""

from __future__ import annotations

import numpy as np

#: Bump when the numbers a sky table's node values are computed with change (the graded
#: rule, the optical-length quadrature, the multiple-scattering gather).
VALUES_VERSION = 1


def table_key(kind: str, *parts):
    """Base key of a table's node values, or ``None`` when caching cannot apply (caching
    off, or a duck-typed atmosphere that has no fingerprint)."""
    from .. import __version__, cache  # noqa: PLC0415

    if cache.cache_dir() is None:
        return None
    try:
        return cache.fingerprint(kind, VALUES_VERSION, __version__, *parts)
    except TypeError:
        return None


def table_meta(atm_obj, r0, s, **extra) -> dict:
    """What ``atmoscatter cache list`` shows of a table entry."""
    R = float(getattr(atm_obj, "planet_radius", 0.0))
    meta = {"atmosphere": str(getattr(atm_obj, "name", "")),
            "wavelengths": [float(w) for w in np.atleast_1d(getattr(atm_obj, "wavelengths", ()))],
            "altitude_m": round(float(r0) - R, 3),
            "sun_elevation_deg": round(float(np.degrees(np.arcsin(np.clip(s[2], -1, 1)))), 6)}
    meta.update(extra)
    return meta


def memo_values(kind: str, base_key, fn, meta: dict | None = None):
    """``fn(v) -> ndarray`` memoised in the persistent cache under ``(kind, base_key, v)``.

    ``base_key`` ``None`` returns ``fn`` itself.  Any failure of the cache (unwritable,
    corrupt entry) falls back to computing, as everywhere in :mod:`atmoscatter.cache`.
    """
    if base_key is None:
        return fn
    from .. import cache  # noqa: PLC0415

    def values(v):
        v = np.ascontiguousarray(v, dtype=float)
        key = cache.fingerprint(base_key, v)
        got = cache.cached(kind, key, lambda: {"values": np.asarray(fn(v))}, meta=meta)
        return got["values"]

    return values

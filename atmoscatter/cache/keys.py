"""Keys of the cache: :func:`fingerprint`, a stable digest of everything an entry depends on.

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

import dataclasses
import hashlib
import json
import math
from typing import Any

import numpy as np

__all__ = ["fingerprint"]

_FINGERPRINT_TAG = "atmoscatter-fingerprint"
_FINGERPRINT_VERSION = 1
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

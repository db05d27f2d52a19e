"""Constants and small helpers shared by the modules of :mod:`atmoscatter.sun`.

- ``_TWO_PI``, ``_DEG``: 2π and the degree in radians.
- ``_CHUNK``: the block size of the per-sample loops (the node interpolation in
  :mod:`atmoscatter.sun.nodes` and the topocentric geometry in :func:`sun_position`).
- ``_horner``: a polynomial by Horner's rule (ΔT pieces, the nutation arguments, obliquity
  and equation of time).
- ``_checked``, ``_describe_first``, ``_out_dtype``: the numeric input checks of the public
  functions (finite values in a stated range, named in the error message) and the output
  dtype rule (float32 in, float32 out).
"""

from __future__ import annotations

import numpy as np

from .._validate import as_float_array

__all__: list[str] = []

_TWO_PI = 2.0 * np.pi
_DEG = np.pi / 180.0
#: Elements per block in the per-sample part (keeps temporaries in cache, bounds memory).
_CHUNK = 1 << 15


def _horner(x, coeffs):
    """Σ coeffs[i] x^i by Horner's rule (coefficients in increasing order)."""
    out = np.full_like(x, coeffs[-1])
    for c in coeffs[-2::-1]:
        out = out * x + c
    return out


def _describe_first(arr: np.ndarray, bad: np.ndarray) -> str:
    if arr.ndim == 0:
        return repr(arr.item())
    idx = tuple(int(i) for i in np.argwhere(bad)[0])
    return f"{arr[idx].item()!r} (at index {idx})"


def _checked(value, name: str, low: float, high: float, unit: str) -> np.ndarray:
    """Float array in [low, high]; ±inf and a scalar NaN raise, NaN array elements pass."""
    arr = as_float_array(value, name)
    nan = np.isnan(arr)
    if arr.ndim == 0 and nan:
        raise ValueError(f"{name} must be finite, got nan")
    bad = np.isinf(arr)
    if np.any(bad):
        raise ValueError(f"{name} must be finite, got {_describe_first(arr, bad)}")
    with np.errstate(invalid="ignore"):
        bad = (arr < low) | (arr > high)
    if np.any(bad):
        raise ValueError(f"{name} must be in [{low}, {high}] {unit}, got {_describe_first(arr, bad)}")
    return arr


def _out_dtype(*arrays) -> type:
    """float32 if every float input is float32, else float64."""
    floats = [a.dtype for a in arrays if a.dtype.kind == "f"]
    return np.float32 if floats and all(dt == np.float32 for dt in floats) else np.float64

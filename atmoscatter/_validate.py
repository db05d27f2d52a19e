"""Input checking shared by every public function.

Each check raises :class:`ValueError` (or :class:`TypeError`) whose message names
the parameter, the offending value and the valid range, as the project's
conventions require.
"""

from __future__ import annotations

from collections.abc import Iterable

import numpy as np

__all__ = [
    "as_float_array",
    "check_finite",
    "check_positive",
    "check_range",
    "check_option",
    "clamp_cosine",
    "safe_sqrt",
]


def _describe(value) -> str:
    arr = np.asarray(value)
    if arr.ndim == 0:
        return repr(arr.item())
    return f"array of shape {arr.shape}"


def _first_bad(arr: np.ndarray, bad: np.ndarray) -> str:
    if arr.ndim == 0:
        return repr(arr.item())
    idx = np.argwhere(bad)[0]
    return f"{arr[tuple(idx)].item()!r} (at index {tuple(int(i) for i in idx)})"


def as_float_array(value, name: str, *, dtype=None) -> np.ndarray:
    """Convert array-like ``value`` to a floating array.

    float32 input stays float32 (precision follows the input); integers,
    booleans and Python floats become float64.  Non-numeric input raises
    :class:`TypeError` naming ``name``.
    """
    try:
        arr = np.asarray(value)
    except Exception as exc:  # pragma: no cover - exotic inputs
        raise TypeError(f"{name} must be array-like of numbers, got {type(value).__name__}") from exc
    if dtype is not None:
        return arr.astype(dtype, copy=False)
    if arr.dtype.kind == "f":
        return arr
    if arr.dtype.kind in "iub":
        return arr.astype(np.float64)
    if arr.dtype.kind == "O":
        try:
            return arr.astype(np.float64)
        except (TypeError, ValueError) as exc:
            raise TypeError(f"{name} must be array-like of numbers, got {_describe(value)}") from exc
    raise TypeError(f"{name} must be array-like of real numbers, got dtype {arr.dtype}")


def check_finite(value, name: str) -> np.ndarray:
    """Raise ``ValueError`` if any element of ``value`` is NaN or infinite."""
    arr = as_float_array(value, name)
    bad = ~np.isfinite(arr)
    if np.any(bad):
        raise ValueError(f"{name} must be finite, got {_first_bad(arr, bad)}")
    return arr


def check_positive(value, name: str, *, allow_zero: bool = False, unit: str = "") -> np.ndarray:
    """Raise ``ValueError`` unless every element is finite and > 0 (or >= 0)."""
    arr = check_finite(value, name)
    bad = arr < 0 if allow_zero else arr <= 0
    if np.any(bad):
        rng = "[0, inf)" if allow_zero else "(0, inf)"
        u = f" {unit}" if unit else ""
        raise ValueError(f"{name} must be in {rng}{u}, got {_first_bad(arr, bad)}")
    return arr


def check_range(
    value,
    name: str,
    low: float,
    high: float,
    *,
    low_inclusive: bool = True,
    high_inclusive: bool = True,
    unit: str = "",
) -> np.ndarray:
    """Raise ``ValueError`` unless every element lies in the given interval."""
    arr = check_finite(value, name)
    bad = (arr < low) if low_inclusive else (arr <= low)
    bad = bad | ((arr > high) if high_inclusive else (arr >= high))
    if np.any(bad):
        lb = "[" if low_inclusive else "("
        hb = "]" if high_inclusive else ")"
        u = f" {unit}" if unit else ""
        raise ValueError(f"{name} must be in {lb}{low}, {high}{hb}{u}, got {_first_bad(arr, bad)}")
    return arr


def check_option(value: str, name: str, options: Iterable[str]) -> str:
    """Raise ``ValueError`` listing the valid choices if ``value`` is not one of them."""
    opts = list(options)
    if value not in opts:
        raise ValueError(f"{name}={value!r} is not valid; choose one of {sorted(opts)}")
    return value


def clamp_cosine(mu):
    """Clamp a cosine into [-1, 1].

    Cosines computed from dot products of unit vectors can leave [-1, 1] by a
    few ulp; ``arccos`` or ``sqrt(1 - mu**2)`` would then give NaN.
    """
    return np.clip(mu, -1.0, 1.0)


def safe_sqrt(x):
    """Square root of ``max(x, 0)``: guards rounding just below zero."""
    return np.sqrt(np.maximum(x, 0.0))

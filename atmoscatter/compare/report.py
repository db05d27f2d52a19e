"""Step 3 of a comparison: the report files (PNG error maps, JSON encoding of the summary).

:meth:`Comparison.write <atmoscatter.compare.stats.Comparison.write>` writes
``summary.json``, ``error_map.png`` and ``delta_e_map.png`` with these helpers (8-bit PNG
through :func:`atmoscatter.write_png`, no extra dependency); ``scripts/validation_report.py``
draws its error maps with them too.  Nothing here is public API.
"""

from __future__ import annotations

import math

import numpy as np

__all__: list[str] = []

#: Default error-map colour range: relative error ±1 (±100 %) for the luminance map and
#: ΔE00 0…10 for the colour-difference map.
ERROR_MAP_RANGE: float = 1.0
DELTA_E_MAP_RANGE: float = 10.0


# --------------------------------------------------------------------------------------
# JSON (summary.json: NumPy scalars to Python numbers, non-finite floats to null)
# --------------------------------------------------------------------------------------
def _jsonable(obj):
    if isinstance(obj, dict):
        return {str(k): _jsonable(v) for k, v in obj.items()}
    if isinstance(obj, list | tuple):
        return [_jsonable(v) for v in obj]
    if isinstance(obj, np.generic):
        obj = obj.item()
    if isinstance(obj, float) and not math.isfinite(obj):
        return None
    return obj


# --------------------------------------------------------------------------------------
# PNG error maps (8-bit, zlib; no extra dependency)
# --------------------------------------------------------------------------------------
def _as_2d(a):
    a = np.asarray(a, dtype=float)
    return a.reshape(1, -1) if a.ndim == 1 else a.reshape(a.shape[0], -1)


def _diverging(signed, vmax):
    """Blue (−vmax) → white (0) → red (+vmax); NaN → mid-grey.  uint8 (h, w, 3)."""
    a = _as_2d(signed)
    t = np.clip(np.nan_to_num(a, nan=0.0) / vmax, -1.0, 1.0)
    r = np.where(t > 0, 1.0, 1.0 + t)
    g = 1.0 - np.abs(t)
    b = np.where(t < 0, 1.0, 1.0 - t)
    rgb = np.stack([r, g, b], axis=-1)
    rgb[np.isnan(a)] = 0.5
    return np.round(rgb * 255).astype(np.uint8)


def _sequential(values, vmax):
    """White (0) → dark red (≥ vmax); NaN → mid-grey."""
    a = _as_2d(values)
    t = np.clip(np.nan_to_num(a, nan=0.0) / vmax, 0.0, 1.0)
    rgb = np.stack([1.0 - 0.4 * t, 1.0 - t, 1.0 - t], axis=-1)
    rgb[np.isnan(a)] = 0.5
    return np.round(rgb * 255).astype(np.uint8)


def _write_png(path, pixels):
    from ..preview import write_png

    return write_png(path, pixels)

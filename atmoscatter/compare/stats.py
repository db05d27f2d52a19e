"""Step 2 of a comparison: the statistics of two images in the same layout, and the result.

Public objects
--------------
- :func:`compare_images`: luminance relative error without rescaling, best-fit scale factor,
  ΔE 2000 after exposure normalisation, error maps; returns a :class:`Comparison`.
- :class:`Comparison`: the result; :meth:`Comparison.to_dict` (JSON-ready summary),
  :meth:`Comparison.summary_text` and :meth:`Comparison.write` (the report files, drawn by
  :mod:`atmoscatter.compare.report`).
- :func:`weighted_quantile`: the inverted-CDF weighted quantile behind the percentiles.
- :data:`SCALE_METHODS`: registry of best-fit scale estimators.

What is compared, and how, is described in :mod:`atmoscatter.compare`.
"""

from __future__ import annotations

import json
import math
import os
from dataclasses import dataclass, field

import numpy as np

from .._validate import check_option, check_positive
from .read import _to_xyz
from .report import (
    DELTA_E_MAP_RANGE,
    ERROR_MAP_RANGE,
    _diverging,
    _jsonable,
    _sequential,
    _write_png,
)

__all__ = ["SCALE_METHODS", "Comparison", "compare_images", "weighted_quantile"]

#: Luminance that middle grey (L* ≈ 50) stands for in the ΔE normalisation, relative to the
#: reference image's median luminance.
MIDDLE_GREY: float = 0.18


# --------------------------------------------------------------------------------------
# statistics
# --------------------------------------------------------------------------------------
def weighted_quantile(values, q, weights=None) -> float:
    """Inverted-CDF weighted quantile: the smallest value whose cumulative weight ≥ q·total.

    Parameters
    ----------
    values : array_like
        Finite values (flattened).
    q : float
        Quantile in [0, 1].
    weights : array_like, optional
        Non-negative weights (e.g. pixel solid angles [sr]); default equal weights, in which
        case the result equals ``numpy.quantile(values, q, method="inverted_cdf")``.

    Returns
    -------
    float
        The quantile, in the units of ``values``.
    """
    v = np.asarray(values, dtype=float).ravel()
    q = float(q)
    if not 0.0 <= q <= 1.0:
        raise ValueError(f"q must be in [0, 1], got {q}")
    if v.size == 0:
        return math.nan
    w = np.ones_like(v) if weights is None else np.asarray(weights, dtype=float).ravel()
    if w.shape != v.shape:
        raise ValueError(f"weights must have the shape of values {v.shape}, got {w.shape}")
    order = np.argsort(v, kind="stable")
    cw = np.cumsum(w[order])
    k = int(np.searchsorted(cw, q * cw[-1], side="left"))
    return float(v[order][min(k, v.size - 1)])


def _stats(err, w) -> dict:
    if err.size == 0:
        return {"median": None, "p95": None, "max": None, "mean": None}
    return {
        "median": weighted_quantile(err, 0.5, w),
        "p95": weighted_quantile(err, 0.95, w),
        "max": float(np.max(err)),
        "mean": float(np.sum(err * w) / np.sum(w)),
    }


def _scale_median_log(ratio, w):
    return math.exp(weighted_quantile(np.log(ratio), 0.5, w))


def _scale_least_squares(ratio, w):
    # ratio = Y_ours / Y_other; minimise Σ w (s/ratio − 1)²  ⇒  s = Σ w r⁻¹ / Σ w r⁻²
    inv = 1.0 / ratio
    return float(np.sum(w * inv) / np.sum(w * inv * inv))


#: Best-fit scale estimators ``(ratio = Y_ours/Y_other, weights) -> s``.
SCALE_METHODS = {
    "median_log": _scale_median_log,
    "least_squares": _scale_least_squares,
}


# --------------------------------------------------------------------------------------
# colour difference
# --------------------------------------------------------------------------------------
def _delta_e_2000(xyz_a, xyz_b, white_y: float):
    import colour

    d65 = colour.CCS_ILLUMINANTS["CIE 1931 2 Degree Standard Observer"]["D65"]
    lab_a = colour.XYZ_to_Lab(xyz_a / white_y, illuminant=d65)
    lab_b = colour.XYZ_to_Lab(xyz_b / white_y, illuminant=d65)
    return np.asarray(colour.delta_E(lab_a, lab_b, method="CIE 2000"), dtype=np.float64)


# --------------------------------------------------------------------------------------
# result
# --------------------------------------------------------------------------------------
@dataclass
class Comparison:
    """Result of :func:`compare_images` / :func:`compare_exr`.

    Attributes
    ----------
    luminance_relative_error : dict
        ``median``, ``p95``, ``max``, ``mean`` of ``|Y_other − Y_ours|/Y_ours`` (no rescaling).
    scale : float
        Best-fit factor *s*, ``s·Y_other ≈ Y_ours``.
    scale_method : str
    scaled_luminance_relative_error : dict
        The statistics of ``|s·Y_other − Y_ours|/Y_ours``.
    delta_e_2000 : dict or None
        ``median``, ``p95``, ``max``, ``mean`` of CIEDE2000 after exposure normalisation (None
        for luminance-only input).
    pixels_compared, pixels_total : int
    weighting : str
        ``"solid_angle"`` or ``"pixel"``.
    relative_error_map : ndarray
        Signed ``Y_other/Y_ours − 1`` per pixel, NaN where excluded (image shape).
    delta_e_map : ndarray or None
        ΔE00 per pixel, NaN where excluded.
    info : dict
        Provenance (files, scene, layout, options) copied into the JSON summary.
    nonfinite_other, nonfinite_reference : int
        Pixels (inside the mask) where that image is NaN or infinite: excluded from the
        statistics, counted and reported.
    """

    luminance_relative_error: dict
    scale: float
    scale_method: str
    scaled_luminance_relative_error: dict
    delta_e_2000: dict | None
    pixels_compared: int
    pixels_total: int
    weighting: str
    relative_error_map: np.ndarray = field(repr=False)
    delta_e_map: np.ndarray | None = field(repr=False, default=None)
    white_luminance: float | None = None
    info: dict = field(default_factory=dict)
    nonfinite_other: int = 0
    nonfinite_reference: int = 0

    def to_dict(self) -> dict:
        """JSON-ready summary (the content of ``summary.json``)."""
        from .. import __version__

        return {
            "luminance_relative_error": self.luminance_relative_error,
            "scale": self.scale,
            "scale_method": self.scale_method,
            "scaled_luminance_relative_error": self.scaled_luminance_relative_error,
            "delta_e_2000": self.delta_e_2000,
            "exposure_normalisation": {
                "other_multiplied_by": self.scale,
                "white_luminance": self.white_luminance,
                "middle_grey": MIDDLE_GREY,
                "white_point": "D65",
            },
            "pixels_compared": self.pixels_compared,
            "pixels_total": self.pixels_total,
            "pixels_not_finite": {"other": self.nonfinite_other,
                                  "reference": self.nonfinite_reference},
            "weighting": self.weighting,
            "definitions": {
                "luminance_relative_error": "|Y_other - Y_ours| / Y_ours, no rescaling",
                "scale": "s with s * Y_other ~ Y_ours",
                "delta_e_2000": "CIEDE2000 of (s * XYZ_other, XYZ_ours) / (median(Y_ours)/0.18)",
            },
            "atmoscatter_version": __version__,
            **self.info,
        }

    def summary_text(self) -> str:
        """A few human-readable lines."""
        e, s = self.luminance_relative_error, self.scaled_luminance_relative_error

        def f(d, k):
            return "n/a" if d is None or d.get(k) is None else f"{d[k]:.4g}"

        lines = [
            f"pixels compared: {self.pixels_compared} of {self.pixels_total} "
            f"(statistics weighted by {self.weighting.replace('_', ' ')})",
            f"luminance relative error (no rescaling): median {f(e, 'median')}, "
            f"p95 {f(e, 'p95')}, max {f(e, 'max')}",
            *([f"pixels not finite (NaN/inf, excluded): {self.nonfinite_other} in the other "
               f"image, {self.nonfinite_reference} in the reference"]
              if self.nonfinite_other or self.nonfinite_reference else []),
            f"best-fit scale ({self.scale_method}): {self.scale:.6g}",
            f"after scaling: median {f(s, 'median')}, p95 {f(s, 'p95')}, max {f(s, 'max')}",
        ]
        if self.delta_e_2000 is not None:
            d = self.delta_e_2000
            lines.append(f"Delta E 2000: median {f(d, 'median')}, p95 {f(d, 'p95')}, "
                         f"max {f(d, 'max')}")
        return "\n".join(lines)

    def write(self, directory) -> dict:
        """Write ``summary.json``, ``error_map.png`` (and ``delta_e_map.png``) to ``directory``.

        Returns the paths written (dict name → path).  The error map is the signed
        luminance relative error (no rescaling): blue where the other image is darker, red
        where brighter, saturated at ±100 %; excluded pixels are mid-grey.  The ΔE map runs
        white (0) → dark red (≥ 10).
        """
        directory = os.fspath(directory)
        os.makedirs(directory, exist_ok=True)
        paths = {"summary": os.path.join(directory, "summary.json"),
                 "error_map": os.path.join(directory, "error_map.png")}
        _write_png(paths["error_map"], _diverging(self.relative_error_map, ERROR_MAP_RANGE))
        if self.delta_e_map is not None:
            paths["delta_e_map"] = os.path.join(directory, "delta_e_map.png")
            _write_png(paths["delta_e_map"], _sequential(self.delta_e_map, DELTA_E_MAP_RANGE))
        data = self.to_dict()
        data["files"] = {k: os.path.basename(v) for k, v in paths.items()}
        from ..exr import atomic_write

        with atomic_write(paths["summary"]) as tmp, open(tmp, "w", encoding="utf-8") as fh:
            json.dump(_jsonable(data), fh, indent=2, sort_keys=False, allow_nan=False)
            fh.write("\n")
        return paths


# --------------------------------------------------------------------------------------
# the comparison
# --------------------------------------------------------------------------------------
def compare_images(
    other,
    reference,
    *,
    other_space: str = "sRGB",
    reference_space: str = "XYZ",
    weights=None,
    mask=None,
    scale_method: str = "median_log",
    info: dict | None = None,
) -> Comparison:
    r"""Compare ``other`` with ``reference`` (ours), pixel by pixel, in the same layout.

    Parameters
    ----------
    other, reference : array_like
        Images of the same shape: (…, 3) linear RGB in a colourspace or CIE XYZ, or (…)
        luminance.  Absolute units (cd m⁻²) for ``reference``; ``other`` may be in any units
        (see ``scale``).
    other_space, reference_space : str
        ``"XYZ"``, ``"luminance"`` (no channel axis) or an RGB colourspace name known to
        colour-science (linear values), e.g. ``"sRGB"``, ``"ACEScg"``.
    weights : array_like, optional
        Per-pixel weights of the statistics, normally the pixel solid angles [sr]; default
        equal weights.
    mask : array_like of bool, optional
        Pixels to compare (e.g. the sky above the horizon).  Pixels where the reference
        luminance is not positive or either image is not finite are always excluded.
    scale_method : str
        Key of :data:`SCALE_METHODS`.
    info : dict, optional
        Extra provenance copied into the summary.

    Returns
    -------
    Comparison

    Raises
    ------
    ValueError
        Mismatched shapes, unknown spaces/methods, or no pixel left to compare.
    """
    check_option(scale_method, "scale_method", SCALE_METHODS)
    xyz_o, y_o = _to_xyz(other, other_space, "other")
    xyz_r, y_r = _to_xyz(reference, reference_space, "reference")
    if y_o.shape != y_r.shape:
        raise ValueError(f"other and reference images differ in shape: {y_o.shape} vs "
                         f"{y_r.shape} (pixels) — bring them to the same layout and size")
    shape = y_r.shape
    if weights is None:
        w_all = np.ones(shape)
        weighting = "pixel"
    else:
        w_all = check_positive(weights, "weights", allow_zero=True).astype(np.float64)
        if w_all.shape != shape:
            raise ValueError(f"weights must have the image shape {shape}, got {w_all.shape}")
        weighting = "solid_angle"
    fin_o = np.isfinite(y_o) if xyz_o is None else np.all(np.isfinite(xyz_o), axis=-1)
    fin_o &= np.isfinite(y_o)
    fin_r = np.isfinite(y_r) if xyz_r is None else np.all(np.isfinite(xyz_r), axis=-1)
    fin_r &= np.isfinite(y_r)
    valid = fin_o & fin_r & (w_all > 0)
    with np.errstate(invalid="ignore"):
        valid &= y_r > 0
    inside = np.ones(shape, dtype=bool)
    if mask is not None:
        m = np.asarray(mask, dtype=bool)
        if m.shape != shape:
            raise ValueError(f"mask must have the image shape {shape}, got {m.shape}")
        valid &= m
        inside = m
    nonfinite_o = int(np.count_nonzero(inside & ~fin_o))
    nonfinite_r = int(np.count_nonzero(inside & ~fin_r))
    n = int(valid.sum())
    if n == 0:
        raise ValueError("no pixel to compare: the reference luminance is not positive (or not "
                         "finite) wherever the mask allows")
    yo, yr, w = y_o[valid], y_r[valid], w_all[valid]
    signed = yo / yr - 1.0
    err = np.abs(signed)
    pos = yo > 0
    if not np.any(pos):
        raise ValueError("the other image has no pixel with positive luminance where the "
                         "reference has: cannot fit a scale factor")
    s = float(SCALE_METHODS[scale_method](yr[pos] / yo[pos], w[pos]))
    err_scaled = np.abs(s * yo / yr - 1.0)

    rel_map = np.full(shape, np.nan)
    rel_map[valid] = signed
    de_stats, de_map, white = None, None, None
    if xyz_o is not None and xyz_r is not None:
        white = weighted_quantile(yr, 0.5, w) / MIDDLE_GREY
        de = _delta_e_2000(s * xyz_o[valid], xyz_r[valid], white)
        de_stats = _stats(de, w)
        de_map = np.full(shape, np.nan)
        de_map[valid] = de
    return Comparison(
        luminance_relative_error=_stats(err, w),
        scale=s,
        scale_method=scale_method,
        scaled_luminance_relative_error=_stats(err_scaled, w),
        delta_e_2000=de_stats,
        pixels_compared=n,
        pixels_total=int(np.prod(shape, dtype=np.int64)),
        weighting=weighting,
        relative_error_map=rel_map,
        delta_e_map=de_map,
        white_luminance=white,
        info=dict(info or {}),
        nonfinite_other=nonfinite_o,
        nonfinite_reference=nonfinite_r,
    )

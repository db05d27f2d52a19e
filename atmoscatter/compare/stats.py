r"""Use atmoscatter as a reference oracle: compare another renderer's sky map with ours.

Public objects
--------------
- :func:`compare_images`: compare two images already in the same layout (arrays) —
  luminance relative error without rescaling, best-fit scale factor, ΔE 2000 after exposure
  normalisation, error maps.  Returns a :class:`Comparison`.
- :class:`Comparison`: the result; :meth:`Comparison.to_dict` (JSON-ready summary) and
  :meth:`Comparison.write` (``summary.json``, ``error_map.png``, ``delta_e_map.png``).
- :func:`read_sky_map`: read another renderer's EXR (lat-long, cube map, fisheye or a
  direction set) into CIE XYZ in our layout, applying the rotate/flip/colourspace options.
- :func:`compare_exr`: read an EXR, render our reference for a scene at the same directions
  and compare (the Python equivalent of ``atmoscatter compare``).
- :func:`add_compare_parser`, :func:`run_compare`: the ``compare`` subcommand.
- :data:`SCALE_METHODS`: registry of best-fit scale estimators.

Assumed layout and frame
------------------------
Our sky maps use OpenEXR's environment-map conventions with the OpenEXR environment frame
(x = west, y = up, z = north) tied to our local frame (x = east, y = north, z = up):

- **lat-long** (``envmap = latlong``, width = 2 × height): row 0 at the zenith, the last row
  at the nadir, rows uniform in elevation; column ``c`` looks at geographic azimuth (from
  north toward east) ``2π (c + ½)/width − π`` — south at both edges, north in the centre
  column, east at three quarters of the width.
- **cube map** (``envmap = cube``, height = 6 × width): six faces stacked vertically in the
  order +X, −X, +Y, −Y, +Z, −Z of the OpenEXR frame (west, east, up, down, north, south),
  with OpenEXR's face orientations.
- **fisheye** (square): angular (equidistant) projection of the upper hemisphere, zenith at
  the centre, north up, east to the left (as seen looking up).
- **directions**: any direction set (a sky-dome mesh, your own sample points): the file
  carries the unit direction of every pixel in channels ``dir.X``, ``dir.Y``, ``dir.Z`` in the
  local frame (x = east, y = north, z = up), as ``atmoscatter render`` writes dome meshes.
  Our reference is rendered at exactly those directions; statistics are weighted per pixel.

Another renderer's map in a different convention is brought into ours with ``flip``
(applied first) and ``rotate_deg``: the pixel the file stores at azimuth *a* is compared
with our sky at azimuth *a* + ``rotate_deg``.  Lat-long maps are shifted column-wise (linear
interpolation for fractional shifts); for cube maps, fisheyes and direction sets the pixels'
directions are transformed and our reference is rendered exactly there.
``flip="horizontal"`` mirrors azimuth (a map whose azimuth runs west-ward),
``flip="vertical"`` swaps zenith and nadir (top and bottom rows of a lat-long map).
RGB files are read as **linear** RGB in ``colourspace`` (any colour-science name, default
sRGB / Rec. 709 primaries); files that carry ``XYZ.X/Y/Z`` or a single ``Y`` channel are
used as such; spectral files (layers ``S0.<λ>nm`` of spectral radiance in
W m⁻² sr⁻¹ nm⁻¹, the Fichet et al. 2021 convention the renderer writes) are integrated to XYZ
with the CIE 1931 2° colour-matching functions.  Priority: XYZ, RGB, spectral, Y.

What is compared
----------------
- ``luminance_relative_error``: ``|Y_other − Y_ours| / Y_ours`` per pixel, **without**
  rescaling, summarised by its median, 95th percentile and maximum.  Percentiles are
  weighted by pixel solid angle when it is known (a fraction of the sky, not of the
  pixels), inverted-CDF definition (no interpolation).
- ``scale``: the best-fit factor *s* with ``s · Y_other ≈ Y_ours`` — for renderers in
  arbitrary units.  Default estimator ``median_log``: ``s = exp(weighted median of
  ln(Y_ours/Y_other))``, robust to local defects; ``least_squares`` minimises the weighted
  relative squared error ``Σ w (s Y_other/Y_ours − 1)²``.
- ``scaled_luminance_relative_error``: the same statistics after multiplying by *s*.
- ``delta_e_2000``: CIEDE2000 colour difference (colour-science) after exposure
  normalisation: the other image is multiplied by *s*, both are divided by
  ``Y_w = median(Y_ours)/0.18`` (so our median sky luminance sits at middle grey, L* ≈ 50)
  and converted to CIELAB with the D65 white.  Pixels where our luminance is not positive,
  pixels that are not finite in either image, pixels outside the chosen region (default:
  the sky above the horizon) and a small cone around the sun (default 1°) are excluded.
"""

from __future__ import annotations

import json
import math
import os
from dataclasses import dataclass, field

import numpy as np

from .._validate import as_float_array, check_option, check_positive

__all__ = [
    "SCALE_METHODS",
    "Comparison",
    "compare_images",
    "weighted_quantile",
    "SkyMap",
    "read_sky_map",
    "compare_exr",
    "add_compare_parser",
    "run_compare",
]

#: Luminance that middle grey (L* ≈ 50) stands for in the ΔE normalisation, relative to the
#: reference image's median luminance.
MIDDLE_GREY: float = 0.18

LAYOUTS = ("auto", "latlong", "cubemap", "fisheye", "directions")
FLIPS = ("none", "horizontal", "vertical", "both")
REGIONS = ("sky", "all")

#: Default error-map colour range: relative error ±1 (±100 %) for the luminance map and
#: ΔE00 0…10 for the colour-difference map.
ERROR_MAP_RANGE: float = 1.0
DELTA_E_MAP_RANGE: float = 10.0


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
# colour
# --------------------------------------------------------------------------------------
def _to_xyz(image, space: str, name: str):
    """(…, 3) linear RGB / XYZ, or (…) luminance → (XYZ or None, Y)."""
    a = as_float_array(image, name).astype(np.float64)
    if space == "luminance":
        return None, a
    if a.shape[-1:] != (3,):
        raise ValueError(f"{name} must have 3 channels on its last axis for space={space!r}, "
                         f"got shape {a.shape}; use space='luminance' for a Y-only image")
    if space == "XYZ":
        return a, a[..., 1]
    from ..colour import linear_rgb_to_XYZ

    xyz = np.asarray(linear_rgb_to_XYZ(a, colourspace=space), dtype=np.float64)
    return xyz, xyz[..., 1]


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


# --------------------------------------------------------------------------------------
# reading another renderer's EXR
# --------------------------------------------------------------------------------------
@dataclass
class SkyMap:
    """Another renderer's sky map, converted to our layout.

    Attributes
    ----------
    xyz : ndarray or None
        CIE XYZ (in the file's units), shape (rows, columns, 3); None for Y-only files.
    luminance : ndarray
        Y, shape (rows, columns).
    layout : str
        ``latlong``, ``cubemap`` or ``fisheye``.
    width, height : int
        Scene resolution fields that reproduce the layout (``cubemap``: width = face size).
    header : dict
        The file's header attributes (strings and numbers only).
    source : str
        How the colour was read (``XYZ channels``, ``Y channel`` or ``RGB as <colourspace>``).
    directions : ndarray or None
        Where each pixel looks in our local frame (rows, columns, 3) when the comparison must
        be rendered at explicit directions: the ``directions`` layout, and cube maps or
        fisheyes with ``flip``/``rotate_deg`` (their pixel directions, transformed).  None
        when the file is already in our layout (after the lat-long column operations).
    solid_angles, valid : ndarray or None
        Pixel solid angles [sr] and validity of a transformed cube map or fisheye.
    """

    xyz: np.ndarray | None
    luminance: np.ndarray
    layout: str
    width: int
    height: int
    header: dict
    source: str
    directions: np.ndarray | None = None
    solid_angles: np.ndarray | None = None
    valid: np.ndarray | None = None


def _read_exr_channels(path):
    from ..exr import read_exr

    img = read_exr(path)
    if not img.channels:
        raise ValueError(f"{os.fspath(path)!r} has no image channels")
    return img.channels, img.header


def _spectral_channels(chans):
    """(wavelengths [nm], channel names) of spectral layers ``S0.<λ>nm`` (Fichet et al.
    2021, λ with ',' or '.' as decimal separator), sorted; None if fewer than 2."""
    found = []
    for name in chans:
        if name.startswith("S0.") and name.endswith("nm"):
            try:
                found.append((float(name[3:-2].replace(",", ".")), name))
            except ValueError:
                continue
    if len(found) < 2:
        return None
    found.sort()
    return np.array([w for w, _ in found]), [n for _, n in found]


def _detect_layout(header, h, w, path, chans=()):
    if all(c in chans for c in ("dir.X", "dir.Y", "dir.Z")):
        return "directions"
    env = header.get("envmap")
    if env is not None:
        name = str(env).lower()
        v = getattr(env, "value", env)
        if "latlong" in name or v == 0:
            return "latlong"
        if "cube" in name or v == 1:
            return "cubemap"
    if w == 2 * h:
        return "latlong"
    if h == 6 * w:
        return "cubemap"
    if w == h:
        return "fisheye"
    raise ValueError(f"{path!r}: cannot infer the layout of a {w}×{h} image without an envmap "
                     "attribute or dir.X/dir.Y/dir.Z channels; pass layout='latlong' (width = "
                     "2 × height), 'cubemap' (height = 6 × width) or 'fisheye' (square)")


def _rotate_columns(a, rotate_deg):
    """Compare stored azimuth a with ours at a + rotate: periodic column shift (linear)."""
    w = a.shape[1]
    shift = (rotate_deg / 360.0) * w
    k0 = math.floor(shift)
    frac = shift - k0
    out = np.roll(a, k0, axis=1)
    if frac > 1e-9:
        out = (1.0 - frac) * out + frac * np.roll(a, k0 + 1, axis=1)
    return out


def read_sky_map(path, *, layout: str = "auto", rotate_deg: float = 0.0, flip: str = "none",
                 colourspace: str = "sRGB") -> SkyMap:
    """Read another renderer's EXR sky map into CIE XYZ in our layout.

    Parameters
    ----------
    path : str or path-like
        OpenEXR file with ``XYZ.X/Y/Z``, ``R, G, B`` (linear, in ``colourspace``), spectral
        ``S0.<λ>nm`` (W m⁻² sr⁻¹ nm⁻¹) or ``Y`` channels (in that priority).
    layout : {"auto", "latlong", "cubemap", "fisheye", "directions"}
        ``auto``: ``directions`` if the file has ``dir.X/Y/Z`` channels, else the ``envmap``
        header attribute, else the aspect ratio (2:1 lat-long, 1:6 cube map, square fisheye).
    rotate_deg : float
        The pixel stored at azimuth *a* is compared with ours at *a* + ``rotate_deg`` [deg]:
        lat-long maps are shifted column-wise (fractional shifts interpolate linearly); cube
        maps, fisheyes and direction sets get transformed pixel directions.
    flip : {"none", "horizontal", "vertical", "both"}
        Mirror the file's columns (azimuth direction) and/or rows before rotating.
    colourspace : str
        Colourspace of linear RGB files (colour-science name).

    Returns
    -------
    SkyMap

    Raises
    ------
    ValueError
        Missing/unreadable file, no usable channels, inconsistent size for the layout,
        unsupported option for the layout.
    """
    check_option(layout, "layout", LAYOUTS)
    check_option(flip, "flip", FLIPS)
    rotate_deg = float(rotate_deg)
    if not math.isfinite(rotate_deg):
        raise ValueError(f"rotate_deg must be finite, got {rotate_deg}")
    chans, header = _read_exr_channels(path)
    if all(c in chans for c in ("XYZ.X", "XYZ.Y", "XYZ.Z")):
        xyz = np.stack([chans[c] for c in ("XYZ.X", "XYZ.Y", "XYZ.Z")], -1).astype(np.float64)
        source = "XYZ channels"
    elif all(c in chans for c in "RGB"):
        rgb = np.stack([chans[c] for c in "RGB"], -1).astype(np.float64)
        from ..colour import colourspace_names

        check_option(colourspace, "colourspace", colourspace_names())
        xyz, _ = _to_xyz(rgb, colourspace, "RGB")
        source = f"RGB as linear {colourspace}"
    elif _spectral_channels(chans):
        wl, names = _spectral_channels(chans)
        from ..colour import spectral_to_XYZ

        spec = np.stack([chans[n] for n in names], -1).astype(np.float64)
        xyz = np.asarray(spectral_to_XYZ(spec, wl), dtype=np.float64)
        source = (f"spectral radiance, {wl.size} bands {wl[0]:g}–{wl[-1]:g} nm "
                  "(W m-2 sr-1 nm-1, CIE 1931 2° CMFs)")
    elif "Y" in chans:
        xyz = None
        source = "Y channel"
    else:
        raise ValueError(f"{os.fspath(path)!r} has none of the channels R,G,B / XYZ.X,XYZ.Y,"
                         f"XYZ.Z / spectral S0.<λ>nm / Y (found {sorted(chans)})")
    lum = xyz[..., 1] if xyz is not None else np.asarray(chans["Y"], dtype=np.float64)
    if lum.ndim != 2:
        raise ValueError(f"{os.fspath(path)!r}: expected a 2-D image, got shape {lum.shape}")
    h, w = lum.shape
    lay = _detect_layout(header, h, w, os.fspath(path), chans) if layout == "auto" else layout
    if lay == "latlong" and w != 2 * h:
        raise ValueError(f"a lat-long map must be twice as wide as high, got {w}×{h}")
    if lay == "cubemap" and h != 6 * w:
        raise ValueError(f"a cube map must be six square faces stacked vertically "
                         f"(height = 6 × width), got {w}×{h}")
    if lay == "fisheye" and w != h:
        raise ValueError(f"a fisheye image must be square, got {w}×{h}")
    if lay == "fisheye" and flip in ("vertical", "both"):
        raise ValueError("flip='vertical' (zenith ↔ nadir) does not apply to a fisheye of the "
                         "upper hemisphere; an image with north at the bottom is rotate_deg=180 "
                         "(plus flip='horizontal' if east is still on the left)")
    dirs = solid = valid = None
    if lay == "directions":
        if not all(c in chans for c in ("dir.X", "dir.Y", "dir.Z")):
            raise ValueError(f"{os.fspath(path)!r}: layout 'directions' needs dir.X, dir.Y, "
                             f"dir.Z channels (found {sorted(chans)})")
        dirs = np.stack([chans[c] for c in ("dir.X", "dir.Y", "dir.Z")], -1).astype(np.float64)
        norm = np.linalg.norm(dirs, axis=-1, keepdims=True)
        if not np.all(np.isfinite(norm)) or np.any(np.abs(norm - 1.0) > 1e-3):
            raise ValueError(f"{os.fspath(path)!r}: dir.X/Y/Z must be unit vectors")
        dirs = _transform_directions(dirs / norm, flip, rotate_deg)
    elif lay in ("cubemap", "fisheye") and (flip != "none" or rotate_deg % 360.0 != 0.0):
        # the file's pixel p looks, in its own convention, where our layout's pixel p looks;
        # turn those directions into ours and render the reference exactly there
        from ..directions import CubeMapDirections, FisheyeDirections

        dset = CubeMapDirections(w) if lay == "cubemap" else FisheyeDirections(w, h)
        d, ok = dset.directions(0, dset.size)
        dirs = _transform_directions(np.asarray(d, dtype=np.float64).reshape(h, w, 3), flip,
                                     rotate_deg)
        solid = np.asarray(dset.solid_angles(0, dset.size), dtype=np.float64).reshape(h, w)
        valid = np.asarray(ok, dtype=bool).reshape(h, w)

    def transform(a):
        if lay != "latlong":  # the pixels stay; their directions were transformed
            return np.ascontiguousarray(a)
        if flip in ("horizontal", "both"):
            a = a[:, ::-1]
        if flip in ("vertical", "both"):
            a = a[::-1]
        if rotate_deg % 360.0 != 0.0:
            a = _rotate_columns(a, rotate_deg % 360.0)
        return np.ascontiguousarray(a)

    xyz = transform(xyz) if xyz is not None else None
    lum = xyz[..., 1] if xyz is not None else transform(lum)
    simple = {k: (v if isinstance(v, int | float | str) else str(v)) for k, v in header.items()}
    width, height = (w, h) if lay != "cubemap" else (w, w)
    return SkyMap(xyz=xyz, luminance=lum, layout=lay, width=width, height=height,
                  header=simple, source=source, directions=dirs, solid_angles=solid,
                  valid=valid)


def _transform_directions(dirs, flip: str, rotate_deg: float):
    """Apply ``flip`` then ``rotate_deg`` to unit directions (…, 3) in the local frame."""
    dirs = np.array(dirs, dtype=np.float64)
    if flip in ("horizontal", "both"):  # azimuth a → −a: mirror east–west
        dirs[..., 0] = -dirs[..., 0]
    if flip in ("vertical", "both"):
        dirs[..., 2] = -dirs[..., 2]
    r = math.radians(rotate_deg)  # azimuth a → a + rotate (from north toward east)
    x, y = dirs[..., 0].copy(), dirs[..., 1].copy()
    dirs[..., 0] = x * math.cos(r) + y * math.sin(r)
    dirs[..., 1] = y * math.cos(r) - x * math.sin(r)
    return dirs


# --------------------------------------------------------------------------------------
# EXR against our reference render
# --------------------------------------------------------------------------------------
def _scene_for(scene, sky_map: SkyMap):
    """Load/replace the scene so that it renders at the sky map's directions."""
    import dataclasses

    from ..scene import Scene, load_scene

    if isinstance(scene, str | os.PathLike):
        scene = load_scene(scene)
    elif isinstance(scene, dict):
        scene = Scene.from_dict(scene)
    elif scene is None:
        scene = Scene()
    changes = {"sun_disc": False}
    if sky_map.directions is None:  # else rendered at the file's own directions
        changes.update(projection=sky_map.layout, width=sky_map.width, height=sky_map.height)
    names = {f.name for f in dataclasses.fields(scene)}
    if "output" in names:
        changes["output"] = "xyz"
    return dataclasses.replace(scene, **{k: v for k, v in changes.items() if k in names})


def compare_exr(
    other,
    scene=None,
    *,
    layout: str = "auto",
    rotate_deg: float = 0.0,
    flip: str = "none",
    colourspace: str = "sRGB",
    region: str = "sky",
    sun_exclusion_deg: float = 1.0,
    scale_method: str = "median_log",
    reference=None,
) -> Comparison:
    """Compare another renderer's EXR sky map with our reference render of ``scene``.

    Parameters
    ----------
    other : str or path-like
        The other renderer's EXR (see :func:`read_sky_map` for layouts and options).
    scene : Scene, dict, str or path-like, optional
        The scene (object, field dict, or TOML/JSON file).  Its projection and resolution are
        replaced by the file's, the sun disc is not drawn (renderers differ too much there;
        the cone within ``sun_exclusion_deg`` of the sun is excluded instead).  Default: the
        package's default scene.
    layout, rotate_deg, flip, colourspace
        Passed to :func:`read_sky_map`.
    region : {"sky", "all"}
        Compare the sky above the horizon only (default) or every pixel we render.
    sun_exclusion_deg : float
        Angular radius [deg] around the sun left out of the statistics (≥ 0).
    scale_method : str
        Key of :data:`SCALE_METHODS`.
    reference : SkyImage, optional
        A render to use instead of rendering ``scene`` (it must match the layout and size).

    Returns
    -------
    Comparison
    """
    check_option(region, "region", REGIONS)
    excl = float(check_positive(sun_exclusion_deg, "sun_exclusion_deg", allow_zero=True,
                                unit="deg"))
    sky = read_sky_map(other, layout=layout, rotate_deg=rotate_deg, flip=flip,
                       colourspace=colourspace)
    if reference is None:
        from ..render import render

        sc = _scene_for(scene, sky)
        reference = render(sc) if sky.directions is None else \
            render(sc, directions=sky.directions)
    else:
        sc = reference.scene
    ours_y = np.asarray(reference.luminance, dtype=np.float64)
    if ours_y.shape != sky.luminance.shape:
        raise ValueError(f"our render has shape {ours_y.shape} but {os.fspath(other)!r} has "
                         f"{sky.luminance.shape}; they must match pixel for pixel")
    if reference.xyz is not None:
        ours_xyz = np.asarray(reference.xyz, dtype=np.float64)
    elif reference.rgb is not None:
        ours_xyz, _ = _to_xyz(reference.rgb, sc.colourspace, "reference")
    else:
        ours_xyz = None
    dset = reference.directions_set
    dirs = dset.all_directions()
    solid = np.asarray(dset.solid_angles(0, dset.size)).reshape(ours_y.shape)
    mask = np.ones(ours_y.shape, dtype=bool)
    if reference.alpha is not None:
        mask &= np.asarray(reference.alpha) > 0
    if region == "sky":
        mask &= dirs[..., 2] > 0
    sun = np.asarray(reference.plan.sun_direction, dtype=float)
    if excl > 0:
        mask &= dirs @ sun < math.cos(math.radians(excl))
    if sky.xyz is not None and ours_xyz is not None:
        o, r, o_space, r_space = sky.xyz, ours_xyz, "XYZ", "XYZ"
    else:
        o, r, o_space, r_space = sky.luminance, ours_y, "luminance", "luminance"
    scene_fields = sc.to_dict() if hasattr(sc, "to_dict") else {}
    info = {
        "other": os.fspath(other),
        "other_colour": sky.source,
        "layout": sky.layout,
        "frame": ("local x=east, y=north, z=up; OpenEXR envmap orientation with its frame "
                  "x=west, y=up, z=north"),
        "options": {"rotate_deg": rotate_deg, "flip": flip, "colourspace": colourspace,
                    "region": region, "sun_exclusion_deg": excl},
        "scene": scene_fields,
    }
    if sky.directions is not None:  # rendered at explicit directions
        solid = sky.solid_angles  # None for a bare direction set: per-pixel weights
        if sky.valid is not None:
            mask &= sky.valid
    weights = solid
    return compare_images(o, r, other_space=o_space, reference_space=r_space, weights=weights,
                          mask=mask, scale_method=scale_method, info=info)


# --------------------------------------------------------------------------------------
# command line
# --------------------------------------------------------------------------------------
def add_compare_parser(subparsers):
    """Register ``atmoscatter compare OTHER.exr --scene SCENE [-o DIR]`` on ``subparsers``.

    The handler is :func:`run_compare` (also set as the parser's ``func`` default).

    Parameters
    ----------
    subparsers : argparse._SubParsersAction
        The ``atmoscatter`` command's sub-command registry (``parser.add_subparsers()``).

    Returns
    -------
    argparse.ArgumentParser
        The ``compare`` parser.
    """
    import argparse

    p = subparsers.add_parser(
        "compare",
        help="compare another renderer's EXR sky map with our reference render",
        description=(
            "Render our reference for SCENE at the directions of OTHER.exr and report the "
            "luminance relative error (median, p95, max; no rescaling), the best-fit scale "
            "factor and Delta E 2000 after exposure normalisation.  Assumed layout: OpenEXR "
            "envmap conventions (lat-long: zenith on top, north in the centre column, east at "
            "3/4 width; cube map: +X,-X,+Y,-Y,+Z,-Z faces of the frame x=west, y=up, "
            "z=north); RGB is linear in --colourspace."
        ),
    )
    p.add_argument("other", metavar="OTHER.exr", help="the other renderer's sky map")
    p.add_argument("--scene", default=None,
                   help="scene file (TOML or JSON); default: the atmoscatter scene recorded "
                        "in OTHER.exr's header, if any")
    p.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                   help="override a scene field (repeatable)")
    p.add_argument("-o", "--output", metavar="DIR", default=None,
                   help="write DIR/summary.json, DIR/error_map.png and DIR/delta_e_map.png")
    p.add_argument("--layout", choices=LAYOUTS, default="auto",
                   help="layout of OTHER.exr (default: from its envmap attribute or shape)")
    p.add_argument("--rotate", type=float, default=0.0, metavar="DEG",
                   help="the file's azimuth a is compared with ours at a + DEG")
    p.add_argument("--flip", choices=FLIPS, default="none",
                   help="mirror OTHER.exr's columns (azimuth) and/or rows before rotating")
    p.add_argument("--colourspace", default="sRGB",
                   help="colourspace of OTHER.exr's linear RGB (colour-science name)")
    p.add_argument("--region", choices=REGIONS, default="sky",
                   help="compare the sky above the horizon (default) or all pixels")
    p.add_argument("--sun-exclusion", type=float, default=1.0, metavar="DEG",
                   help="leave out a cone of this radius around the sun (default 1)")
    p.add_argument("--scale-method", choices=sorted(SCALE_METHODS), default="median_log")
    p.add_argument("--debug", action="store_true", default=argparse.SUPPRESS,
                   help="show tracebacks on errors")
    p.set_defaults(func=run_compare)
    return p


def _scene_for_cli(args):
    from ..scene import Scene, load_scene

    if args.scene:
        scene = load_scene(args.scene)
    else:
        _, header = _read_exr_channels(args.other)
        data = {k: v for k, v in header.items()
                if k in Scene.field_names() and isinstance(v, str)}
        if not data:
            raise ValueError(f"{args.other!r} records no atmoscatter scene; pass --scene "
                             "SCENE.toml (the scene the other renderer rendered)")
        scene = Scene.from_dict(data)
    if args.set:
        scene = scene.replace_from_strings(args.set)
    return scene


def run_compare(args, out=None) -> int:
    """Handler of the ``compare`` subcommand: prints the summary (to ``out``, default
    stdout), writes the report if ``-o`` was given and returns the exit status (0).

    Parameters
    ----------
    args : argparse.Namespace
        Parsed arguments of the ``compare`` parser (:func:`add_compare_parser`).
    out : file-like, optional
        Where the summary is printed (default ``sys.stdout``).

    Returns
    -------
    int
        Exit status: 0.
    """
    import sys

    out = sys.stdout if out is None else out
    result = compare_exr(
        args.other, _scene_for_cli(args), layout=args.layout, rotate_deg=args.rotate,
        flip=args.flip, colourspace=args.colourspace, region=args.region,
        sun_exclusion_deg=args.sun_exclusion, scale_method=args.scale_method,
    )
    print(result.summary_text(), file=out)
    if args.output:
        paths = result.write(args.output)
        print("wrote " + ", ".join(paths.values()), file=out)
    return 0

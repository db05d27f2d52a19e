"""Tone-mapped 8-bit PNG previews of sky maps (no extra dependency).

Public objects
--------------
:func:`tone_map`
    Linear radiance [cd m⁻²] → display values in [0, 1]: the exponential curve
    of seed 002 (``1 − e^{−exposure·L}``), Reinhard's ``x/(1 + x)``, or a clip, each
    applied to every RGB channel on its own; or ``luminance``: the exponential curve
    applied to the luminance and the RGB colour scaled with it, which keeps every
    colour's chromaticity (a bright red sunset stays red instead of saturating to
    yellow or white channel by channel).
:func:`auto_exposure`
    An exposure [m² cd⁻¹] that maps the median sky luminance to mid-grey.
:func:`preview_array`, :func:`write_preview`, :func:`write_png`
    8-bit sRGB-encoded RGB(A) arrays and PNG files (written with zlib, atomically).

Alpha (for blending with a star background, as seed 002 does): ``mask`` uses
the map's alpha (sky 1, ground/outside 0); ``sky`` uses seed 002's
``(r + g + b)^transparency`` of the tone-mapped colour (clipped to 1), so a
dark night sky lets the stars through.
"""

from __future__ import annotations

import math
import os
import struct
import zlib

import numpy as np

from ._scene_checks import TONES  # one list for Scene.tone, the CLI and these curves
from .exr import atomic_write

__all__ = ["tone_map", "auto_exposure", "preview_array", "write_preview", "write_png",
           "srgb_encode"]

ALPHAS = ("none", "mask", "sky")


def auto_exposure(luminance, mask=None) -> float:
    """Exposure [m² cd⁻¹] mapping the median luminance of ``mask`` to 0.5 (exponential).

    ``ln 2 / median(L)``; 1 if the image is black.

    Parameters
    ----------
    luminance : array_like
        Luminance [cd m⁻²]; non-finite and non-positive values are ignored.
    mask : array_like, optional
        Pixels with ``mask > 0`` are used (default all).

    Returns
    -------
    float
        Exposure [m² cd⁻¹].
    """
    L = np.asarray(luminance, dtype=float)
    if mask is not None:
        L = L[np.asarray(mask) > 0]
    L = L[np.isfinite(L) & (L > 0)]
    if L.size == 0:
        return 1.0
    return math.log(2.0) / float(np.median(L))


def tone_map(values, exposure: float, tone: str = "exponential", *, luminance=None,
             colourspace: str = "sRGB"):
    """Map linear values [cd m⁻²] to [0, 1] with ``tone`` at ``exposure`` [m² cd⁻¹].

    With ``x = exposure·values``: ``exponential`` is ``1 − e^{−x}`` (seed 002's
    ``finalColor = 1 − exp(−exposure·finalColor)``), ``reinhard`` is ``x/(1 + x)`` and
    ``clip`` is ``min(x, 1)``, each applied to every channel on its own — so a colour
    brighter than white drifts toward white or a secondary colour channel by channel.

    ``luminance`` keeps chromaticity: with ``y = exposure·Y`` (``Y`` the luminance of the
    colour ``c``), the output is ``d = s·exposure·c`` with one factor per pixel,

    ``s = min((1 − e^{−y}) / y, 1 / max_k(exposure·c_k))``,

    i.e. the exponential curve is applied to the luminance and the colour scaled with it;
    where that would lift a channel above 1 (a saturated colour brighter than white can
    show) the whole colour is scaled down until its largest channel is 1.  The channel
    ratios — hence the chromaticity and hue — are exactly those of ``c``; the displayed
    luminance ``s·y`` is non-decreasing in ``y`` for a fixed chromaticity and equals
    ``1 − e^{−y}`` wherever no channel reaches 1 (for an achromatic colour ``c = (Y, Y, Y)``
    it is the ``exponential`` curve).  Black stays black.

    Parameters
    ----------
    values : array_like
        Linear luminance or RGB [cd m⁻²]; NaN counts as 0, negative values are clipped to 0.
        ``tone = "luminance"`` needs RGB, channels on the last axis ``(..., 3)``.
    exposure : float
        Scale applied before the curve [m² cd⁻¹], in (0, inf).
    tone : {"exponential", "reinhard", "clip", "luminance"}
        The curve (see above).
    luminance : array_like, optional
        ``tone = "luminance"`` only: the luminance ``Y`` [cd m⁻²] of ``values``, shape
        ``values.shape[:-1]`` (e.g. :attr:`SkyImage.luminance`); default computed from the
        RGB values with the luminance coefficients of ``colourspace``.
    colourspace : str
        RGB colourspace of ``values`` (for its luminance coefficients; default ``sRGB``).

    Returns
    -------
    ndarray
        Display values [-] in [0, 1], same shape as ``values``.

    Raises
    ------
    ValueError
        For an unknown ``tone``, an ``exposure`` outside (0, inf), or ``tone="luminance"``
        with values that are not RGB or a ``luminance`` of another shape.
    """
    if tone not in TONES:
        raise ValueError(f"tone={tone!r} is not valid; choose one of {sorted(TONES)}")
    if not (exposure > 0 and math.isfinite(exposure)):
        raise ValueError(f"exposure must be in (0, inf) m^2/cd, got {exposure!r}")
    x = np.maximum(np.nan_to_num(np.asarray(values, dtype=np.float64), nan=0.0, posinf=1e30), 0.0)
    x = x * exposure
    if tone == "exponential":  # seed 002: finalColor = 1 - exp(-exposure * finalColor)
        return -np.expm1(-x)
    if tone == "reinhard":
        return x / (1.0 + x)
    if tone == "clip":
        return np.minimum(x, 1.0)
    return _tone_luminance(x, exposure, luminance, colourspace)


def _tone_luminance(x, exposure, luminance, colourspace):
    """The ``luminance`` curve of :func:`tone_map` on exposed, non-negative RGB ``x``."""
    if x.ndim < 1 or x.shape[-1] != 3:
        raise ValueError(f"tone='luminance' needs RGB values (..., 3), got shape {x.shape}")
    if luminance is None:
        from .colour import _luminance_coefficients  # noqa: PLC0415  (shipped table)

        y = x @ _luminance_coefficients(colourspace)
    else:
        y = np.asarray(luminance, dtype=np.float64)
        if y.shape != x.shape[:-1]:
            raise ValueError(f"luminance must have shape {x.shape[:-1]} (the RGB values "
                             f"without their channel axis), got {y.shape}")
        y = np.maximum(np.nan_to_num(y, nan=0.0, posinf=1e30), 0.0) * exposure
    peak = np.maximum(np.maximum(x[..., 0], x[..., 1]), x[..., 2])
    with np.errstate(divide="ignore", invalid="ignore"):
        # (1 − e^{−y})/y → 1 for y → 0: expm1 keeps it exact for tiny y; y = 0 gives 0/0 → 1
        gain = np.where(y > 0.0, -np.expm1(-y) / y, 1.0)
        s = np.minimum(gain, np.where(peak > 0.0, 1.0 / peak, np.inf))
    s = np.where(np.isfinite(s), s, 0.0)
    return np.minimum(x * s[..., None], 1.0)  # the min only removes rounding above 1


def srgb_encode(v):
    """IEC 61966-2-1 sRGB transfer function (linear [0, 1] → encoded [0, 1]).

    Parameters
    ----------
    v : array_like
        Linear values [-] in [0, 1].

    Returns
    -------
    ndarray
        Encoded values [-] in [0, 1].
    """
    v = np.clip(v, 0.0, 1.0)
    return np.where(v <= 0.0031308, 12.92 * v, 1.055 * np.power(v, 1.0 / 2.4) - 0.055)


def preview_array(rgb, *, exposure=None, tone="exponential", alpha="none", mask=None,
                  transparency=0.5, luminance=None, colourspace="sRGB"):
    """8-bit sRGB preview, shape ``(h, w, 3)`` or ``(h, w, 4)`` with alpha.

    Parameters
    ----------
    rgb : array_like (h, w, 3) or (h, w)
        Linear RGB (or luminance) [cd m⁻²].
    exposure : float, optional
        [m² cd⁻¹]; default :func:`auto_exposure`.
    tone : {"exponential", "reinhard", "clip", "luminance"}
        Tone curve (see :func:`tone_map`; ``luminance`` keeps chromaticity).
    alpha : {"none", "mask", "sky"}
        See the module notes.
    mask : array_like (h, w), optional
        Alpha of the map (used by ``alpha="mask"`` and by the auto exposure).
    transparency : float
        Exponent of seed 002's alpha ``(r + g + b)^transparency``, in (0, inf).
    luminance : array_like (h, w), optional
        Luminance Y [cd m⁻²] of the pixels (e.g. :attr:`SkyImage.luminance`): used by the
        automatic exposure and by ``tone="luminance"``; default computed from ``rgb``
        (the channel mean for the exposure, the ``colourspace`` coefficients for the tone).
    colourspace : str
        RGB colourspace of ``rgb`` (``tone="luminance"`` without ``luminance``).

    Returns
    -------
    ndarray of uint8, shape (h, w, 3) or (h, w, 4)
        sRGB-encoded pixels (with alpha unless ``alpha="none"``).
    """
    if alpha not in ALPHAS:
        raise ValueError(f"alpha={alpha!r} is not valid; choose one of {sorted(ALPHAS)}")
    t = float(transparency)
    if not (math.isfinite(t) and t > 0.0):
        raise ValueError(f"transparency must be in (0, inf), got {transparency!r}")
    a = np.asarray(rgb, dtype=np.float64)
    if a.ndim == 2:
        a = np.repeat(a[..., None], 3, axis=-1)
    if a.ndim != 3 or a.shape[-1] != 3:
        raise ValueError(f"rgb must have shape (h, w, 3) or (h, w), got {a.shape}")
    if exposure is None:
        lum = a.mean(axis=-1) if luminance is None else luminance
        exposure = auto_exposure(lum, mask)
    if tone == "luminance":
        mapped = tone_map(a, exposure, tone, luminance=luminance, colourspace=colourspace)
    else:
        mapped = tone_map(a, exposure, tone)
    out = np.round(srgb_encode(mapped) * 255.0).astype(np.uint8)
    if alpha == "none":
        return out
    if alpha == "mask":
        m = np.ones(a.shape[:2]) if mask is None else np.asarray(mask, dtype=float)
        al = np.clip(m, 0.0, 1.0)
    else:
        al = np.minimum(np.power(mapped.sum(axis=-1), transparency), 1.0)
        if mask is not None:
            al = al * np.clip(np.asarray(mask, dtype=float), 0.0, 1.0)
    return np.concatenate([out, np.round(al * 255.0).astype(np.uint8)[..., None]], axis=-1)


def write_png(path, pixels) -> str:
    """Write 8-bit RGB/RGBA/grey ``pixels`` (h, w[, c]) as a PNG, atomically.

    Parameters
    ----------
    path : str or path-like
        Output file (written to a temporary name, then moved into place).
    pixels : array_like of uint8, shape (h, w) or (h, w, c) with c in {1, 3, 4}
        Grey, RGB or RGBA pixel values.

    Returns
    -------
    str
        ``path``.

    Notes
    -----
    Each row is stored with the PNG filter (none, Sub, Up, Average or Paeth; PNG
    specification, 2nd ed., W3C 2003, section 9) that gives the smallest sum of absolute
    filtered bytes, the specification's recommended heuristic (section 12.8): smooth sky
    gradients then compress several times better than unfiltered rows.
    """
    p = np.ascontiguousarray(pixels, dtype=np.uint8)
    if p.ndim == 2:
        p = p[..., None]
    h, w, c = p.shape
    colour_type = {1: 0, 3: 2, 4: 6}.get(c)
    if colour_type is None:
        raise ValueError(f"pixels must have 1, 3 or 4 channels, got {c}")
    raw = _filter_rows(p.reshape(h, w * c), c)  # in row blocks: bounded working memory

    def chunk(tag, data):
        body = tag + data
        return struct.pack(">I", len(data)) + body + struct.pack(">I", zlib.crc32(body) & 0xFFFFFFFF)

    png = (b"\x89PNG\r\n\x1a\n"
           + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, colour_type, 0, 0, 0))
           + chunk(b"IDAT", zlib.compress(raw.tobytes(), 6))
           + chunk(b"IEND", b""))
    path = os.fspath(path)
    with atomic_write(path) as tmp:
        with open(tmp, "wb") as fh:
            fh.write(png)
    return path


#: rows filtered at a time by :func:`_filter_rows` (its candidates take ~10 bytes per byte)
_FILTER_BLOCK_ROWS = 256


def _filter_rows(rows, bpp):
    """PNG scanlines: each row of ``rows`` (h, n) uint8 prefixed by its filter type and
    filtered with the type of least sum of absolute (signed) filtered bytes; in blocks of
    :data:`_FILTER_BLOCK_ROWS` rows (each block sees the row above it)."""
    h = rows.shape[0]
    blocks = [_filter_block(rows[i:i + _FILTER_BLOCK_ROWS], rows[i - 1] if i else None, bpp)
              for i in range(0, h, _FILTER_BLOCK_ROWS)]
    return np.concatenate(blocks, axis=0) if blocks else np.zeros((0, rows.shape[1] + 1), np.uint8)


def _filter_block(rows, above, bpp):
    """:func:`_filter_rows` of one block; ``above``: the row before it (``None``: the
    image's first row, whose "above" is 0)."""
    x = rows.astype(np.int16)
    up = np.zeros_like(x)
    up[1:] = x[:-1]
    if above is not None:
        up[0] = above
    a = np.zeros_like(x)
    a[:, bpp:] = x[:, :-bpp]  # left neighbour (same channel), 0 before the row
    b = up  # above, 0 on the first row
    c = np.zeros_like(x)
    c[:, bpp:] = up[:, :-bpp]  # above-left
    pa, pb, pc = np.abs(b - c), np.abs(a - c), np.abs(a + b - 2 * c)
    paeth = np.where((pa <= pb) & (pa <= pc), a, np.where(pb <= pc, b, c))
    cand = np.stack([x, x - a, x - b, x - (a + b) // 2, x - paeth]) & 0xFF  # types 0..4
    cost = np.abs(cand.astype(np.int8).astype(np.int32)).sum(axis=2)  # (5, h)
    kind = np.argmin(cost, axis=0)
    best = np.take_along_axis(cand, kind[None, :, None], axis=0)[0].astype(np.uint8)
    return np.concatenate([kind.astype(np.uint8)[:, None], best], axis=1)


def write_preview(source, path, *, exposure=None, tone=None, alpha="none",
                  transparency=0.5) -> str:
    """Write a PNG preview of a SkyImage or an EXR file (path or :class:`ExrImage`).

    ``tone``/``exposure`` default to the scene's (recorded in the EXR header),
    else ``exponential`` and :func:`auto_exposure`.

    Parameters
    ----------
    source : SkyImage, ExrImage, str or path-like
        The rendered image, or an EXR sky map (read with :func:`read_exr`).
    path : str or path-like
        Output PNG.
    exposure : float, optional
        [m² cd⁻¹]; default the scene's, else :func:`auto_exposure`.
    tone : {"exponential", "reinhard", "clip", "luminance"}, optional
        Default the scene's, else ``"exponential"`` (see :func:`tone_map`).
    alpha : {"none", "mask", "sky"}
        PNG alpha: none, the map's mask (sky 1, ground 0), or seed 002's
        ``(r + g + b)^transparency``.
    transparency : float
        Exponent of ``alpha="sky"``, in (0, inf).

    Returns
    -------
    str
        The path written.
    """
    from .exr import ExrImage, read_exr  # noqa: PLC0415

    if isinstance(source, (str, os.PathLike)):
        source = read_exr(source)
    if isinstance(source, ExrImage):
        rgb = source.rgb
        if rgb is None:
            rgb = source.luminance
        if rgb is None and source.xyz is not None:
            rgb = source.xyz[..., 1]
        if rgb is None:
            raise ValueError("the EXR file has no R, G, B, Y or XYZ channels to preview")
        mask = source.alpha
        hdr = source.header
        # Y of the RGB pixels: the XYZ layer's when written, else from the colourspace
        lum = source.xyz[..., 1] if source.rgb is not None and source.xyz is not None else None
        colourspace = hdr.get("colourspace") if isinstance(hdr.get("colourspace"), str) else None
        if hdr.get("atmoscatter:projection") == "dome":
            raise ValueError("a dome mesh has no image to preview; render a latlong, cubemap "
                             "or fisheye projection")
        if tone is None and isinstance(hdr.get("tone"), str) and hdr["tone"]:
            tone = hdr["tone"]
        if exposure is None and isinstance(hdr.get("exposure"), str) and hdr["exposure"]:
            exposure = float(hdr["exposure"])
    else:  # SkyImage
        if source.projection == "dome":
            raise ValueError("a dome mesh has no image to preview; render a latlong, cubemap "
                             "or fisheye projection")
        rgb = source.rgb if source.rgb is not None else source.luminance
        lum = source.luminance if source.rgb is not None else None
        colourspace = source.scene.colourspace
        mask = source.alpha
        if tone is None:
            tone = source.scene.tone
        if exposure is None:
            exposure = source.scene.exposure
    pixels = preview_array(np.asarray(rgb, dtype=np.float64), exposure=exposure,
                           tone=tone or "exponential", alpha=alpha, mask=mask,
                           transparency=transparency, luminance=lum,
                           colourspace=colourspace or "sRGB")
    return write_png(path, pixels)

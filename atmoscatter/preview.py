"""Tone-mapped 8-bit PNG previews of sky maps (no extra dependency).

Public objects
--------------
:func:`tone_map`
    Linear radiance [cd m⁻²] → display values in [0, 1]: the exponential curve
    of seed 002 (``1 − e^{−exposure·L}``), Reinhard's ``x/(1 + x)``, or a clip.
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

from .exr import atomic_write

__all__ = ["tone_map", "auto_exposure", "preview_array", "write_preview", "write_png",
           "srgb_encode"]

TONES = ("exponential", "reinhard", "clip")
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


def tone_map(values, exposure: float, tone: str = "exponential"):
    """Map linear values [cd m⁻²] to [0, 1] with ``tone`` at ``exposure`` [m² cd⁻¹].

    Parameters
    ----------
    values : array_like
        Linear luminance or RGB [cd m⁻²]; NaN counts as 0, negative values are clipped to 0.
    exposure : float
        Scale applied before the curve [m² cd⁻¹], in (0, inf).
    tone : {"exponential", "reinhard", "clip"}
        ``1 − e^{−x}`` (seed 002), ``x/(1 + x)`` or ``min(x, 1)`` of ``x = exposure·values``.

    Returns
    -------
    ndarray
        Display values [-] in [0, 1], same shape as ``values`` (each channel mapped on its own).
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
    return np.minimum(x, 1.0)


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
                  transparency=0.5, luminance=None):
    """8-bit sRGB preview, shape ``(h, w, 3)`` or ``(h, w, 4)`` with alpha.

    Parameters
    ----------
    rgb : array_like (h, w, 3) or (h, w)
        Linear RGB (or luminance) [cd m⁻²].
    exposure : float, optional
        [m² cd⁻¹]; default :func:`auto_exposure`.
    tone : {"exponential", "reinhard", "clip"}
    alpha : {"none", "mask", "sky"}
        See the module notes.
    mask : array_like (h, w), optional
        Alpha of the map (used by ``alpha="mask"`` and by the auto exposure).
    transparency : float
        Exponent of seed 002's alpha ``(r + g + b)^transparency``, in (0, inf).

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
    """
    p = np.ascontiguousarray(pixels, dtype=np.uint8)
    if p.ndim == 2:
        p = p[..., None]
    h, w, c = p.shape
    colour_type = {1: 0, 3: 2, 4: 6}.get(c)
    if colour_type is None:
        raise ValueError(f"pixels must have 1, 3 or 4 channels, got {c}")
    raw = np.concatenate([np.zeros((h, 1), dtype=np.uint8), p.reshape(h, w * c)], axis=1)

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
    tone : {"exponential", "reinhard", "clip"}, optional
        Default the scene's, else ``"exponential"``.
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
        mask = source.alpha
        if tone is None:
            tone = source.scene.tone
        if exposure is None:
            exposure = source.scene.exposure
    pixels = preview_array(np.asarray(rgb, dtype=np.float64), exposure=exposure,
                           tone=tone or "exponential", alpha=alpha, mask=mask,
                           transparency=transparency)
    return write_png(path, pixels)

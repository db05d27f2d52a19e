"""Step 1 of a comparison: read another renderer's EXR sky map into CIE XYZ in our layout.

Public objects
--------------
- :class:`SkyMap`: the map, converted (XYZ and luminance, layout, header, pixel directions
  when it must be rendered at explicit directions).
- :func:`read_sky_map`: read an EXR (lat-long, cube map, fisheye or a direction set) and
  apply the ``rotate_deg``/``flip``/``colourspace`` options (resampling lat-long maps
  column-wise, transforming the pixel directions of the other layouts).

The layouts, the frame and the conventions of the options are described in
:mod:`atmoscatter.compare`.
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass

import numpy as np

from .._validate import as_float_array, check_option

__all__ = ["SkyMap", "read_sky_map"]

LAYOUTS = ("auto", "latlong", "cubemap", "fisheye", "directions")
FLIPS = ("none", "horizontal", "vertical", "both")


# --------------------------------------------------------------------------------------
# colour: pixels to CIE XYZ
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
        from ..render.directions import CubeMapDirections, FisheyeDirections

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

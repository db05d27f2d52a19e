"""Colorimetry glue: spectra → CIE XYZ → linear RGB, through colour-science.

Public objects
--------------
- :func:`spectral_to_XYZ`: integrate spectral radiance with the CIE 1931 2° colour-matching
  functions into photometric XYZ [cd m⁻²] (K_m = 683 lm W⁻¹).
- :func:`cmf_weights`: the quadrature weights behind it (for callers that integrate many
  spectra on one grid).
- :func:`xyY_to_XYZ`, :func:`XYZ_to_xyY`: chromaticity conversions.
- :func:`XYZ_to_linear_rgb`, :func:`linear_rgb_to_XYZ`: linear RGB in any colour-science
  colourspace (default sRGB / Rec. 709 primaries).
- :func:`rgb_into_gamut`, :data:`GAMUT_POLICIES`: what happens to out-of-gamut colours
  (negative RGB channels) in rendered RGB: mapped into the gamut keeping luminance and hue
  (default), clipped, or kept raw.

No colour data is hand-copied: the CMFs and RGB matrices come from colour-science.  The CIE
1931 2° CMFs are read from ``data/cie1931_2deg_cmf.csv`` (written by
``scripts/make_cmf_table.py``, checked against colour-science by the tests).  The RGB
colourspaces (names, aliases, matrices, primaries, whitepoints) are read from
``data/colourspaces.json``, written from ``colour.RGB_COLOURSPACES`` by
``scripts/make_colourspace_table.py`` and checked against colour-science by the tests, so that
validating a colourspace name or converting to RGB does not import colour-science (about a
second, with SciPy and Matplotlib); names the table lacks (a newer colour-science) are looked
up in colour-science itself.
"""

from __future__ import annotations

import json
import os
from functools import lru_cache

import numpy as np

from ._validate import as_float_array, check_option, check_positive

__all__ = [
    "K_M",
    "cmf_weights",
    "spectral_to_XYZ",
    "xyY_to_XYZ",
    "XYZ_to_xyY",
    "XYZ_to_linear_rgb",
    "linear_rgb_to_XYZ",
    "colourspace_names",
    "GAMUT_POLICIES",
    "rgb_into_gamut",
]

#: Maximum luminous efficacy of photopic vision [lm W⁻¹] (CIE; 683.002 rounded as in
#: the SI definition of the candela, 683 lm W⁻¹ at 540 THz).
K_M: float = 683.0

_CMF_NAME = "CIE 1931 2 Degree Standard Observer"


_CMF_TABLE = os.path.join(os.path.dirname(__file__), "data", "cie1931_2deg_cmf.csv")


@lru_cache(maxsize=1)
def _cmfs():
    """(wavelengths [nm], x̄ ȳ z̄ (n, 3)) of the CIE 1931 2° observer, 360–830 nm at 1 nm:
    ``data/cie1931_2deg_cmf.csv``, written from colour-science's ``MSDS_CMFS`` by
    ``scripts/make_cmf_table.py`` (so that colour conversion does not import colour-science)."""
    t = np.loadtxt(_CMF_TABLE, delimiter=",", skiprows=3)
    return np.ascontiguousarray(t[:, 0]), np.ascontiguousarray(t[:, 1:4])


def cmf_weights(wavelengths) -> np.ndarray:
    """Trapezoid-rule weights ``W`` (n, 3) such that ``XYZ = K_m · values @ W``.

    Parameters
    ----------
    wavelengths : array_like
        Strictly increasing sample wavelengths [nm], at least 2.  The CIE 1931 2° CMFs
        (colour-science, 1 nm table 360–830 nm) are interpolated linearly to them; outside
        360–830 nm they are 0.

    Returns
    -------
    ndarray
        Weights [nm], shape (n, 3).  Accuracy is that of the trapezoid rule on the given
        grid: with 5 nm spacing, < 0.1 % for smooth spectra.
    """
    wl = check_positive(as_float_array(wavelengths, "wavelengths"), "wavelengths", unit="nm").ravel()
    if wl.size < 2 or np.any(np.diff(wl) <= 0):
        raise ValueError("wavelengths must be strictly increasing with at least 2 samples")
    cw, cv = _cmfs()
    cm = np.stack([np.interp(wl, cw, cv[:, i], left=0.0, right=0.0) for i in range(3)], axis=-1)
    dw = np.empty_like(wl)
    dw[1:-1] = 0.5 * (wl[2:] - wl[:-2])
    dw[0] = 0.5 * (wl[1] - wl[0])
    dw[-1] = 0.5 * (wl[-1] - wl[-2])
    return cm * dw[:, None]


def spectral_to_XYZ(values, wavelengths):
    """CIE XYZ of spectral radiance (photometric: Y is luminance).

    Parameters
    ----------
    values : array_like
        Spectral radiance [W m⁻² sr⁻¹ nm⁻¹] with wavelengths on the last axis.
    wavelengths : array_like
        Sample wavelengths [nm], strictly increasing, matching the last axis.

    Returns
    -------
    ndarray
        XYZ [cd m⁻²], shape ``values.shape[:-1] + (3,)``.

    Notes
    -----
    ``X = K_m ∫ L(λ) x̄(λ) dλ`` etc. with K_m = 683 lm W⁻¹ and the CIE 1931 2° observer
    (seed 004's D-series/CMF round trip uses the same functions).
    """
    v = as_float_array(values, "values")
    W = cmf_weights(wavelengths)
    if v.shape[-1] != W.shape[0]:
        raise ValueError(
            f"values has {v.shape[-1]} samples on its last axis but wavelengths has {W.shape[0]}"
        )
    return K_M * (v @ W.astype(v.dtype, copy=False))



def _triplets(value, name: str) -> np.ndarray:
    """``value`` as a float array whose last axis has length 3 (one-line error otherwise)."""
    a = as_float_array(value, name)
    if a.ndim < 1 or a.shape[-1] != 3:
        raise ValueError(f"{name} must have shape (..., 3), got shape {a.shape}")
    return a


def xyY_to_XYZ(xyY):
    """CIE xyY → XYZ (last axis).  ``y = 0`` gives XYZ = 0 (black), not NaN.

    Parameters
    ----------
    xyY : array_like, shape (..., 3)
        Chromaticity ``x``, ``y`` [1] and luminance ``Y`` on the last axis (``Y`` in any
        unit, typically cd m⁻²).  float32 stays float32; integers become float64.

    Returns
    -------
    ndarray, shape (..., 3)
        ``X = x Y / y``, ``Y``, ``Z = (1 − x − y) Y / y`` in the unit of ``Y``; 0 where
        ``y = 0``.

    Raises
    ------
    TypeError
        If ``xyY`` is not numeric.
    ValueError
        If the last axis does not have length 3.
    """
    a = _triplets(xyY, "xyY")
    x, y, Y = a[..., 0], a[..., 1], a[..., 2]
    with np.errstate(divide="ignore", invalid="ignore"):
        s = np.where(y != 0, Y / np.where(y != 0, y, 1.0), 0.0)
    return np.stack([x * s, Y, (1.0 - x - y) * s], axis=-1)


def XYZ_to_xyY(XYZ, *, black_xy=(0.3127, 0.3290)):
    """CIE XYZ → xyY (last axis).  Black (X+Y+Z = 0) gets chromaticity ``black_xy`` (D65).

    Parameters
    ----------
    XYZ : array_like, shape (..., 3)
        CIE XYZ on the last axis, in any unit (typically cd m⁻²).  float32 stays float32;
        integers become float64.
    black_xy : tuple of float, optional
        Chromaticity ``(x, y)`` [1] given to black pixels (``X + Y + Z = 0``); default
        ``(0.3127, 0.3290)``, CIE D65.

    Returns
    -------
    ndarray, shape (..., 3)
        ``x = X / (X + Y + Z)``, ``y = Y / (X + Y + Z)`` [1] and ``Y`` in the unit of the
        input.

    Raises
    ------
    TypeError
        If ``XYZ`` is not numeric.
    ValueError
        If the last axis does not have length 3.
    """
    a = _triplets(XYZ, "XYZ")
    s = a[..., 0] + a[..., 1] + a[..., 2]
    ok = s != 0
    with np.errstate(divide="ignore", invalid="ignore"):
        inv = np.where(ok, 1.0 / np.where(ok, s, 1.0), 0.0)
    x = np.where(ok, a[..., 0] * inv, black_xy[0])
    y = np.where(ok, a[..., 1] * inv, black_xy[1])
    return np.stack([x, y, a[..., 1]], axis=-1)


_COLOURSPACE_TABLE = os.path.join(os.path.dirname(__file__), "data", "colourspaces.json")


@lru_cache(maxsize=1)
def _colourspace_table() -> dict:
    """``data/colourspaces.json`` (see ``scripts/make_colourspace_table.py``)."""
    with open(_COLOURSPACE_TABLE, encoding="utf-8") as f:
        return json.load(f)


def _resolve_colourspace(name) -> str | None:
    """colour-science's key of the RGB colourspace ``name``, or None if it is unknown.

    Accepts what ``name in colour.RGB_COLOURSPACES`` accepts, in the same order: the exact key,
    its lower-case, slugified or canonical variant (e.g. ``"srgb"``, ``"iturbt2020"``).
    Names missing from the shipped table are looked up in colour-science (imported only then)
    when the installed colour-science is not the version the table was written from.
    """
    if not isinstance(name, str):
        return None
    t = _colourspace_table()
    if name in t["colourspaces"]:
        return name
    for variant, key in (("lower", name.lower()), ("slugified", name), ("canonical", name)):
        hit = t[variant].get(key)
        if hit is not None:
            return hit
    if _installed_colour_science_version() in (None, t["colour_science_version"]):
        return None  # the table is colour-science's own list: ``name`` is not a colourspace
    return name if _colour_science_colourspace(name) is not None else None


@lru_cache(maxsize=1)
def _installed_colour_science_version() -> str | None:
    """Version of the installed colour-science (from its metadata: nothing is imported)."""
    from importlib import metadata  # noqa: PLC0415

    try:
        return metadata.version("colour-science")
    except metadata.PackageNotFoundError:  # pragma: no cover - a declared dependency
        return None


def _colour_science_colourspace(name):
    """colour-science's colourspace object for ``name`` (None if unknown or not installed)."""
    try:
        import colour  # noqa: PLC0415
    except ImportError:  # pragma: no cover - colour-science is a declared dependency
        return None
    return colour.RGB_COLOURSPACES[name] if name in colour.RGB_COLOURSPACES else None


def _colourspace_data(name) -> dict | None:
    """``matrix_XYZ_to_RGB`` (3, 3), ``primaries`` (3, 2) and ``whitepoint`` (2,) of ``name``
    as float arrays (from the shipped table; colour-science for names it lacks), or None."""
    key = _resolve_colourspace(name)
    if key is None:
        return None
    entry = _colourspace_table()["colourspaces"].get(key)
    if entry is None:
        cs = _colour_science_colourspace(key)
        entry = {"matrix_XYZ_to_RGB": cs.matrix_XYZ_to_RGB, "primaries": cs.primaries,
                 "whitepoint": cs.whitepoint}
    return {k: np.asarray(v, dtype=float) for k, v in entry.items()}


def colourspace_names() -> list[str]:
    """Names of the RGB colourspaces colour-science provides (valid ``colourspace`` values).

    Read from the shipped table ``data/colourspaces.json`` (colour-science is not imported).
    The ``colourspace`` arguments also accept the lower-case, slugified and canonical
    variants colour-science accepts (e.g. ``"srgb"``, ``"iturbt2020"``), which are not listed.

    Returns
    -------
    list of str
        The colourspace keys of ``colour.RGB_COLOURSPACES``, sorted.
    """
    return sorted(_colourspace_table()["colourspaces"])


@lru_cache(maxsize=32)
def _matrices(colourspace: str):
    data = _colourspace_data(colourspace)
    if data is None:
        check_option(colourspace, "colourspace", colourspace_names())
    # XYZ → RGB is colour-science's matrix for the colourspace (for sRGB the IEC 61966-2-1
    # published matrix), so results equal ``colour.XYZ_to_RGB`` without adaptation to
    # rounding; RGB → XYZ is its exact inverse so the two round-trip to rounding error.
    # (colour-science's two sRGB matrices are each rounded to 4 decimals and are inverses of
    # each other only to 4e-5.)
    # Returned transposed and contiguous: callers compute ``a @ M.T`` on (..., 3) rows, and
    # a non-contiguous ``M.T`` makes that matmul ~6x slower.
    xyz_to_rgb = data["matrix_XYZ_to_RGB"]
    return np.ascontiguousarray(xyz_to_rgb.T), np.ascontiguousarray(np.linalg.inv(xyz_to_rgb).T)


def XYZ_to_linear_rgb(XYZ, colourspace: str = "sRGB"):
    """CIE XYZ → linear RGB (no transfer function) in ``colourspace``.

    Uses the colourspace's XYZ → RGB matrix from colour-science (identical to
    ``colour.XYZ_to_RGB(..., illuminant=None)``), without chromatic adaptation: XYZ is
    taken as absolute (an equal-RGB pixel has the colourspace white's
    chromaticity, D65 for sRGB).  Units follow the input (cd m⁻² in, cd m⁻² out, with
    ``Y = 0.2126 R + 0.7152 G + 0.0722 B`` for sRGB).  float32 in → float32 out.

    Parameters
    ----------
    XYZ : array_like, shape (..., 3)
        CIE XYZ on the last axis, in any unit (typically cd m⁻²).
    colourspace : str, optional
        RGB colourspace, one of :func:`colourspace_names` or a variant colour-science
        accepts (e.g. ``"srgb"``); default ``"sRGB"``.

    Returns
    -------
    ndarray, shape (..., 3)
        Linear R, G, B in the unit of ``XYZ``.  Out-of-gamut colours have negative
        channels (see :func:`rgb_into_gamut`); nothing is clipped.

    Raises
    ------
    ValueError
        If ``colourspace`` is unknown (the message lists the valid names), or if the last
        axis of ``XYZ`` is not of length 3.
    TypeError
        If ``XYZ`` is not numeric.
    """
    a = _triplets(XYZ, "XYZ")
    MT, _ = _matrices(colourspace)
    return a @ MT.astype(a.dtype, copy=False)


def linear_rgb_to_XYZ(rgb, colourspace: str = "sRGB"):
    """Linear RGB in ``colourspace`` → CIE XYZ, the exact inverse of :func:`XYZ_to_linear_rgb`.

    Differs from colour-science's own RGB → XYZ matrix by < 1e-4 for sRGB (whose published
    matrices are rounded to 4 decimals).

    Parameters
    ----------
    rgb : array_like, shape (..., 3)
        Linear R, G, B on the last axis (no transfer function), in any unit (typically
        cd m⁻²).  float32 stays float32.
    colourspace : str, optional
        RGB colourspace, one of :func:`colourspace_names` or a variant colour-science
        accepts (e.g. ``"srgb"``); default ``"sRGB"``.

    Returns
    -------
    ndarray, shape (..., 3)
        CIE XYZ in the unit of ``rgb``.

    Raises
    ------
    ValueError
        If ``colourspace`` is unknown (the message lists the valid names), or if the last
        axis of ``rgb`` is not of length 3.
    TypeError
        If ``rgb`` is not numeric.
    """
    a = _triplets(rgb, "rgb")
    _, MT = _matrices(colourspace)
    return a @ MT.astype(a.dtype, copy=False)


#: Out-of-gamut policies of rendered RGB (the scene field ``gamut``; see
#: :func:`rgb_into_gamut`): ``map`` (default) desaturates toward the achromatic colour of the
#: same luminance, ``clip`` sets negative channels to 0, ``none`` keeps the raw values.
GAMUT_POLICIES = ("map", "clip", "none")


def _luminance_coefficients(colourspace: str) -> np.ndarray:
    """Luminance of unit R, G and B in ``colourspace`` (Y row of its RGB → XYZ matrix) [1]."""
    _, rgb_to_xyz_T = _matrices(colourspace)
    return np.ascontiguousarray(rgb_to_xyz_T[:, 1])


def _gamut_map_inplace(rgb: np.ndarray, policy: str, lum: np.ndarray) -> tuple:
    """Apply ``policy`` to the rows of ``rgb`` (k, 3) in place.

    Returns ``(out_of_gamut, changed, max_desaturation, min_value)``: pixels with a channel
    < 0, pixels the policy changed, the largest ``1 − s`` of ``map`` (0 otherwise) and the most
    negative raw channel (0 when none is negative).  Only the out-of-gamut rows are touched
    (NaN rows never are), so the in-gamut ones keep their exact values.
    """
    # (min over the short last axis with ``min(axis=-1)`` is ~40x slower than this)
    low = np.minimum(np.minimum(rgb[:, 0], rgb[:, 1]), rgb[:, 2])
    neg = low < 0.0
    k = int(np.count_nonzero(neg))
    if k == 0:
        return 0, 0, 0.0, 0.0
    whole = k == len(rgb)  # e.g. a low Hoffman–Preetham sun: no gather/scatter copies
    m = (low if whole else low[neg]).astype(np.float64)
    min_value = float(m.min())
    if policy == "none":
        return k, 0, 0.0, min_value
    if policy == "clip":
        if whole:
            np.maximum(rgb, 0.0, out=rgb)
        else:
            rgb[neg] = np.maximum(rgb[neg], 0.0)
        return k, k, 0.0, min_value
    c = (rgb if whole else rgb[neg]).astype(np.float64)
    # a: the achromatic colour (a, a, a) of the pixel's luminance Y = c·lum.  Points
    # a + s (c − a) keep Y for every s (Y is linear in RGB); the largest s ≤ 1 with all
    # channels ≥ 0 puts the lowest channel m on 0: s = a / (a − m), in (0, 1) for a > 0 > m.
    # In XYZ the result is a positive mix of the colourspace white and the raw colour, so its
    # chromaticity stays on the line from the white point through the raw one (same hue,
    # lower purity).  Y ≤ 0 has no non-negative colour of that luminance: black (s = 0).
    a = c @ (lum / float(lum.sum()))
    s = np.divide(a, a - m, out=np.zeros_like(a), where=a > 0.0)
    c -= a[:, None]
    c *= s[:, None]
    c += a[:, None]
    np.maximum(c, 0.0, out=c)  # the lowest channel is 0 up to rounding (~1e-16 a)
    if whole:
        rgb[...] = c
    else:
        rgb[neg] = c
    return k, k, float(1.0 - s.min()), min_value


def rgb_into_gamut(rgb, colourspace: str = "sRGB", *, policy: str = "map"):
    """Linear RGB with out-of-gamut colours (a channel < 0) treated by ``policy``.

    Parameters
    ----------
    rgb : array_like (..., 3)
        Linear RGB in ``colourspace`` [any unit, e.g. cd m⁻²], channels on the last axis.
    colourspace : str
        RGB colourspace of ``rgb`` (for its luminance coefficients and white).
    policy : {"map", "clip", "none"}
        ``map``: move each out-of-gamut colour ``c`` along the straight line toward the
        achromatic colour ``(a, a, a)`` of the same luminance Y, to ``a + s (c − a)`` with the
        largest ``s`` that makes every channel ≥ 0 (the lowest becomes 0).  Y is kept exactly
        (to rounding) and the chromaticity stays on the line from the colourspace's white
        point through the original one (hue kept, purity lowered by the factor ``s``); a colour
        with Y ≤ 0 becomes black.  ``clip``: negative channels set to 0 (Y and hue change).
        ``none``: unchanged.  In-gamut colours and NaN are never changed.

    Returns
    -------
    ndarray
        Same shape and float dtype as ``rgb`` (a new array).

    Examples
    --------
    >>> import numpy as np
    >>> raw = np.array([1.0, 0.5, -0.1])   # outside sRGB: negative blue
    >>> out = rgb_into_gamut(raw)
    >>> print([round(float(v), 4) for v in out])
    [0.9341, 0.5095, 0.0]
    >>> print(round(float(linear_rgb_to_XYZ(out)[1]), 6), round(float(linear_rgb_to_XYZ(raw)[1]), 6))
    0.562951 0.562951
    """
    check_option(policy, "policy", GAMUT_POLICIES)
    a = _triplets(rgb, "rgb")
    out = np.array(a, copy=True)
    _gamut_map_inplace(out.reshape(-1, 3), policy, _luminance_coefficients(colourspace))
    return out

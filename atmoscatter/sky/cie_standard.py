r"""The 15 CIE standard general skies (ISO 15469:2004 / CIE S 011/E:2003).

Public objects
--------------
CIE_STANDARD_SKY_TYPES
    Lazily loaded table (``atmoscatter/data/cie_standard_skies.csv``): type → gradation
    group, indicatrix group, ``a, b, c, d, e`` and the standard's description.
cie_standard_sky_parameters
    ``(a, b, c, d, e)`` of one or many sky types (array in, arrays out).
cie_gradation, cie_indicatrix
    The gradation function φ(Z) and the scattering indicatrix f(χ) of the standard.
cie_standard_relative_luminance
    ``L(Z, γ)/L_z = f(γ) φ(Z) / (f(Z_s) φ(0))``, exact to the standard's formulas.
cie_standard_diffuse_ratio
    ``D_v/L_z = ∫ (L/L_z) cos Z dΩ`` [sr]: diffuse horizontal illuminance per unit zenith
    luminance (numerical, relative error < 1e-8).
cie_standard_luminance, cie_standard_sky
    Absolute luminance [cd m⁻²], scaled by a zenith luminance [cd m⁻²] or by a diffuse
    horizontal illuminance [lx]; for (Z, γ) arrays or for view directions.

The model
---------
CIE S 011 defines the luminance of a sky element at zenith angle Z and angular distance χ from
the sun (the sun at zenith angle Z_s) relative to the zenith luminance L_z:

.. math::

    \frac{L(Z, \chi)}{L_z} = \frac{f(\chi)\,\varphi(Z)}{f(Z_s)\,\varphi(0)}, \qquad
    \varphi(Z) = 1 + a\,e^{b/\cos Z}, \qquad
    f(\chi) = 1 + c\left[e^{d\chi} - e^{d\pi/2}\right] + e\cos^2\chi ,

with φ(π/2) = 1 (the horizon limit) and φ(0) = 1 + a e^{b}. The six gradation groups (a, b)
and six indicatrix groups (c, d, e) combine into 15 types, from type 1 (the standard's
overcast sky) through type 5 (uniform luminance) to type 12 (the CIE standard clear sky,
identical to :func:`atmoscatter.cie_clear_sky_luminance` up to the rounding of its constant
0.91 = 1 − 10 e^{−3π/2} to two digits, < 5e-4 relative) and type 15.

The traditional Moon & Spencer (1942) overcast sky ``(1 + 2 cos Z)/3`` is **not** type 1; it
stays available as :func:`atmoscatter.cie_overcast_luminance` (model ``cie_overcast``). Type 1
gives a horizon/zenith ratio of 1/(1 + 4 e^{−0.7}) = 0.335 against 1/3, but a different shape
in between.

Edges and validity
------------------
* The standard defines the sky for a sun on or above the horizon (Z_s ∈ [0, π/2]); for a sun
  below it every function here returns 0 luminance (the convention of
  :func:`atmoscatter.cie_clear_sky_luminance`); ``D_v/L_z`` is then undefined and raises.
* View directions at or below the horizon get the horizon value (cos Z clamped to 0, where
  ``e^{b/cos Z} → 0`` for the standard's b < 0, without division warnings).
* Scaling by diffuse horizontal illuminance uses :func:`cie_standard_diffuse_ratio`, a
  Gauss–Legendre product rule split at the sun (relative error < 1e-8, checked against a
  rule four times finer in each direction).

References
----------
ISO 15469:2004(E) / CIE S 011/E:2003, *Spatial distribution of daylight — CIE standard general
sky*, CIE, Vienna. S. Darula & R. Kittler (2002), "CIE general sky standard defining luminance
distributions", *Proc. eSim 2002*, Montréal. R. Kittler, S. Darula & R. Perez (1998), "A set of
standard skies characterizing daylight conditions for computer and energy conscious design",
US–SK grant 92 052 final report.
"""

from __future__ import annotations

import csv
import math
from collections.abc import Mapping
from functools import lru_cache
from importlib import resources

import numpy as np

from .._validate import as_float_array, check_positive
from . import _hemisphere
from ._preetham_eval import _sun, _views
from .perez import _horizon_term

__all__ = [
    "CIE_STANDARD_SKY_TYPES",
    "cie_standard_sky_parameters",
    "cie_gradation",
    "cie_indicatrix",
    "cie_standard_relative_luminance",
    "cie_standard_diffuse_ratio",
    "cie_standard_luminance",
    "cie_standard_sky",
]


@lru_cache(maxsize=1)
def _table() -> dict[int, dict]:
    path = resources.files("atmoscatter") / "data" / "cie_standard_skies.csv"
    rows = {}
    with path.open("r", encoding="utf-8") as fh:
        for rec in csv.reader(line for line in fh if not line.startswith("#")):
            t = int(rec[0])
            rows[t] = {
                "gradation_group": rec[1],
                "indicatrix_group": int(rec[2]),
                **{k: float(v) for k, v in zip("abcde", rec[3:8], strict=True)},
                "description": rec[8],
            }
    return rows


class _LazyTable(Mapping):
    """Read-only mapping filled from the package data on first use."""

    def __init__(self, loader):
        self._loader = loader

    def __getitem__(self, key):
        return self._loader()[key]

    def __iter__(self):
        return iter(self._loader())

    def __len__(self):
        return len(self._loader())

    def __repr__(self):
        return repr(self._loader())


#: The 15 CIE standard general skies, type (1–15) → ``{"gradation_group", "indicatrix_group",
#: "a", "b", "c", "d", "e", "description"}`` (ISO 15469:2004 / CIE S 011/E:2003, Table 1).
CIE_STANDARD_SKY_TYPES: Mapping[int, dict] = _LazyTable(_table)


def _check_type(cie_type) -> np.ndarray:
    arr = np.asarray(cie_type)
    if arr.dtype.kind not in "iuf" or arr.dtype == bool:
        raise TypeError(f"cie_type must be an integer 1..15, got {cie_type!r}")
    with np.errstate(invalid="ignore"):
        bad = ~np.isfinite(arr) | (arr != np.round(arr)) | (arr < 1) | (arr > 15)
    if np.any(bad):
        v = arr[bad].ravel()[0] if arr.ndim else arr.item()
        raise ValueError(f"cie_type must be an integer in [1, 15], got {v!r}")
    return arr.astype(int)


def cie_standard_sky_parameters(cie_type):
    """Gradation and indicatrix parameters ``(a, b, c, d, e)`` of CIE standard sky types.

    Parameters
    ----------
    cie_type : int or array_like of int
        Sky type(s), 1–15 (ISO 15469:2004 / CIE S 011/E:2003, Table 1).

    Returns
    -------
    tuple of 5 numpy.ndarray or float
        ``a, b`` (gradation, [1]) and ``c, d, e`` (indicatrix, [1]; ``d`` per radian), each of
        the shape of ``cie_type``.

    Raises
    ------
    ValueError
        If a type is not an integer in [1, 15].

    Examples
    --------
    >>> cie_standard_sky_parameters(12)
    (-1.0, -0.32, 10.0, -3.0, 0.45)
    """
    t = _check_type(cie_type)
    table = _table()
    cols = np.array([[table[k][p] for p in "abcde"] for k in range(1, 16)])
    vals = cols[t - 1]
    if t.ndim == 0:
        return tuple(float(v) for v in vals)
    return tuple(vals[..., i] for i in range(5))


def cie_gradation(view_zenith, a, b):
    r"""Gradation function ``φ(Z) = 1 + a e^{b/cos Z}`` of CIE S 011.

    Parameters
    ----------
    view_zenith : array_like
        Zenith angle Z of the sky element; Z ≥ π/2 gives the horizon value φ = 1. [rad]
    a, b : array_like
        Gradation parameters (:func:`cie_standard_sky_parameters`), b ≤ 0. [1]

    Returns
    -------
    numpy.ndarray or float
        φ(Z) [1], the broadcast shape of the inputs. Exact to the formula; ``e^{b/cos Z}`` is
        evaluated without division or underflow warnings at the horizon.
    """
    z = as_float_array(view_zenith, "view_zenith")
    a = as_float_array(a, "a")
    b = as_float_array(b, "b")
    if np.any(b > 0):
        raise ValueError(f"b must be in (-inf, 0] (the standard's gradation), got {np.max(b)!r}")
    out = 1.0 + a * _horizon_term(np.cos(z), b)
    return out[()] if out.ndim == 0 else out


def cie_indicatrix(chi, c, d, e):
    r"""Scattering indicatrix ``f(χ) = 1 + c [e^{dχ} − e^{dπ/2}] + e cos²χ`` of CIE S 011.

    Parameters
    ----------
    chi : array_like
        Angular distance χ from the sun, in [0, π]. [rad]
    c, d, e : array_like
        Indicatrix parameters (:func:`cie_standard_sky_parameters`). [1]

    Returns
    -------
    numpy.ndarray or float
        f(χ) [1], the broadcast shape of the inputs.
    """
    chi = as_float_array(chi, "chi")
    c, d, e = (as_float_array(v, n) for v, n in ((c, "c"), (d, "d"), (e, "e")))
    cc = np.cos(chi)
    out = 1.0 + c * (np.exp(d * chi) - np.exp(d * (np.pi / 2))) + e * cc * cc
    return out[()] if out.ndim == 0 else out


def _relative(cos_z, cos_g, gamma, sun_zenith, a, b, c, d, e):
    """``L/L_z`` from cosines (no checks; the sun above the horizon)."""
    grad = 1.0 + a * _horizon_term(cos_z, b)
    grad0 = 1.0 + a * np.exp(b)
    ind = 1.0 + c * (np.exp(d * gamma) - np.exp(d * (np.pi / 2))) + e * cos_g * cos_g
    cs = np.cos(sun_zenith)
    ind_s = 1.0 + c * (np.exp(d * sun_zenith) - np.exp(d * (np.pi / 2))) + e * cs * cs
    return (ind * grad) / (ind_s * grad0)


def _sun_zenith(sun_zenith):
    ts = as_float_array(sun_zenith, "sun_zenith")
    with np.errstate(invalid="ignore"):
        bad = ~np.isfinite(ts) | (ts < 0) | (ts > np.pi)
    if np.any(bad):
        raise ValueError(f"sun_zenith must be in [0, pi] rad, got {ts[bad].ravel()[0]!r}"
                         if ts.ndim else f"sun_zenith must be in [0, pi] rad, got {ts.item()!r}")
    return ts


def cie_standard_relative_luminance(view_zenith, gamma, sun_zenith, cie_type):
    r"""Relative luminance ``L(Z, γ)/L_z`` of a CIE standard general sky (CIE S 011).

    .. math::

        \frac{L}{L_z} = \frac{\left(1 + c\,[e^{d\gamma} - e^{d\pi/2}] + e\cos^2\gamma\right)
                              \left(1 + a\,e^{b/\cos Z}\right)}
                             {\left(1 + c\,[e^{dZ_s} - e^{d\pi/2}] + e\cos^2 Z_s\right)
                              \left(1 + a\,e^{b}\right)}

    Parameters
    ----------
    view_zenith : array_like
        Zenith angle Z of the view direction; Z ≥ π/2 gives the horizon value. [rad]
    gamma : array_like
        Angle γ (the standard's χ) between the view direction and the sun, in [0, π]. [rad]
    sun_zenith : array_like
        Solar zenith angle Z_s in [0, π]; above π/2 (sun below the horizon) the result is 0.
        [rad]
    cie_type : int or array_like of int
        Sky type 1–15. All inputs broadcast.

    Returns
    -------
    numpy.ndarray or float
        ``L/L_z`` [1]; exactly 1 at the zenith (Z = 0, γ = Z_s). Exact to the standard's
        formulas (float64 rounding only).

    Examples
    --------
    >>> round(float(cie_standard_relative_luminance(np.pi / 2, 1.0, 0.5, 1)), 4)  # horizon
    0.3349
    """
    z = as_float_array(view_zenith, "view_zenith")
    g = as_float_array(gamma, "gamma")
    ts = _sun_zenith(sun_zenith)
    a, b, c, d, e = cie_standard_sky_parameters(cie_type)
    tsc = np.minimum(ts, np.pi / 2)
    with np.errstate(invalid="ignore"):
        out = _relative(np.cos(z), np.cos(g), g, tsc, a, b, c, d, e)
        out = np.where(ts > np.pi / 2, 0.0, out)
    return out[()] if out.ndim == 0 else out


def cie_standard_diffuse_ratio(sun_zenith, cie_type):
    r"""Diffuse horizontal illuminance per unit zenith luminance, ``D_v/L_z`` [sr].

    .. math:: \frac{D_v}{L_z} = \int_{2\pi} \frac{L(Z, \gamma)}{L_z}\,\cos Z\,d\Omega

    Parameters
    ----------
    sun_zenith : array_like
        Solar zenith angle in [0, π/2]. [rad]
    cie_type : int or array_like of int
        Sky type 1–15; broadcast against ``sun_zenith``.

    Returns
    -------
    numpy.ndarray or float
        ``D_v/L_z`` [sr] (lx per cd m⁻²). Type 5 (uniform sky) gives π exactly.

    Notes
    -----
    Accuracy: relative error < 1e-8 (Gauss–Legendre in the zenith angle split at the sun ×
    Gauss–Legendre in azimuth, 96 × 120 nodes per sky; see
    :mod:`atmoscatter.sky._hemisphere`). Vectorised: about 0.7 ms CPU per sky.

    Raises
    ------
    ValueError
        If a solar zenith is outside [0, π/2] (no daylight sky is defined for a sun below the
        horizon) or a type outside 1–15.
    """
    ts = as_float_array(sun_zenith, "sun_zenith")
    with np.errstate(invalid="ignore"):
        bad = ~np.isfinite(ts) | (ts < 0) | (ts > np.pi / 2)
    if np.any(bad):
        v = ts[bad].ravel()[0] if ts.ndim else ts.item()
        raise ValueError(f"sun_zenith must be in [0, pi/2] rad (sun above the horizon), got {v!r}")
    t = _check_type(cie_type)
    ts, t = np.broadcast_arrays(ts, t)
    params = cie_standard_sky_parameters(t.ravel())
    out = _hemisphere.horizontal_integral(_relative, ts.ravel(), params).reshape(ts.shape)
    return out[()] if out.ndim == 0 else out


def _zenith_scale(sun_zenith, cie_type, zenith_luminance, diffuse_horizontal_illuminance):
    """Zenith luminance [cd m⁻²] from exactly one of the two scalings."""
    if (zenith_luminance is None) == (diffuse_horizontal_illuminance is None):
        raise ValueError("give exactly one of zenith_luminance [cd m^-2] and "
                         "diffuse_horizontal_illuminance [lx]")
    if zenith_luminance is not None:
        return check_positive(zenith_luminance, "zenith_luminance", allow_zero=True, unit="cd m^-2")
    dv = check_positive(diffuse_horizontal_illuminance, "diffuse_horizontal_illuminance",
                        allow_zero=True, unit="lx")
    ts = np.asarray(sun_zenith, dtype=float)
    day = ts <= np.pi / 2
    ratio = cie_standard_diffuse_ratio(np.where(day, ts, 0.0), cie_type)
    return np.where(day, dv / ratio, 0.0)


def cie_standard_luminance(view_zenith, gamma, sun_zenith, cie_type, *, zenith_luminance=None,
                           diffuse_horizontal_illuminance=None):
    """Absolute luminance of a CIE standard general sky [cd m⁻²].

    ``L = L_z · (L/L_z)`` (:func:`cie_standard_relative_luminance`), with the zenith
    luminance given, or ``L_z = D_v / (D_v/L_z)`` (:func:`cie_standard_diffuse_ratio`) for a
    given diffuse horizontal illuminance D_v.

    Parameters
    ----------
    view_zenith, gamma, sun_zenith : array_like
        As in :func:`cie_standard_relative_luminance`. [rad]
    cie_type : int or array_like of int
        Sky type 1–15.
    zenith_luminance : array_like, optional
        Zenith luminance L_z ≥ 0. [cd m⁻²]
    diffuse_horizontal_illuminance : array_like, optional
        Diffuse horizontal illuminance D_v ≥ 0 from the sky (sun excluded). [lx]
        Exactly one of the two must be given; all inputs broadcast.

    Returns
    -------
    numpy.ndarray or float
        Luminance [cd m⁻²]; 0 for a sun below the horizon.
    """
    rel = cie_standard_relative_luminance(view_zenith, gamma, sun_zenith, cie_type)
    lz = _zenith_scale(_sun_zenith(sun_zenith), cie_type, zenith_luminance,
                       diffuse_horizontal_illuminance)
    out = np.asarray(rel * lz)
    return out[()] if out.ndim == 0 else out


def cie_standard_sky(view_directions, sun_direction, cie_type, *, zenith_luminance=None,
                     diffuse_horizontal_illuminance=None):
    """CIE standard general sky luminance for view directions (..., 3) [cd m⁻²].

    Same model as :func:`cie_standard_luminance`; frame x = east, y = north, z = up; γ is
    computed as ``2 atan2(|v̂ − ŝ|, |v̂ + ŝ|)`` (accurate at the sun and the anti-solar point).

    Parameters
    ----------
    view_directions : array_like
        View directions, shape (..., 3); normalised internally; NaN gives NaN.
    sun_direction : array_like
        Direction toward the sun, shape (3,); below the horizon the sky is dark (0).
    cie_type : int
        Sky type 1–15.
    zenith_luminance : float, optional
        Zenith luminance ≥ 0. [cd m⁻²]
    diffuse_horizontal_illuminance : float, optional
        Diffuse horizontal illuminance ≥ 0. [lx] (exactly one of the two.)

    Returns
    -------
    numpy.ndarray
        Luminance [cd m⁻²], shape ``view_directions.shape[:-1]``; float32 in → float32 out.
    """
    v = _views(view_directions)
    sun = _sun(sun_direction)
    t = int(_check_type(cie_type))
    ts = math.acos(max(-1.0, min(1.0, float(sun[2]))))
    lz = float(_zenith_scale(ts, t, zenith_luminance, diffuse_horizontal_illuminance))
    if sun[2] < 0.0:
        return _hemisphere.dark_sky(v)
    vh, gamma = _hemisphere.unit_views_and_sun_angle(v, sun)
    a, b, c, d, e = cie_standard_sky_parameters(t)
    with np.errstate(invalid="ignore"):
        rel = _relative(vh[..., 2], np.cos(gamma), gamma, ts, a, b, c, d, e)
    return np.asarray(lz * rel, dtype=v.dtype)

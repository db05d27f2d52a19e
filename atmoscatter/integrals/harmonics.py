r"""Sky integrals for lighting and daylighting: irradiance/illuminance and spherical harmonics.

Every function here accepts a sky in one of two forms:

- a **callable** ``sky(directions) -> values`` taking unit directions of shape (N, 3) in the
  local frame (x = east, y = north, z = up) and returning (N,) or (N, C) values (radiance
  [W m⁻² sr⁻¹] or [W m⁻² sr⁻¹ nm⁻¹], luminance [cd m⁻²], XYZ, RGB …; channels on the last
  axis).  The integral is then computed with :func:`sphere_quadrature`;
- **values on a direction set**: ``sky`` is an array, and ``directions`` (…, 3) and
  ``weights`` (…) — the solid angle [sr] each sample stands for — are passed too.
  :func:`latlong_quadrature` gives them for an equirectangular map.

Public objects
--------------
- :func:`sphere_quadrature`: Gauss–Legendre in cos θ × uniform (trapezoid) in φ, split at
  the horizon, with weights [sr].
- :func:`latlong_quadrature`: directions and exact pixel solid angles of a lat-long map.
- :func:`diffuse_irradiance`: ``E = ∫ L(ω) max(n·ω, 0) dΩ`` over the sky dome (horizontal by
  default).  With luminance in cd m⁻² the result is illuminance [lx]; with radiance
  [W m⁻² sr⁻¹] it is irradiance [W m⁻²].
- :func:`direct_irradiance`: the sun's direct contribution ``E_n max(n·s, 0)`` on a plane.
- :func:`direct_normal_irradiance`: extraterrestrial solar spectrum × transmittance along the
  sun's path through an :class:`~atmoscatter.Atmosphere` [W m⁻² nm⁻¹].
- :func:`sh_count`, :func:`sh_index`, :func:`real_sph_harm`: the real spherical-harmonic basis.
- :func:`sh_project`, :func:`sh_evaluate`: projection of a sky onto real SH up to a given
  order and reconstruction from the coefficients.
- :func:`sh_irradiance`: irradiance from SH coefficients (convolution with the clamped
  cosine, Ramamoorthi & Hanrahan 2001) — the ambient term a renderer needs.

Spherical-harmonic convention
-----------------------------
Orthonormal real spherical harmonics, ``∫_{S²} Y_lm Y_l'm' dΩ = δ_ll' δ_mm'``:

.. math::

    Y_{l0} = N_{l0} P_l(\cos\theta), \quad
    Y_{lm} = \sqrt2 N_{lm} P_l^m(\cos\theta)\cos m\varphi, \quad
    Y_{l,-m} = \sqrt2 N_{lm} P_l^m(\cos\theta)\sin m\varphi \quad (m > 0),

with :math:`N_{lm} = \sqrt{(2l+1)/(4\pi)\,(l-m)!/(l+m)!}`, θ the zenith angle (from +z, up)
and φ = atan2(y, x) the **mathematical** azimuth, from east (+x) toward north (+y) —
not the geographic azimuth (from north toward east) used elsewhere in the package; this keeps
the usual Cartesian forms.  By default the associated Legendre functions :math:`P_l^m` carry
**no Condon–Shortley phase** (``(−1)^m``), so that

``Y_00 = 1/(2√π)``, ``Y_1,−1 = √(3/4π)·y``, ``Y_10 = √(3/4π)·z``, ``Y_11 = √(3/4π)·x``

as in Ramamoorthi & Hanrahan (2001) and most real-time graphics code.  Pass
``condon_shortley=True`` to include the phase (then ``Y_11 = −√(3/4π)·x``).  In terms of
the complex harmonics of ``scipy.special.sph_harm_y`` (which include the phase), the default
basis is ``Y_lm = √2 (−1)^m Re Y_l^m`` for m > 0 and ``√2 (−1)^m Im Y_l^|m|`` for m < 0.  Coefficients are stored flat with index
``i = l(l + 1) + m`` (``l = 0…order``, ``m = −l…l``), ``(order + 1)²`` in all, channels on
the last axis.

References
----------
- R. Ramamoorthi, P. Hanrahan, "An efficient representation for irradiance environment
  maps", SIGGRAPH 2001 (clamped-cosine coefficients Â_l).
- CIE S 011/E:2003, "Spatial distribution of daylight — CIE standard general sky" (the
  overcast sky L(θ)/L_z = (1 + 2 cos θ)/3 used in the tests).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from functools import lru_cache
from math import factorial, lgamma

import numpy as np

from .._validate import as_float_array, check_option, check_positive, clamp_cosine

__all__ = [
    "sphere_quadrature",
    "latlong_quadrature",
    "diffuse_irradiance",
    "direct_irradiance",
    "direct_normal_irradiance",
    "sh_count",
    "sh_index",
    "real_sph_harm",
    "sh_project",
    "sh_evaluate",
    "sh_irradiance",
    "clamped_cosine_sh_coefficients",
]

QUADRATURE_DOMAINS = ("sphere", "upper", "lower")
"""Valid ``domain`` values: the whole sphere, the sky dome (z > 0) or the ground half."""

#: Default Gauss–Legendre nodes in cos θ per hemisphere.
DEFAULT_N_THETA: int = 48


# --------------------------------------------------------------------------------------
# quadrature
# --------------------------------------------------------------------------------------
@lru_cache(maxsize=32)
def _gauss_legendre_01(n: int) -> tuple[np.ndarray, np.ndarray]:
    x, w = np.polynomial.legendre.leggauss(n)
    return 0.5 * (x + 1.0), 0.5 * w


def _check_count(value, name: str, minimum: int) -> int:
    if isinstance(value, bool) or not isinstance(value, int | np.integer):
        raise TypeError(f"{name} must be an integer, got {value!r}")
    if value < minimum:
        raise ValueError(f"{name} must be an integer >= {minimum}, got {value}")
    return int(value)


def sphere_quadrature(n_theta: int = DEFAULT_N_THETA, n_phi: int | None = None, *,
                      domain: str = "sphere"):
    r"""Product quadrature on the unit sphere: Gauss–Legendre in cos θ × uniform in φ.

    Parameters
    ----------
    n_theta : int
        Gauss–Legendre nodes in μ = cos θ **per hemisphere** (≥ 1).  The two hemispheres are
        integrated separately, so a discontinuity at the horizon (a sky that is zero below it)
        costs no accuracy.
    n_phi : int, optional
        Uniformly spaced azimuths (midpoints, trapezoid rule, ≥ 1).  Default ``2·n_theta``.
    domain : {"sphere", "upper", "lower"}
        Whole sphere, the sky dome (z ≥ 0) or the lower hemisphere.

    Returns
    -------
    directions : ndarray, shape (N, 3)
        Unit vectors in the local frame (x east, y north, z up).
    weights : ndarray, shape (N,)
        Solid angle per node [sr]; they sum to 4π (sphere) or 2π (hemisphere) to rounding.

    Notes
    -----
    On each hemisphere the rule integrates exactly every polynomial in μ of degree
    ≤ 2·n_theta − 1 times a trigonometric polynomial in φ of degree < n_phi; a real SH
    expansion of order L is therefore integrated exactly when n_theta ≥ L + 1 and
    n_phi ≥ 2L + 1 (products of two order-L harmonics need n_theta ≥ L + 1, n_phi ≥ 2L + 1).
    """
    n_theta = _check_count(n_theta, "n_theta", 1)
    n_phi = 2 * n_theta if n_phi is None else _check_count(n_phi, "n_phi", 1)
    check_option(domain, "domain", QUADRATURE_DOMAINS)
    x, w = _gauss_legendre_01(n_theta)
    if domain == "upper":
        mu, wmu = x, w
    elif domain == "lower":
        mu, wmu = -x[::-1], w[::-1]
    else:
        mu, wmu = np.concatenate([-x[::-1], x]), np.concatenate([w[::-1], w])
    phi = (np.arange(n_phi) + 0.5) * (2.0 * np.pi / n_phi)
    s = np.sqrt((1.0 - mu) * (1.0 + mu))
    dirs = np.stack(
        np.broadcast_arrays(
            s[:, None] * np.cos(phi)[None, :],
            s[:, None] * np.sin(phi)[None, :],
            mu[:, None],
        ),
        axis=-1,
    ).reshape(-1, 3)
    weights = np.repeat(wmu * (2.0 * np.pi / n_phi), n_phi)
    return dirs, weights


def latlong_quadrature(width: int, height: int):
    r"""Pixel-centre directions and exact pixel solid angles of an equirectangular map.

    Layout (OpenEXR ``envmap = latlong``, the one the renderer writes and
    :mod:`atmoscatter.compare` assumes): row 0 touches the zenith (θ = 0) and the last row
    the nadir (θ = π), rows uniform in θ; column ``j`` looks at geographic azimuth (from
    north toward east) ``2π (j + ½)/width − π``: south at both edges, north in the centre
    column, east at three quarters of the width.

    Parameters
    ----------
    width, height : int
        Map size in pixels (≥ 1).

    Returns
    -------
    directions : ndarray, shape (height, width, 3)
        Unit vectors in the local frame (x east, y north, z up).
    solid_angles : ndarray, shape (height, width)
        ``Δφ (cos θ_top − cos θ_bottom)`` [sr]; the map sums to 4π.  Integrating with these
        weights is the midpoint rule in φ and exact in the pixel's θ extent for a function
        constant over each pixel (first-order accurate in general).
    """
    width = _check_count(width, "width", 1)
    height = _check_count(height, "height", 1)
    edges = np.linspace(0.0, np.pi, height + 1)
    theta = 0.5 * (edges[:-1] + edges[1:])
    az = (np.arange(width) + 0.5) * (2.0 * np.pi / width) - np.pi
    st, ct = np.sin(theta)[:, None], np.cos(theta)[:, None]
    dirs = np.stack(
        np.broadcast_arrays(st * np.sin(az)[None, :], st * np.cos(az)[None, :], ct), axis=-1
    )
    band = np.cos(edges[:-1]) - np.cos(edges[1:])
    omega = np.broadcast_to((band * (2.0 * np.pi / width))[:, None], (height, width)).copy()
    return dirs, omega


def _unit_vector(v, name: str) -> np.ndarray:
    a = as_float_array(v, name).astype(float)
    if a.shape[-1:] != (3,):
        raise ValueError(f"{name} must have 3 components on its last axis, got shape {a.shape}")
    n = np.linalg.norm(a, axis=-1, keepdims=True)
    if np.any(~np.isfinite(n)) or np.any(n == 0):
        raise ValueError(f"{name} must be finite and non-zero, got {a!r}")
    return a / n


def _frame(normal: np.ndarray) -> np.ndarray:
    """Rotation matrix whose third row is ``normal`` (rows: t1, t2, n)."""
    n = normal
    helper = np.array([1.0, 0.0, 0.0]) if abs(n[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    t1 = np.cross(helper, n)
    t1 /= np.linalg.norm(t1)
    t2 = np.cross(n, t1)
    return np.stack([t1, t2, n])


def _plane_dome_rule(n: np.ndarray, n_theta: int, n_phi: int | None):
    """Quadrature over {ω : n·ω > 0, z > 0} with weights ``dΩ · (n·ω)``.

    In the frame of the normal (t1, t2, n), ω = sinθ cos φ t1 + sinθ sin φ t2 + cosθ n.
    With ψ = φ − φ0 and c(ψ) = A cos ψ the vertical component of the in-plane part
    (A = √(1 − n_z²)), the horizon z = cosθ n_z + sinθ c(ψ) > 0 bounds θ smoothly on each
    half of ψ: for n_z ≥ 0, θ ∈ [0, π/2] where cos ψ ≥ 0 and θ ∈ [0, atan2(n_z, |c|)] where
    cos ψ < 0; for n_z < 0, only cos ψ > 0 with θ ∈ [atan2(|n_z|, c), π/2].  Gauss–Legendre
    in ψ on each half and in θ between the bounds (dΩ = sinθ dθ dψ, smooth in θ unlike μ)
    integrates the smooth pieces spectrally — no kink at the horizon.
    """
    R = _frame(n)
    t1, t2 = R[0], R[1]
    nz = float(n[2])
    A = math.hypot(t1[2], t2[2])
    phi0 = math.atan2(t2[2], t1[2])
    xt, wt = _gauss_legendre_01(n_theta)
    m = max(2, (2 * n_theta if n_phi is None else n_phi) // 2)
    xp, wpsi = _gauss_legendre_01(m)
    halves = [(-0.5 * np.pi, 0.5 * np.pi, "front")]
    if nz >= 0.0:
        halves.append((0.5 * np.pi, 1.5 * np.pi, "back"))
    dirs, weights = [], []
    for a, b, kind in halves:
        psi = a + (b - a) * xp
        wp = (b - a) * wpsi
        c = A * np.cos(psi)
        if nz >= 0.0 and kind == "front":
            lo, hi = np.zeros_like(psi), np.full_like(psi, 0.5 * np.pi)
        elif nz >= 0.0:
            lo, hi = np.zeros_like(psi), np.arctan2(nz, np.abs(c))
        else:
            lo, hi = np.arctan2(-nz, np.maximum(c, 0.0)), np.full_like(psi, 0.5 * np.pi)
        th = lo[:, None] + (hi - lo)[:, None] * xt[None, :]
        st, ct = np.sin(th), np.cos(th)
        w = wp[:, None] * (hi - lo)[:, None] * wt[None, :] * st * ct  # dΩ × cosine
        phi = (psi + phi0)[:, None]
        d = (st * np.cos(phi))[..., None] * t1 + (st * np.sin(phi))[..., None] * t2 \
            + ct[..., None] * n
        dirs.append(d.reshape(-1, 3))
        weights.append(w.reshape(-1))
    return np.concatenate(dirs), np.concatenate(weights)


def _is_sky_image(sky) -> bool:
    return hasattr(sky, "directions_set") and hasattr(sky, "luminance")


def _sample_sky(sky, directions, weights, *, domain: str, n_theta: int, n_phi):
    """Return (values (N,) or (N, C), directions (N, 3), weights (N,))."""
    if _is_sky_image(sky):
        if directions is not None or weights is not None:
            raise ValueError("pass directions/weights only with sampled values, not a SkyImage")
        dset = sky.directions_set
        vals = np.asarray(sky.luminance, dtype=np.float64).reshape(-1)
        dirs = np.asarray(dset.all_directions(), dtype=np.float64).reshape(-1, 3)
        w = np.asarray(dset.solid_angles(0, dset.size), dtype=np.float64).reshape(-1)
        if w.shape != vals.shape:
            raise ValueError("this SkyImage has no per-direction solid angles")
        return vals, dirs, w
    if callable(sky):
        if directions is not None or weights is not None:
            raise ValueError("pass directions/weights only with sampled values, not a callable sky")
        dirs, w = sphere_quadrature(n_theta, n_phi, domain=domain)
        vals = as_float_array(sky(dirs), "sky(directions)")
        if vals.shape[:1] != (dirs.shape[0],):
            raise ValueError(
                f"sky(directions) must return shape (N,) or (N, C) for N = {dirs.shape[0]} "
                f"directions, got {vals.shape}"
            )
        return vals, dirs, w
    if directions is None or weights is None:
        raise ValueError(
            "sky given as values needs directions (..., 3) and weights (...) [sr] "
            "(e.g. from sphere_quadrature or latlong_quadrature)"
        )
    vals = as_float_array(sky, "sky")
    dirs = as_float_array(directions, "directions")
    if dirs.shape[-1:] != (3,):
        raise ValueError(f"directions must have shape (..., 3), got {dirs.shape}")
    lead = dirs.shape[:-1]
    w = as_float_array(weights, "weights")
    if w.shape != lead:
        raise ValueError(f"weights must have shape {lead} (one per direction), got {w.shape}")
    if vals.shape[: len(lead)] != lead or vals.ndim > len(lead) + 1:
        raise ValueError(
            f"sky values must have shape {lead} or {lead} + (C,) to match directions, "
            f"got {vals.shape}"
        )
    n = int(np.prod(lead, dtype=np.int64))
    vals = vals.reshape((n,) + vals.shape[len(lead):])
    return vals, dirs.reshape(n, 3), w.reshape(n)


def _weighted_sum(vals: np.ndarray, w: np.ndarray) -> np.ndarray:
    vals = vals.astype(np.float64, copy=False)
    if vals.ndim == 1:
        return np.float64(w @ vals)
    return np.tensordot(w, vals, axes=(0, 0))


# --------------------------------------------------------------------------------------
# irradiance / illuminance
# --------------------------------------------------------------------------------------
def diffuse_irradiance(
    sky: Callable | np.ndarray,
    *,
    normal=(0.0, 0.0, 1.0),
    directions=None,
    weights=None,
    domain: str = "upper",
    n_theta: int = DEFAULT_N_THETA,
    n_phi: int | None = None,
):
    r"""Irradiance (or illuminance) of a plane from the sky dome, ``∫ L(ω) max(n·ω, 0) dΩ``.

    Parameters
    ----------
    sky : callable, array_like or SkyImage
        Sky radiance/luminance: ``sky(directions (N, 3)) -> (N,) or (N, C)``, sampled
        values with ``directions`` and ``weights`` (see the module docstring), or a rendered
        :class:`~atmoscatter.render.SkyImage` (its luminance [cd m⁻²] and pixel solid angles
        are used: the result is illuminance [lx]).
    normal : array_like, shape (3,)
        Plane normal in the local frame (x east, y north, z up); normalised here.  Default:
        a horizontal plane facing up (diffuse horizontal irradiance/illuminance).
    directions, weights : array_like, optional
        Direction set (…, 3) and solid angles [sr] (…) for sampled values.
    domain : {"upper", "sphere"}
        ``"upper"`` (default) integrates the sky dome only (z > 0): the ground is not a
        source.  ``"sphere"`` also integrates whatever ``sky`` gives below the horizon (a
        ground-reflected term, a planet seen from space).
    n_theta, n_phi : int
        Quadrature resolution for a callable sky (see :func:`sphere_quadrature`).  The rule is
        built around the plane normal (Gauss–Legendre in n·ω), so a horizontal plane with
        ``domain="upper"`` integrates polynomial skies of degree ≤ 2·n_theta − 2 in cos θ
        exactly.  A tilted plane with ``domain="upper"`` uses a rule bounded by both the
        plane and the horizon (Gauss–Legendre in the azimuth ψ about the normal on each half,
        and in n·ω between smooth ψ-dependent limits), so the horizon costs no accuracy:
        uniform and CIE overcast skies on vertical and tilted planes come out to ~1e-13.

    Returns
    -------
    float or ndarray
        Irradiance [W m⁻²] (radiance in W m⁻² sr⁻¹), spectral irradiance (spectral radiance)
        or illuminance [lx] (luminance in cd m⁻²); shape () or (C,).

    Notes
    -----
    Checks (tests): a uniform sky L gives πL; the CIE overcast sky
    ``L = L_z (1 + 2 cos θ)/3`` gives exactly ``7π L_z / 9``.
    """
    check_option(domain, "domain", ("upper", "sphere"))
    n = _unit_vector(normal, "normal").reshape(3)
    if callable(sky):
        if directions is not None or weights is not None:
            raise ValueError("pass directions/weights only with sampled values, not a callable sky")
        n_theta = _check_count(n_theta, "n_theta", 1)
        horizontal = bool(np.allclose(n, (0.0, 0.0, 1.0), rtol=0.0, atol=1e-15))
        if domain == "upper" and not horizontal:
            # tilted plane under the dome: rule bounded by both the plane and the horizon
            dirs_eval, wc = _plane_dome_rule(n, n_theta, n_phi)
        else:
            local, w = sphere_quadrature(n_theta, n_phi, domain="upper")
            # rule built around the normal: local z axis → n (exact frame when horizontal)
            dirs_eval = local if horizontal else local @ _frame(n)
            wc = w * local[:, 2]
        vals = as_float_array(sky(dirs_eval), "sky(directions)")
        if vals.shape[:1] != (dirs_eval.shape[0],):
            raise ValueError(
                f"sky(directions) must return shape (N,) or (N, C) for N = {dirs_eval.shape[0]} "
                f"directions, got {vals.shape}"
            )
        return _weighted_sum(vals, wc)
    vals, dirs, w = _sample_sky(sky, directions, weights, domain="upper", n_theta=n_theta,
                                n_phi=n_phi)
    cosine = np.maximum(dirs @ n, 0.0)
    if domain == "upper":
        cosine = np.where(dirs[:, 2] > 0.0, cosine, 0.0)
    return _weighted_sum(vals, w * cosine)


def direct_irradiance(direct_normal, sun_direction, *, normal=(0.0, 0.0, 1.0)):
    r"""Direct-beam irradiance (or illuminance) of a plane, ``E_n · max(n·s, 0)``.

    Parameters
    ----------
    direct_normal : array_like
        Direct normal irradiance [W m⁻²] (or spectral [W m⁻² nm⁻¹], or illuminance [lx]) of
        the sun's beam, optionally with channels on the last axis.
    sun_direction : array_like, shape (..., 3)
        Unit vector toward the sun (local frame); normalised here.
    normal : array_like, shape (3,)
        Plane normal (default: horizontal, facing up).

    Returns
    -------
    ndarray or float
        ``E_n max(n·s, 0)``, zero when the sun is below the horizon (the ground blocks the
        beam even for a tilted plane).  Shape: broadcast of ``direct_normal`` with the
        sun directions' leading shape (a trailing channel axis of ``direct_normal`` is kept).
    """
    e = as_float_array(direct_normal, "direct_normal")
    s = _unit_vector(sun_direction, "sun_direction")
    n = _unit_vector(normal, "normal").reshape(3)
    f = np.where(s[..., 2] > 0.0, np.maximum(s @ n, 0.0), 0.0)
    if e.ndim > f.ndim and f.ndim > 0:
        f = f[..., None]
    out = e * f.astype(e.dtype if e.dtype.kind == "f" else float)
    return out if out.ndim else float(out)


def direct_normal_irradiance(atmosphere, sun_direction, *, altitude: float = 0.0,
                             distance_au: float = 1.0):
    r"""Spectral direct normal irradiance of the sun at an observer [W m⁻² nm⁻¹].

    ``E_n(λ) = E_0(λ) · exp(−Σ_c β_ext,c(λ) · ℓ_c(μ_s))`` with ``E_0`` the ASTM G-173
    extraterrestrial spectrum (:func:`~atmoscatter.extraterrestrial_irradiance`) and
    ``ℓ_c`` the exact optical length of constituent *c*'s density profile from the observer
    toward the sun (:func:`~atmoscatter.optical_length`; seed 000 Eq. 2–3, seed 004 §2).

    Parameters
    ----------
    atmosphere : Atmosphere
        Planet and constituents; the result is sampled at ``atmosphere.wavelengths``.
    sun_direction : array_like, shape (..., 3)
        Unit vector toward the sun (local frame).
    altitude : float
        Observer altitude above the ground [m].
    distance_au : float
        Earth–Sun distance [au] (scales E_0 by 1/d²).

    Returns
    -------
    ndarray, shape (..., n_wavelengths)
        [W m⁻² nm⁻¹]; 0 where the sun's ray hits the planet (sun below the observer's
        geometric horizon).  Accuracy: that of ``optical_length`` (~1e-10 relative in ℓ).
        The sun is treated as a point (no disc-averaging of the transmittance).
    """
    from ..geometry import ray_hits_ground
    from ..optical_length import optical_length
    from ..solar import extraterrestrial_irradiance

    s = _unit_vector(sun_direction, "sun_direction")
    alt = float(check_positive(altitude, "altitude", allow_zero=True, unit="m"))
    mu = clamp_cosine(s[..., 2])
    wl = atmosphere.wavelengths_array
    e0 = extraterrestrial_irradiance(wl, distance_au=distance_au)
    tau = np.zeros(mu.shape + (wl.size,))
    for c in atmosphere.active_constituents():
        ell = optical_length(c.profile, alt, mu, planet_radius=atmosphere.planet_radius,
                             top_radius=atmosphere.top_radius)
        tau = tau + np.asarray(ell)[..., None] * c.extinction_array
    blocked = ray_hits_ground(atmosphere.planet_radius + alt, mu, atmosphere.planet_radius)
    out = e0 * np.exp(-tau)
    return np.where(np.asarray(blocked)[..., None], 0.0, out)


# --------------------------------------------------------------------------------------
# spherical harmonics
# --------------------------------------------------------------------------------------
def sh_count(order: int) -> int:
    """Number of real SH coefficients up to and including ``order``: ``(order + 1)²``.

    Parameters
    ----------
    order : int
        Highest degree l, ≥ 0.

    Returns
    -------
    int
        ``(order + 1)²``.
    """
    order = _check_count(order, "order", 0)
    return (order + 1) ** 2


def sh_index(l, m):  # noqa: E741 - l is the conventional degree symbol
    """Flat coefficient index ``l(l + 1) + m`` of degree ``l`` ≥ 0 and order ``|m| ≤ l``.

    Parameters
    ----------
    l : int or array_like of int
        Degree, ≥ 0.
    m : int or array_like of int
        Order, ``|m| ≤ l``.

    Returns
    -------
    int or ndarray of int
        Flat index (an int for scalar input).
    """
    la, ma = np.asarray(l), np.asarray(m)
    if np.any(la < 0) or np.any(np.abs(ma) > la):
        raise ValueError(f"sh_index needs l >= 0 and |m| <= l, got l={l!r}, m={m!r}")
    out = la * (la + 1) + ma
    return int(out) if out.ndim == 0 else out


def _order_from_count(n: int) -> int:
    order = int(round(np.sqrt(n))) - 1
    if (order + 1) ** 2 != n:
        raise ValueError(
            f"coefficients must have (order + 1)**2 entries on their first axis, got {n}"
        )
    return order


MAX_SH_ORDER: int = 40
"""Highest supported order (``lpmv`` stays accurate to ~1e-12 relative up to here)."""


def real_sph_harm(order: int, directions, *, condon_shortley: bool = False):
    r"""Real orthonormal spherical harmonics ``Y_lm`` up to ``order`` at unit directions.

    Parameters
    ----------
    order : int
        Highest degree L (0 ≤ L ≤ 40).
    directions : array_like, shape (..., 3)
        Unit vectors in the local frame (x east, y north, z up); normalised here.
    condon_shortley : bool
        Include the ``(−1)^m`` Condon–Shortley phase (default ``False``; see the module
        docstring for the convention).

    Returns
    -------
    ndarray, shape (..., (order + 1)²)
        ``Y[..., l(l+1)+m]``, normalised so that ``∫ Y² dΩ = 1`` (Ω in sr).

    Notes
    -----
    Associated Legendre functions from :func:`scipy.special.lpmv`; checked against
    :func:`scipy.special.sph_harm_y` in the tests (≤ 1e-12).
    """
    from scipy.special import lpmv

    order = _check_count(order, "order", 0)
    if order > MAX_SH_ORDER:
        raise ValueError(f"order must be in [0, {MAX_SH_ORDER}], got {order}")
    d = as_float_array(directions, "directions")
    if d.shape[-1:] != (3,):
        raise ValueError(f"directions must have shape (..., 3), got {d.shape}")
    d = d.astype(np.float64)
    norm = np.linalg.norm(d, axis=-1)
    with np.errstate(invalid="ignore", divide="ignore"):
        d = d / norm[..., None]
    mu = clamp_cosine(d[..., 2])
    phi = np.arctan2(d[..., 1], d[..., 0])
    out = np.empty(d.shape[:-1] + ((order + 1) ** 2,))
    for m in range(order + 1):
        cos_m, sin_m = (np.cos(m * phi), np.sin(m * phi)) if m else (None, None)
        sign = 1.0 if (condon_shortley or m % 2 == 0) else -1.0  # lpmv includes (−1)^m
        for l in range(m, order + 1):  # noqa: E741
            # N_lm via log-gamma so large l does not overflow the factorials.
            nlm = np.sqrt((2 * l + 1) / (4.0 * np.pi) * np.exp(lgamma(l - m + 1) - lgamma(l + m + 1)))
            p = sign * nlm * lpmv(m, l, mu)
            if m == 0:
                out[..., l * (l + 1)] = p
            else:
                out[..., l * (l + 1) + m] = np.sqrt(2.0) * p * cos_m
                out[..., l * (l + 1) - m] = np.sqrt(2.0) * p * sin_m
    return out


def sh_project(
    sky: Callable | np.ndarray,
    order: int = 4,
    *,
    directions=None,
    weights=None,
    domain: str = "sphere",
    n_theta: int | None = None,
    n_phi: int | None = None,
    condon_shortley: bool = False,
):
    r"""Project a sky onto real spherical harmonics: ``c_lm = ∫ f(ω) Y_lm(ω) dΩ``.

    Parameters
    ----------
    sky : callable, array_like or SkyImage
        ``sky(directions (N, 3)) -> (N,) or (N, C)``, sampled values with ``directions``
        and ``weights`` [sr], or a rendered :class:`~atmoscatter.render.SkyImage` (its
        luminance [cd m⁻²] with the pixel solid angles).
    order : int
        Highest SH degree L (default 4 → 25 coefficients).
    directions, weights : array_like, optional
        Direction set and solid angles for sampled values.
    domain : {"sphere", "upper"}
        ``"sphere"``: the function on the whole sphere.  ``"upper"``: the function is taken as
        zero below the horizon (a sky without ground) and only the dome is sampled, which
        integrates the horizon discontinuity exactly.
    n_theta, n_phi : int, optional
        Quadrature resolution for a callable (per hemisphere); default
        ``max(48, 2·(order + 1))`` and ``2·n_theta``.  Exact for skies band-limited to
        degree ≤ 2·n_theta − 1 − order in cos θ (see :func:`sphere_quadrature`).
    condon_shortley : bool
        Basis convention (default: no Condon–Shortley phase).

    Returns
    -------
    ndarray, shape ((order + 1)²,) or ((order + 1)², C)
        Coefficients in the units of ``sky`` × sr.

    Examples
    --------
    >>> import numpy as np
    >>> c = sh_project(lambda d: np.ones(len(d)), order=2)   # c_00 = 4π · Y_00 = 2√π
    >>> print(f"{c[0]:.6f} {2 * np.sqrt(np.pi):.6f} {abs(c[1:]).max() < 1e-12}")
    3.544908 3.544908 True
    """
    check_option(domain, "domain", ("sphere", "upper"))
    order = _check_count(order, "order", 0)
    if n_theta is None:
        n_theta = max(DEFAULT_N_THETA, 2 * (order + 1))
    vals, dirs, w = _sample_sky(sky, directions, weights, domain=domain, n_theta=n_theta,
                                n_phi=n_phi)
    if domain == "upper" and (_is_sky_image(sky) or not callable(sky)):
        w = np.where(dirs[:, 2] > 0.0, w, 0.0)
    y = real_sph_harm(order, dirs, condon_shortley=condon_shortley)
    vals = vals.astype(np.float64, copy=False)
    yw = y * w[:, None]
    if vals.ndim == 1:
        return yw.T @ vals
    return np.tensordot(yw, vals, axes=(0, 0))


def sh_evaluate(coefficients, directions, *, condon_shortley: bool = False):
    r"""Reconstruct ``f(ω) = Σ c_lm Y_lm(ω)`` from SH coefficients.

    Parameters
    ----------
    coefficients : array_like, shape ((L + 1)²,) or ((L + 1)², C)
        As returned by :func:`sh_project` (same convention!).
    directions : array_like, shape (..., 3)
        Unit directions (local frame).

    Returns
    -------
    ndarray, shape (...) or (..., C)
    """
    c = as_float_array(coefficients, "coefficients").astype(np.float64)
    if c.ndim not in (1, 2):
        raise ValueError(f"coefficients must have shape (n,) or (n, C), got {c.shape}")
    order = _order_from_count(c.shape[0])
    y = real_sph_harm(order, directions, condon_shortley=condon_shortley)
    return y @ c


def clamped_cosine_sh_coefficients(order: int) -> np.ndarray:
    r"""Convolution factors ``Â_l`` of the clamped cosine ``max(cos θ, 0)``, l = 0…order.

    ``Â_0 = π``, ``Â_1 = 2π/3``, ``Â_l = 0`` for odd l > 1 and, for even l,
    ``Â_l = 2π (−1)^{l/2−1} / ((l + 2)(l − 1)) · l! / (2^l ((l/2)!)²)``
    (Ramamoorthi & Hanrahan 2001, Eq. 8–9; ``Â_2 = π/4``, ``Â_4 = −π/24``).

    Parameters
    ----------
    order : int
        Highest degree l, ≥ 0.

    Returns
    -------
    ndarray, shape (order + 1,)
        ``Â_l`` [sr] for l = 0…order.
    """
    order = _check_count(order, "order", 0)
    a = np.zeros(order + 1)
    for l in range(order + 1):  # noqa: E741
        if l == 0:
            a[l] = np.pi
        elif l == 1:
            a[l] = 2.0 * np.pi / 3.0
        elif l % 2 == 0:
            h = l // 2
            a[l] = (2.0 * np.pi * (-1.0) ** (h - 1) / ((l + 2) * (l - 1))
                    * factorial(l) / (2.0**l * factorial(h) ** 2))
    return a


def sh_irradiance(coefficients, normals, *, condon_shortley: bool = False):
    r"""Irradiance ``E(n) = ∫ L(ω) max(n·ω, 0) dΩ`` from the SH coefficients of ``L``.

    ``E(n) = Σ_lm Â_l c_lm Y_lm(n)`` (Ramamoorthi & Hanrahan 2001).  Exact when ``L`` is
    band-limited to the coefficients' order; with order 2 the error is below ~3 % of the
    irradiance for any ``L ≥ 0`` (their bound), order 4 is much better.  The whole sphere is
    a source: project with ``domain="upper"`` to exclude the ground.

    Parameters
    ----------
    coefficients : array_like, shape ((L + 1)²,) or ((L + 1)², C)
    normals : array_like, shape (..., 3)
        Plane normals (local frame).

    Returns
    -------
    ndarray, shape (...) or (..., C)
        Units of the radiance × sr (W m⁻², or lx from cd m⁻²).
    """
    c = as_float_array(coefficients, "coefficients").astype(np.float64)
    order = _order_from_count(c.shape[0])
    a = clamped_cosine_sh_coefficients(order)
    per_coef = np.repeat(a, 2 * np.arange(order + 1) + 1)
    scaled = c * (per_coef if c.ndim == 1 else per_coef[:, None])
    return sh_evaluate(scaled, normals, condon_shortley=condon_shortley)

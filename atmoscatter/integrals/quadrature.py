"""Quadrature on the unit sphere and the sampling of a sky for the integrals.

Public objects
--------------
- :func:`sphere_quadrature`: Gauss–Legendre in cos θ × uniform (trapezoid) in φ, split at
  the horizon, with weights [sr].
- :func:`latlong_quadrature`: directions and exact pixel solid angles of a lat-long map.

The private helpers turn a sky given in either form (a callable, or values on a direction
set with their solid angles, or a rendered :class:`~atmoscatter.SkyImage`) into values,
directions and weights, and build the quadrature over the part of the dome a tilted plane
sees (:mod:`atmoscatter.integrals.irradiance`).
"""

from __future__ import annotations

import math
from functools import lru_cache

import numpy as np

from .._validate import as_float_array, check_option

__all__ = ["sphere_quadrature", "latlong_quadrature"]

QUADRATURE_DOMAINS = ("sphere", "upper", "lower")
"""Valid ``domain`` values: the whole sphere, the sky dome (z > 0) or the ground half."""

#: Default Gauss–Legendre nodes in cos θ per hemisphere.
DEFAULT_N_THETA: int = 48


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

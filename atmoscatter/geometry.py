"""Numerically stable ray–sphere geometry on a spherical planet.

Rays are described as in Bruneton (2017): ``r`` is the distance of the ray origin from the
planet centre [m] and ``mu`` the cosine of the angle between the ray and the local vertical
(zenith) at the origin.  All functions broadcast ``r``, ``mu`` and the radius.

Numerical guards
----------------
- The discriminant ``R² − r²(1 − μ²)`` is evaluated as ``(R − r)(R + r) + r²μ²``.  The naive
  form subtracts two numbers of order 4e13 m² for an Earth-sized planet; in float32 that
  loses every digit for a ground observer, and in float64 it loses ~7 digits near grazing
  rays.
- Roots use the cancellation-free pair ``q = −(b + sign(b)√D)``, ``t = q`` and ``t = c/q``
  (Press et al., *Numerical Recipes*, §5.6), so a root near zero (origin on the sphere) is
  exact rather than the difference of two large numbers.
- ``mu`` is clamped into [−1, 1].

Public objects
--------------
:func:`ray_sphere_intersections`, :func:`distance_to_top`, :func:`distance_to_ground`,
:func:`ray_hits_ground`, :func:`altitude_along_ray`, :func:`impact_parameter`.
"""

from __future__ import annotations

import numpy as np

from ._validate import as_float_array, clamp_cosine, safe_sqrt

__all__ = [
    "ray_sphere_intersections",
    "distance_to_top",
    "distance_to_ground",
    "ray_hits_ground",
    "altitude_along_ray",
    "impact_parameter",
    "distance_to_entry",
]


def _prep(r, mu, radius):
    r = as_float_array(r, "r")
    mu = clamp_cosine(as_float_array(mu, "mu"))
    radius = as_float_array(radius, "radius")
    dtype = np.result_type(r, mu, radius)
    return r.astype(dtype, copy=False), mu.astype(dtype, copy=False), radius.astype(dtype, copy=False)


def _discriminant(r, mu, radius):
    # R² − r²(1 − μ²) = (R − r)(R + r) + (rμ)²  (no cancellation for r ≈ R)
    return (radius - r) * (radius + r) + (r * mu) ** 2


def impact_parameter(r, mu):
    """Closest distance of the (infinite) ray line to the planet centre [m].

    ``p = r·sqrt(1 − μ²)``.  Computed as ``r·sqrt((1 − μ)(1 + μ))`` to keep accuracy for
    near-vertical rays.

    Parameters
    ----------
    r : array_like
        Distance of the ray origin from the planet centre [m].
    mu : array_like
        Cosine of the ray's zenith angle at the origin [-].

    Returns
    -------
    ndarray
        Impact parameter ``p`` [m].
    """
    r = as_float_array(r, "r")
    mu = clamp_cosine(as_float_array(mu, "mu"))
    return r * safe_sqrt((1.0 - mu) * (1.0 + mu))


def ray_sphere_intersections(r, mu, radius):
    """Both signed distances along a ray to a sphere centred on the planet.

    Parameters
    ----------
    r : array_like
        Distance of the ray origin from the planet centre [m], ``r >= 0``.
    mu : array_like
        Cosine of the ray's zenith angle at the origin [-]; clamped into [−1, 1].
    radius : array_like
        Sphere radius [m].

    Returns
    -------
    t_near, t_far : ndarray
        Signed distances [m] of the two intersections, ``t_near <= t_far``; negative values
        lie behind the origin.  NaN where the ray line misses the sphere.

    Notes
    -----
    Solves ``t² + 2rμ t + (r² − R²) = 0`` with the cancellation-free root pair; accurate to a
    few ulp of the larger root in float32 and float64 (tested against a float128 / mpmath-free
    exact evaluation in ``tests/test_geometry.py``).
    """
    r, mu, radius = _prep(r, mu, radius)
    b = r * mu
    c = (r - radius) * (r + radius)
    disc = _discriminant(r, mu, radius)
    hit = disc >= 0
    sq = safe_sqrt(disc)
    # q = −(b + sign(b)·√D); sign(0) taken as +1 so q ≠ 0 unless b = D = 0.
    q = -(b + np.where(b >= 0, sq, -sq))
    # over: for a ray that misses (D < 0, √D clamped to 0) with a denormal b = rμ, c/q can
    # overflow; that element is replaced by NaN below.
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        t1 = q
        t2 = np.where(q != 0, c / np.where(q != 0, q, 1), 0.0)
    t_near = np.where(hit, np.minimum(t1, t2), np.nan)
    t_far = np.where(hit, np.maximum(t1, t2), np.nan)
    return t_near, t_far


def distance_to_top(r, mu, top_radius):
    """Distance [m] from the ray origin to where it leaves the top-of-atmosphere sphere.

    For an origin inside (or on) the sphere this is the positive root.  For an origin
    outside, it is the far intersection if the ray enters the atmosphere ahead, and 0 if it
    misses or points away (nothing to integrate).  Never NaN for finite input.

    Parameters
    ----------
    r : array_like
        Distance of the ray origin from the planet centre [m].
    mu : array_like
        Cosine of the ray's zenith angle at the origin [-].
    top_radius : float or array_like
        Radius of the top of the atmosphere [m].

    Returns
    -------
    ndarray
        Distance to the exit point [m] (0 when there is nothing to integrate).
    """
    t_near, t_far = ray_sphere_intersections(r, mu, top_radius)
    return np.where(np.isfinite(t_far) & (t_far > 0), t_far, 0.0).astype(t_far.dtype, copy=False)


def distance_to_entry(r, mu, top_radius):
    """Distance [m] to where the ray enters the top-of-atmosphere sphere (0 if inside).

    Parameters
    ----------
    r : array_like
        Distance of the ray origin from the planet centre [m].
    mu : array_like
        Cosine of the ray's zenith angle at the origin [-].
    top_radius : float or array_like
        Radius of the top of the atmosphere [m].

    Returns
    -------
    ndarray
        Distance to the entry point [m]; 0 for an origin inside the atmosphere.
    """
    t_near, t_far = ray_sphere_intersections(r, mu, top_radius)
    return np.where(np.isfinite(t_near) & (t_near > 0), t_near, 0.0).astype(t_near.dtype, copy=False)


def ray_hits_ground(r, mu, planet_radius):
    """True where the ray from ``r`` with zenith cosine ``mu`` hits the planet ahead.

    A ray hits the ground iff it points downward (μ < 0) and its line passes within the
    planet radius, i.e. ``R² − r²(1 − μ²) >= 0`` (evaluated without cancellation).  A ray
    from above the ground (``r > R``) exactly tangent to it counts as a hit; from the ground
    itself (``r = R``) the horizontal ray (``μ = 0``) does not — it is the horizon ray,
    which travels through the atmosphere.  Origins below the surface are invalid input;
    they are reported as hitting.

    Parameters
    ----------
    r : array_like
        Distance of the ray origin from the planet centre [m].
    mu : array_like
        Cosine of the ray's zenith angle at the origin [-].
    planet_radius : float or array_like
        Planet radius [m].

    Returns
    -------
    ndarray of bool
        True where the ray hits the ground.
    """
    r, mu, radius = _prep(r, mu, planet_radius)
    disc = _discriminant(r, mu, radius)
    return ((mu < 0) & (disc >= 0)) | (r < radius)


def distance_to_ground(r, mu, planet_radius):
    """Distance [m] along the ray to the ground, ``+inf`` where it does not hit.

    The near (first) intersection is returned: for ``r ≥ R`` and ``μ < 0`` that is
    ``c/q`` with ``q = −(rμ − √D)`` (no cancellation), 0 for an observer exactly on the
    surface looking down.

    Parameters
    ----------
    r : array_like
        Distance of the ray origin from the planet centre [m].
    mu : array_like
        Cosine of the ray's zenith angle at the origin [-].
    planet_radius : float or array_like
        Planet radius [m].

    Returns
    -------
    ndarray
        Distance to the ground [m]; ``inf`` for rays that miss it.
    """
    r, mu, radius = _prep(r, mu, planet_radius)
    t_near, _ = ray_sphere_intersections(r, mu, radius)
    hit = ray_hits_ground(r, mu, radius)
    return np.where(hit, np.maximum(np.nan_to_num(t_near, nan=0.0), 0.0), np.inf).astype(r.dtype, copy=False)


def altitude_along_ray(r, mu, t, planet_radius):
    """Altitude above the surface [m] and zenith cosine at distance ``t`` along the ray.

    Returns ``(h, mu_t)`` with ``r_t = sqrt(r² + 2rμt + t²)`` evaluated as
    ``sqrt((r + μt)² + (1 − μ²)t²)`` (sum of squares: no cancellation), and
    ``mu_t = (rμ + t)/r_t``.

    Parameters
    ----------
    r : array_like
        Distance of the ray origin from the planet centre [m].
    mu : array_like
        Cosine of the ray's zenith angle at the origin [-].
    t : array_like
        Distance along the ray [m].
    planet_radius : float or array_like
        Planet radius [m].

    Returns
    -------
    h : ndarray
        Altitude above the surface at ``t`` [m].
    mu_t : ndarray
        Cosine of the ray's zenith angle at ``t`` [-].
    """
    r, mu, radius = _prep(r, mu, planet_radius)
    t = as_float_array(t, "t")
    along = r + mu * t
    r_t = np.sqrt(along * along + ((1.0 - mu) * (1.0 + mu)) * t * t)
    with np.errstate(divide="ignore", invalid="ignore"):
        mu_t = np.where(r_t > 0, (r * mu + t) / np.where(r_t > 0, r_t, 1.0), 1.0)
    return r_t - radius, clamp_cosine(mu_t)

"""Per-sample geometry: from the time-only columns to the topocentric Sun at a site.

Shared by the methods of :func:`sun_position`.  For one block of broadcast times and sites,
``_block`` turns the hour angle ``H = 2π frac(d) + longitude − q`` and the declination into
the topocentric zenith, azimuth and unit vector (x = east, y = north, z = up):

- parallax as a vector subtraction, equivalent to the topocentric step of Reda & Andreas
  (2004), Eq. 37–40: the observer sits at ``sin ξ·(x, 0, y)`` in units of the Sun's
  distance, with the site terms ``x = ρ cos φ′``, ``y = ρ sin φ′`` of the SPA ellipsoid
  (Eq. 34–36, ``_site_terms``; the equatorial horizontal parallax ξ of Eq. 33 is computed
  by :func:`sun_position`);
- atmospheric refraction by Reda & Andreas Eq. 42 (``_refraction_deg``), applied while the
  true elevation is ≥ −(0.26667° + 0.5667°), as a small rotation of the unit vector;
- zenith and azimuth (Eq. 41–46) from the components of that vector.

``_blocks`` cuts an array shape into blocks of at most ``_CHUNK`` elements so that the
temporaries stay in cache and memory stays bounded whatever the shape.
"""

from __future__ import annotations

import numpy as np

from ._common import _DEG, _TWO_PI

__all__: list[str] = []

#: Earth equatorial radius used by the SPA parallax terms [m]; flattening factor b/a.
_EARTH_RADIUS_SPA = 6378140.0
_B_OVER_A = 0.99664719
#: SPA refraction is applied while the true elevation is ≥ −(0.26667° + 0.5667°).
_REFRACTION_LIMIT_DEG = -(0.26667 + 0.5667)


def _refraction_deg(e0_deg, pressure_hpa, temperature_c):
    """SPA atmospheric refraction Δe [deg] (Reda & Andreas Eq. 42) for true elevation e0."""
    e = np.maximum(e0_deg, _REFRACTION_LIMIT_DEG)
    corr = (
        (pressure_hpa / 1010.0)
        * (283.0 / (273.0 + temperature_c))
        * 1.02
        / (60.0 * np.tan((e + 10.3 / (e + 5.11)) * _DEG))
    )
    return np.where(e0_deg >= _REFRACTION_LIMIT_DEG, corr, 0.0)


def _site_terms(lat_deg, elev_m):
    """Geodetic latitude → sin/cos and the SPA parallax terms x = ρ cos φ′, y = ρ sin φ′."""
    phi = lat_deg * _DEG
    sphi, cphi = np.sin(phi), np.cos(phi)
    u = np.arctan2(_B_OVER_A * sphi, cphi)
    h = elev_m / _EARTH_RADIUS_SPA
    return sphi, cphi, np.cos(u) + h * cphi, _B_OVER_A * np.sin(u) + h * sphi


def _block(d, q, sin_dec, sin_xi, lon_rad, sphi, cphi, xs, ys, p_hpa, temp_c, refraction):
    """Topocentric geometry for one block of broadcast arrays.

    The parallax is applied as a vector subtraction (equivalent to SPA Eq. 36–41): in the
    hour-angle frame the Sun's geocentric unit vector is (cos δ cos H, −cos δ sin H, sin δ)
    and the observer sits at sin ξ·(x, 0, y) in units of the Sun's distance.
    """
    h_ang = _TWO_PI * (d - np.floor(d)) + lon_rad - q
    cos_dec = np.sqrt(1.0 - sin_dec * sin_dec)
    vx = cos_dec * np.cos(h_ang) - xs * sin_xi
    east = -cos_dec * np.sin(h_ang)
    vz = sin_dec - ys * sin_xi
    north = cphi * vz - sphi * vx
    up = cphi * vx + sphi * vz
    horiz = np.sqrt(east * east + north * north)
    true_zen = np.arctan2(horiz, up)
    azimuth = np.arctan2(east, north) % _TWO_PI
    inv_norm = 1.0 / np.sqrt(horiz * horiz + up * up)
    if refraction:
        delta = _refraction_deg(90.0 - true_zen / _DEG, p_hpa, temp_c) * _DEG
        zen = true_zen - delta
        # rotate the true unit vector up by delta (series: |delta| < 0.011 rad, error < 1e-12)
        d2 = delta * delta
        cd = 1.0 - d2 * (0.5 - d2 / 24.0)
        sd = delta * (1.0 - d2 / 6.0)
        ce, se = horiz * inv_norm, up * inv_norm
        ca = ce * cd - se * sd
        k = ca / np.maximum(horiz, 1e-300)
        direction = np.stack([east * k, north * k, se * cd + ce * sd], axis=-1)
    else:
        zen = true_zen
        direction = np.stack([east * inv_norm, north * inv_norm, up * inv_norm], axis=-1)
    return zen, true_zen, azimuth, direction


def _blocks(shape: tuple[int, ...], chunk: int):
    """Index tuples covering ``shape`` in blocks of at most ``chunk`` elements (C order).

    Blocks are slices of the leading axis when a row fits, else single leading indices with
    the rest split recursively, so memory stays bounded whatever the shape.
    """
    if len(shape) == 0:
        yield ()
        return
    inner = int(np.prod(shape[1:], dtype=np.int64))
    if inner <= chunk:
        rows = max(1, chunk // max(inner, 1))
        for s in range(0, shape[0], rows):
            yield (slice(s, s + rows),)
        return
    if len(shape) == 1:  # pragma: no cover - inner == 1 always fits
        yield (slice(None),)
        return
    for i in range(shape[0]):
        for sub in _blocks(shape[1:], chunk):
            yield (i, *sub)

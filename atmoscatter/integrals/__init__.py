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
- :func:`clamped_cosine_sh_coefficients`: the clamped-cosine kernel's SH coefficients Â_l.

The spherical-harmonic convention (real, orthonormal, no Condon–Shortley phase by default)
is described in :mod:`atmoscatter.integrals.harmonics`.

Modules
-------
quadrature
    Quadrature rules on the sphere (:func:`sphere_quadrature`, :func:`latlong_quadrature`)
    and the sampling of a sky given in either form.
irradiance
    Irradiance/illuminance on a plane: diffuse (sky) and direct (sun).
harmonics
    The real spherical-harmonic basis, projection, reconstruction and SH irradiance.

The public names are re-exported here and flat from :mod:`atmoscatter`.

References
----------
- CIE S 011/E:2003, "Spatial distribution of daylight — CIE standard general sky" (the
  overcast sky L(θ)/L_z = (1 + 2 cos θ)/3 used in the tests).
"""

# DEFAULT_N_THETA, QUADRATURE_DOMAINS and MAX_SH_ORDER are not in __all__ but stay importable
# from atmoscatter.integrals, as before the split (hence the noqa).
from .harmonics import (  # noqa: F401
    MAX_SH_ORDER,
    clamped_cosine_sh_coefficients,
    real_sph_harm,
    sh_count,
    sh_evaluate,
    sh_index,
    sh_irradiance,
    sh_project,
)
from .irradiance import diffuse_irradiance, direct_irradiance, direct_normal_irradiance
from .quadrature import (  # noqa: F401
    DEFAULT_N_THETA,
    QUADRATURE_DOMAINS,
    latlong_quadrature,
    sphere_quadrature,
)

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

"""The solar disc of a rendered sky: its radiance through the atmosphere, with linear limb
darkening, as the evaluator paints it into the pixels the disc covers (or adds its beam to a
dome's vertices)."""

from __future__ import annotations

import math

import numpy as np

from ..scene import Scene
from .plan import Plan
from .plan import plan as make_plan

__all__ = ["sun_disc_radiance", "LIMB_DARKENING_U"]

#: Linear limb-darkening coefficient u in ``I(μ)/I(1) = 1 − u (1 − μ)``: the
#: Eddington approximation for a grey atmosphere, ``I(μ) ∝ (2 + 3μ)/5`` (e.g.
#: Mihalas 1978, *Stellar Atmospheres*, §3-3), u = 0.6 at all wavelengths.  The
#: real Sun darkens more in the blue than in the red; that dependence is not modelled.
LIMB_DARKENING_U = 0.6


def _transmittance(scene: Scene, plan: Plan, wavelengths):
    """Direct-beam transmittance toward the sun, from the observer (per wavelength)."""
    from ..geometry import ray_hits_ground  # noqa: PLC0415
    from ..optical_length import optical_length  # noqa: PLC0415
    from .physical_adapters import _build_atmosphere  # noqa: PLC0415

    wavelengths = np.asarray(wavelengths, dtype=float)
    custom = plan.atmosphere
    atm = _build_atmosphere(scene, wavelengths) if custom is None else custom
    mu = math.cos(plan.sun_zenith)
    r = float(atm.planet_radius) + scene.altitude
    if bool(ray_hits_ground(r, mu, float(atm.planet_radius))):
        return np.zeros(len(wavelengths))
    tau = np.zeros(atm.n_wavelengths)
    for c in atm.constituents:
        ol = float(optical_length(c.profile, scene.altitude, mu,
                                  planet_radius=float(atm.planet_radius),
                                  top_radius=float(atm.top_radius)))
        tau += c.extinction_array * ol
    if custom is not None:  # optical depth at the atmosphere's wavelengths → the grid
        wl = atm.wavelengths_array
        order = np.argsort(wl)
        tau = np.interp(wavelengths, wl[order], tau[order])
    return np.exp(-tau)


def sun_disc_radiance(scene: Scene, plan: Plan | None = None):
    """Radiance at the centre of the solar disc and the disc's angular radius.

    ``L(λ) = E(λ) T(λ) / (Ω_sun (1 − u/3))`` at the disc centre, with ``E`` the
    ASTM G-173 ETR at the scene's Earth–Sun distance, ``T`` the direct-beam
    transmittance of the scene's atmosphere (turbidity, ozone) along the sun
    direction from the observer (exact optical lengths on the sphere), ``Ω_sun``
    the solar disc's solid angle and ``u`` :data:`LIMB_DARKENING_U` (the mean of
    ``1 − u(1 − μ)`` over the disc is ``1 − u/3``, so the disc integrates to
    ``E·T``).  Returns ``(XYZ_centre [cd m⁻²], angular_radius [rad], spectrum)``
    where ``spectrum`` is ``(wavelengths [nm], L [W m⁻² sr⁻¹ nm⁻¹])``.

    Parameters
    ----------
    scene : Scene
        The sun position, date (Earth–Sun distance), observer altitude and atmosphere
        preset (turbidity, ozone).
    plan : Plan, optional
        The scene's plan (default: :func:`atmoscatter.plan` of ``scene``); its custom
        atmosphere, if any, replaces the preset.

    Returns
    -------
    XYZ_centre : ndarray, shape (3,)
        CIE XYZ of the radiance at the disc centre [cd m⁻²]; zeros when the direct beam
        hits the ground (the sun below the observer's horizon).
    angular_radius : float
        Angular radius of the solar disc [rad]: ``SUN_ANGULAR_RADIUS / d`` for the
        Earth–Sun distance ``d`` [AU] of the scene's date (``d = 1`` without a date).
    spectrum : tuple of ndarray
        ``(wavelengths, L)``: :data:`~atmoscatter.models.FINE_GRID` (380–780 nm every
        5 nm) [nm] and the spectral radiance at the disc centre [W m⁻² sr⁻¹ nm⁻¹], both of
        shape (81,).

    Raises
    ------
    ValueError
        If ``plan`` is None and :func:`atmoscatter.plan` rejects ``scene``.
    """
    from ..colour import K_M, cmf_weights  # noqa: PLC0415
    from ..solar import SUN_ANGULAR_RADIUS  # noqa: PLC0415
    from .photometry import FINE_GRID, _band_etr  # noqa: PLC0415

    p = make_plan(scene) if plan is None else plan
    alpha = SUN_ANGULAR_RADIUS / p.distance_au
    omega = 2.0 * math.pi * (1.0 - math.cos(alpha))
    grid = FINE_GRID
    T = _transmittance(scene, p, grid)
    L = _band_etr(grid, p.distance_au) * T / (omega * (1.0 - LIMB_DARKENING_U / 3.0))
    xyz = K_M * (L @ cmf_weights(grid))
    return xyz, alpha, (grid, L)

"""Adapters of the analytic skies: Preetham et al. (1999) and the CIE overcast and clear skies.

Public objects
--------------
:data:`CIE_SKY_CHROMATICITY`
    The chromaticity (CIE D65) given to the luminance-only CIE skies.

These photometric models return luminance/XYZ [cd m⁻²] directly (units and turbidity:
:mod:`atmoscatter.render.models`).  Each adapter is registered in
:data:`~atmoscatter.render.models.MODELS` on import if its model's functions are in the
package.
"""

from __future__ import annotations

import math

import numpy as np

from .models import ModelAdapter, _lookup, register_model

__all__ = ["CIE_SKY_CHROMATICITY"]



# ----------------------------------------------------------------------------
# Preetham (analytic)
# ----------------------------------------------------------------------------
def _preetham_luminance_function(scene, plan):
    """Y only: ``Y = Y_z F_Y(θ, γ)/F_Y(0, θ_s)`` from the Y row of the Preetham fit.

    Uses the public pieces of :mod:`atmoscatter.sky.preetham` (coefficients,
    zenith value) and :func:`atmoscatter.perez`; the x and y distributions are
    never evaluated.  Returns None if those pieces are not available.
    """
    coef_fn = _lookup("preetham_distribution_coefficients")
    zen_fn = _lookup("preetham_zenith")
    perez = _lookup("perez")
    if coef_fn is None or zen_fn is None or perez is None:
        return None
    sun = plan.sun_direction
    theta_s = float(plan.sun_zenith)
    if sun[2] < 0.0:  # the Preetham policy: dark sky for a sun below the horizon
        return lambda d: {"Y": np.zeros(len(d))}
    A, B, C, D, E = np.asarray(coef_fn(scene.turbidity), dtype=float)[0]
    y_zenith = float(np.asarray(zen_fn(scene.turbidity, theta_s))[..., 0])
    norm = float(perez(0.0, theta_s, A, B, C, D, E))

    def evaluate(directions):
        d = np.asarray(directions, dtype=float)
        theta = np.arccos(np.clip(d[:, 2], 0.0, 1.0))
        # γ = 2 atan2(|v − s|, |v + s|): accurate at the sun and the anti-solar point
        gamma = 2.0 * np.arctan2(np.linalg.norm(d - sun, axis=-1), np.linalg.norm(d + sun, axis=-1))
        return {"Y": y_zenith * np.asarray(perez(theta, gamma, A, B, C, D, E)) / norm}

    return evaluate


def _prepare_preetham(scene, plan):
    if plan.quantity == "Y":
        lum = _preetham_luminance_function(scene, plan)
        if lum is not None:
            return lum
    fn = _lookup("preetham_sky")
    sun = plan.sun_direction
    turbidity = scene.turbidity
    if plan.quantity == "spectral":
        spectral = _lookup("preetham_sky_spectral")
        wl = np.asarray(plan.wavelengths, dtype=float)

        def evaluate_spectral(directions):
            # the D-series reconstruction can dip below zero far from the daylight locus
            # (low sun); an image gets the clipped spectrum rescaled to the model's Y
            return {"XYZ": np.asarray(fn(directions, sun, turbidity), dtype=float),
                    "spectral": np.asarray(spectral(directions, sun, turbidity, wl,
                                                    clip_negative=True), dtype=float)}

        return evaluate_spectral

    def evaluate(directions):
        xyz = np.asarray(fn(directions, sun, turbidity), dtype=float)
        if plan.quantity == "Y":
            return {"Y": xyz[..., 1]}
        return {"XYZ": xyz}

    return evaluate


def _preetham_wavelengths(scene):
    """Spectral layers of the Preetham sky only when asked for (CIE D-series, 380–780 nm)."""
    if scene.output != "spectral":
        return ()
    step = scene.wavelength_step
    n = int(math.floor((780.0 - 380.0) / step + 1e-9)) + 1
    return tuple(380.0 + step * np.arange(n))


# ----------------------------------------------------------------------------
# CIE overcast and clear skies (luminance distributions)
# ----------------------------------------------------------------------------
#: Chromaticity given to the luminance-only CIE skies: CIE D65 (x, y).
CIE_SKY_CHROMATICITY = (0.3127, 0.3290)


def _with_d65(y, quantity):
    if quantity == "Y":
        return {"Y": y}
    x, yy = CIE_SKY_CHROMATICITY
    return {"XYZ": np.stack([x / yy * y, y, (1.0 - x - yy) / yy * y], axis=-1)}


def _prepare_cie_overcast(scene, plan):
    fn = _lookup("cie_overcast_sky")
    zl = _lookup("cie_zenith_luminance")
    y_zenith = float(zl(plan.sun_zenith, method="krochmann"))

    def evaluate(directions):
        return _with_d65(np.asarray(fn(directions, y_zenith), dtype=float), plan.quantity)

    return evaluate


def _prepare_cie_clear(scene, plan):
    fn = _lookup("cie_clear_sky")
    zl = _lookup("cie_zenith_luminance")
    sun = plan.sun_direction
    y_zenith = float(zl(plan.sun_zenith, method="preetham", turbidity=scene.turbidity))

    def evaluate(directions):
        return _with_d65(np.asarray(fn(directions, sun, y_zenith), dtype=float), plan.quantity)

    return evaluate


_CIE_OVERCAST = ModelAdapter(
    name="cie_overcast",
    description="CIE standard overcast sky (Moon & Spencer 1942), zenith luminance after "
    "Krochmann (1963); colour: D65 chromaticity",
    prepare=_prepare_cie_overcast,
    cost_per_direction=5e-8,
    error_estimate="CIE standard distribution (exact by definition); absolute level from "
    "Krochmann's zenith-luminance fit; chromaticity assumed D65",
)

_CIE_CLEAR = ModelAdapter(
    name="cie_clear",
    description="CIE clear sky (Kittler), zenith luminance from Preetham et al. (1999); "
    "colour: D65 chromaticity",
    prepare=_prepare_cie_clear,
    cost_per_direction=2e-7,
    turbidity_range=(2.0, 10.0),
    error_estimate="CIE standard distribution; absolute level from the Preetham zenith fit "
    "(turbidity 2-10); chromaticity assumed D65",
)


_PREETHAM = ModelAdapter(
    name="preetham",
    description="Preetham, Shirley & Smits (1999) analytic clear sky (Perez fits of Y, x, y)",
    prepare=_prepare_preetham,
    spectral=True,
    wavelengths=_preetham_wavelengths,
    separate_haze=False,
    ground_only=True,
    cost_per_direction=3e-7,
    turbidity_range=(2.0, 10.0),
    error_estimate=(
        "Preetham 1999 fit to Nishita-type simulations; the authors do not state a bound; "
        "valid for turbidity 2-10 and the sun above the horizon"
    ),
)


def _register_available():
    if _lookup("preetham_sky") is not None:
        register_model(_PREETHAM, replace=True)
    if _lookup("cie_overcast_sky") is not None and _lookup("cie_zenith_luminance") is not None:
        register_model(_CIE_OVERCAST, replace=True)
    if _lookup("cie_clear_sky") is not None and _lookup("cie_zenith_luminance") is not None:
        register_model(_CIE_CLEAR, replace=True)


_register_available()

"""Adapters of the daylighting skies: the 15 CIE standard general skies (ISO 15469 / CIE
S 011) and the Perez, Seals & Michalsky (1993) all-weather sky driven by measured
irradiance.

Both are luminance models; like the CIE skies of :mod:`atmoscatter.render.analytic_adapters`
they are given the D65 chromaticity.  The adapters are registered in
:data:`~atmoscatter.render.models.MODELS` on import.
"""

from __future__ import annotations

import numpy as np

from .analytic_adapters import _with_d65
from .models import ModelAdapter, register_model

__all__: list[str] = []


def _prepare_cie_standard(scene, plan):
    from ..sky.cie_standard import cie_standard_sky  # noqa: PLC0415

    sun = plan.sun_direction
    kw = {"zenith_luminance": scene.zenith_luminance,
          "diffuse_horizontal_illuminance": scene.diffuse_horizontal_illuminance}

    def evaluate(directions):
        y = np.asarray(cie_standard_sky(directions, sun, scene.cie_type, **kw), dtype=float)
        return _with_d65(y, plan.quantity)

    return evaluate


def _scene_extraterrestrial_irradiance(scene) -> float:
    """Solar constant 1367 W m⁻² scaled by 1/r² for the scene date (1 AU without a time)."""
    from ..sky.perez_all_weather import PEREZ_SOLAR_CONSTANT  # noqa: PLC0415

    if not scene.time:
        return PEREZ_SOLAR_CONSTANT
    from ..sun import earth_sun_distance  # noqa: PLC0415

    t = np.datetime64(scene.datetime().replace(tzinfo=None), "ns")
    return PEREZ_SOLAR_CONSTANT / float(earth_sun_distance(t)) ** 2


def _prepare_perez_all_weather(scene, plan):
    from ..sky.perez_all_weather import perez_all_weather_sky  # noqa: PLC0415

    sun = plan.sun_direction
    kw = {"dew_point": scene.dew_point,
          "extraterrestrial_normal_irradiance": _scene_extraterrestrial_irradiance(scene)}
    dni, dhi = scene.direct_normal_irradiance, scene.diffuse_horizontal_irradiance
    perez_all_weather_sky(np.array([[0.0, 0.0, 1.0]]), sun, dni, dhi, **kw)  # errors up front

    def evaluate(directions):
        y = np.asarray(perez_all_weather_sky(directions, sun, dni, dhi, **kw), dtype=float)
        return _with_d65(y, plan.quantity)

    return evaluate


_CIE_STANDARD = ModelAdapter(
    name="cie_standard",
    description="CIE standard general sky, types 1-15 (ISO 15469 / CIE S 011), scaled by a "
    "zenith luminance or a diffuse horizontal illuminance; colour: D65 chromaticity",
    prepare=_prepare_cie_standard,
    driven_by="cie_type and a zenith luminance or diffuse horizontal illuminance",
    cost_per_direction=2e-7,
    error_estimate="CIE S 011 relative distribution (exact to the standard's formulas); "
    "illuminance scaling by quadrature (< 1e-8 relative); chromaticity assumed D65",
)

_PEREZ_ALL_WEATHER = ModelAdapter(
    name="perez_all_weather",
    description="Perez, Seals & Michalsky (1993) all-weather sky from direct-normal and "
    "diffuse-horizontal irradiance, Perez et al. (1990) diffuse efficacy; colour: D65",
    prepare=_prepare_perez_all_weather,
    driven_by="direct-normal and diffuse-horizontal irradiance",
    cost_per_direction=2e-7,
    error_estimate="Perez all-weather fit (published RMS errors of ~20-30 % per sky element); "
    "absolute level from the Perez 1990 diffuse efficacy (a few % RMS); chromaticity "
    "assumed D65",
)


register_model(_CIE_STANDARD, replace=True)
register_model(_PEREZ_ALL_WEATHER, replace=True)

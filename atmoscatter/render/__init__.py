"""Rendering: from a :class:`~atmoscatter.scene.Scene` to a :class:`SkyImage`, one module per step.

* :mod:`atmoscatter.render.plan` — :func:`~atmoscatter.render.plan.plan` decides the minimal
  work a scene needs (a :class:`Plan`);
* :mod:`atmoscatter.render.directions` — the view directions of the output geometry
  (lat-long, cube map, fisheye, dome);
* :mod:`atmoscatter.render.models` — :class:`ModelAdapter` and the registry :data:`MODELS`;
  the built-in adapters are in :mod:`atmoscatter.render.analytic_adapters` and
  :mod:`atmoscatter.render.physical_adapters`, their conversion to absolute units in
  :mod:`atmoscatter.render.photometry`;
* :mod:`atmoscatter.render.evaluate` — :func:`render` evaluates the model's adapter over the
  directions in batches and returns a :class:`SkyImage` (written by :mod:`atmoscatter.exr`).

This package is the public face of these modules: it re-exports their public names (and
``atmoscatter`` re-exports them in turn).  As attributes, ``atmoscatter.render`` is the
function :func:`render` and ``atmoscatter.render.plan`` the function
:func:`~atmoscatter.render.plan.plan`; import from the modules by their full names
(``from atmoscatter.render.plan import Plan``).
"""

# ruff: noqa: I001  (imports follow the data flow, not the alphabet)
# (no ``from __future__ import annotations`` here: it would leak ``annotations``)
from .plan import Plan, auto_sampling_rule, plan
from .directions import (
    AIR_OPTICAL_LENGTH_ZENITH,
    ArrayDirections,
    CubeMapDirections,
    DirectionSet,
    FisheyeDirections,
    LatLongDirections,
    direction_set,
    exr_to_local,
    local_to_exr,
    mirror_pairs,
)
from .dome import DomeDirections
from .models import MODELS, ModelAdapter, get_model, register_model, unregister_model
from .analytic_adapters import CIE_SKY_CHROMATICITY  # importing it registers Preetham, CIE
from . import daylight_adapters  # noqa: F401  (registers the CIE standard and Perez skies)
from .photometry import rgb_sampling_matrix
from .physical_adapters import HOFFMAN_PREETHAM_HAZE_G, physical_adapter  # registers them
from .evaluate import GAMUT_WARN_FRACTION, GamutWarning, render, render_batches
from .sun_disc import LIMB_DARKENING_U, sun_disc_radiance
from .image import SkyImage

# Exactly the union of the modules' ``__all__``: ``atmoscatter.__all__`` is built from the
# modules themselves, so tests/test_startup.py fails if a name is missing here.
__all__ = [
    # plan
    "Plan", "plan", "auto_sampling_rule",
    # directions
    "DirectionSet", "LatLongDirections", "CubeMapDirections", "FisheyeDirections",
    "DomeDirections", "direction_set", "local_to_exr", "exr_to_local", "mirror_pairs",
    "ArrayDirections", "AIR_OPTICAL_LENGTH_ZENITH",
    # models, analytic_adapters, photometry, physical_adapters
    "ModelAdapter", "MODELS", "get_model", "register_model", "unregister_model",
    "CIE_SKY_CHROMATICITY", "rgb_sampling_matrix", "physical_adapter", "HOFFMAN_PREETHAM_HAZE_G",
    # evaluate
    "SkyImage", "render", "render_batches", "sun_disc_radiance", "LIMB_DARKENING_U",
    "GamutWarning", "GAMUT_WARN_FRACTION",
]

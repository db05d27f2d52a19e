"""Rendering: a :class:`~atmoscatter.scene.Scene` evaluated over its directions.

The public face of the package: the evaluator lives in :mod:`atmoscatter.render.evaluate`,
the rendered sky (:class:`SkyImage`) in :mod:`atmoscatter.render.image`.
"""

from .evaluate import (
    GAMUT_WARN_FRACTION,
    LIMB_DARKENING_U,
    GamutWarning,
    render,
    render_batches,
    sun_disc_radiance,
)
from .image import SkyImage

__all__ = ["SkyImage", "render", "render_batches", "sun_disc_radiance", "LIMB_DARKENING_U",
           "GamutWarning", "GAMUT_WARN_FRACTION"]

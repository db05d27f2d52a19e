"""Rendering: from a :class:`~atmoscatter.scene.Scene` to a :class:`SkyImage`.

The data flow, one module per step:

Modules
-------
plan
    :func:`plan` decides the minimal work a scene needs (:class:`Plan`).
directions
    The view directions of the output geometry (lat-long, cube map, fisheye, dome).
models
    :class:`ModelAdapter` and the registry :data:`MODELS`; the built-in adapters are in
    ``analytic_adapters`` and ``physical_adapters``, their unit conversion in ``photometry``.
evaluate
    :func:`render` evaluates the model's adapter over the directions in batches and returns
    a :class:`SkyImage` (written by :mod:`atmoscatter.exr`).

This package is the public face of these modules: it re-exports their ``__all__``.  Note that
``atmoscatter.render`` as an attribute is the function :func:`render` (``ac.render``), and
``atmoscatter.render.plan`` the function :func:`plan`; the modules are reached by
``from atmoscatter.render.plan import ...`` or ``sys.modules``.
"""

# ruff: noqa: I001  (re-exports follow the data flow, not the alphabet)
# (no ``from __future__ import annotations`` here: it would leak ``annotations``)
import sys as _sys

from .directions import *  # noqa: F403
from .models import *  # noqa: F403
from .analytic_adapters import *  # noqa: F403  (registers Preetham and the CIE skies)
from .photometry import *  # noqa: F403
from .physical_adapters import *  # noqa: F403  (registers the physical models)
from .plan import *  # noqa: F403
from .evaluate import *  # noqa: F403

#: The public names: exactly the union of the re-exported modules' ``__all__``.
_REEXPORTED = ("plan", "directions", "models", "analytic_adapters", "photometry",
               "physical_adapters", "evaluate")
__all__ = sorted({n for m in _REEXPORTED for n in _sys.modules[f"{__name__}.{m}"].__all__})

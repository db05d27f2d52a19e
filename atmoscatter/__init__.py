"""atmoscatter: sky colour and brightness from the physics of atmospheric light scattering.

The public API is flat: ``import atmoscatter as ac`` and use ``ac.<name>``.
Modules are organised by physical topic (see ``docs/architecture.md``); each
module defines ``__all__`` and is re-exported here, one line per module.
"""

# ruff: noqa: I001  (re-exports are grouped by topic, not alphabetically)
# (no ``from __future__ import annotations`` here: it would leak ``annotations`` into ``ac``)
import sys as _sys

__version__ = "0.1.0"

# --- re-exports: one line per module, grouped by topic --------------------------
# foundation
from .atmosphere import *  # noqa: F403
from .colour import *  # noqa: F403
from .geometry import *  # noqa: F403
from .optical_length import *  # noqa: F403
from .phase import *  # noqa: F403
from .presets import *  # noqa: F403
from .profiles import *  # noqa: F403
from .scattering import *  # noqa: F403
from .solar import *  # noqa: F403
from .standard_atmosphere import *  # noqa: F403
# sun
from .sun import *  # noqa: F403
# analytic skies
from .sky.aerial import *  # noqa: F403
from .sky.cie import *  # noqa: F403
from .sky.cie_standard import *  # noqa: F403
from .sky.perez_all_weather import *  # noqa: F403
from .sky.perez import *  # noqa: F403
from .sky.preetham import *  # noqa: F403
# numerical scattering
from .sky.single import *  # noqa: F403
from .sky.multiple import *  # noqa: F403
# scenes, rendering, files, CLI
from .scene import *  # noqa: F403
from .render import *  # noqa: F403
from .exr import *  # noqa: F403
from .preview import *  # noqa: F403
from .batch import *  # noqa: F403
# oracle toolkit
from .integrals import *  # noqa: F403
from .compare import *  # noqa: F403

#: The public names: exactly the union of the re-exported modules' ``__all__``.
_REEXPORTED = ("atmosphere", "colour", "geometry", "optical_length", "phase", "presets",
               "profiles", "scattering", "solar", "standard_atmosphere", "sun", "sky.aerial",
               "sky.cie", "sky.cie_standard", "sky.perez_all_weather", "sky.perez",
               "sky.preetham", "sky.single", "sky.multiple", "scene", "render.plan",
               "render.directions", "render.dome", "render.models", "render.analytic_adapters",
               "render.photometry", "render.physical_adapters", "render.evaluate",
               "render.sun_disc", "render.image", "exr", "preview", "batch", "integrals", "compare")
__all__ = sorted({n for m in _REEXPORTED for n in _sys.modules[f"{__name__}.{m}"].__all__})

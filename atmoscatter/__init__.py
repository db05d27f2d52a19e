"""atmoscatter: sky colour and brightness from the physics of atmospheric light scattering.

The public API is flat: ``import atmoscatter as ac`` and use ``ac.<name>``.
Modules are organised by physical topic (see ``docs/architecture.md``); each
module defines ``__all__`` and is re-exported here, one line per module.
"""

from __future__ import annotations

__version__ = "0.1.0"

# --- re-exports: one line per module (keep sorted within groups) -------------
# foundation
from .atmosphere import *  # noqa: F403
from .colour import *  # noqa: F403
from .geometry import *  # noqa: F403
from .optical_length import *  # noqa: F403
from .phase import *  # noqa: F403
from .presets import *  # noqa: F403
from .scattering import *  # noqa: F403

# sun
# analytic skies
# numerical scattering
from .sky.multiple import *  # noqa: F403
from .sky.single import *  # noqa: F403
from .solar import *  # noqa: F403
from .standard_atmosphere import *  # noqa: F403
# scenes, rendering, files, CLI
# oracle toolkit

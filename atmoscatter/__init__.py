"""atmoscatter: sky colour and brightness from the physics of atmospheric light scattering.

The public API is flat: ``import atmoscatter as ac`` and use ``ac.<name>``.
Modules are organised by physical topic (see ``docs/architecture.md``).
"""

from __future__ import annotations

__version__ = "0.1.0"

__all__ = ["__version__"]

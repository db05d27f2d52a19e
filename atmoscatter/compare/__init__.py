"""Use atmoscatter as a reference oracle (being split into modules; see ``stats``)."""

from .stats import *  # noqa: F403
from .stats import (  # noqa: F401  (module-level constants, importable as before)
    DELTA_E_MAP_RANGE,
    ERROR_MAP_RANGE,
    FLIPS,
    LAYOUTS,
    MIDDLE_GREY,
    REGIONS,
    __all__,
)

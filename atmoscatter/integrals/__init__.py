"""Sky integrals for lighting and daylighting (being split into modules; see ``harmonics``)."""

from .harmonics import *  # noqa: F403
from .harmonics import DEFAULT_N_THETA, QUADRATURE_DOMAINS, __all__  # noqa: F401

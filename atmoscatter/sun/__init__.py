"""Sun position, sunrise/sunset/solar noon and the solar geometry the sky models need."""

from .position import *  # noqa: F403
from .position import __all__  # noqa: F401

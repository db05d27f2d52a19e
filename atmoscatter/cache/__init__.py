"""Persistent on-disk cache of precomputed arrays (being split into modules; see ``storage``)."""

from .storage import *  # noqa: F403
from .storage import ENV_DIR, ENV_MAX_BYTES, __all__  # noqa: F401

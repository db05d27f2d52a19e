"""Shared test configuration.

Hypothesis: under CI (``CI`` set) examples are derandomised, so a run is reproducible and a
failure seen once is seen again; locally the default random exploration keeps finding new
cases.  No deadline anywhere: the machines are shared and timing is not what is tested.
"""

from __future__ import annotations

import os

from hypothesis import settings

settings.register_profile("ci", derandomize=True, deadline=None, print_blob=True)
settings.register_profile("dev", deadline=None, print_blob=True)
settings.load_profile("ci" if os.environ.get("CI") else "dev")

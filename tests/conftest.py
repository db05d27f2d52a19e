"""Shared test configuration.

Hypothesis: under CI (``CI`` set) examples are derandomised, so a run is reproducible and a
failure seen once is seen again; locally the default random exploration keeps finding new
cases.  No deadline anywhere: the machines are shared and timing is not what is tested.
"""

from __future__ import annotations

import atexit
import os
import shutil
import tempfile

import numpy as np
import pytest
from hypothesis import settings

from atmoscatter.render import ModelAdapter, register_model, unregister_model

# Hermetic cache: the whole session (and every subprocess, notebook kernel or Dask worker it
# starts, which inherit the environment) uses a fresh, empty cache directory instead of the
# user's ~/.cache/atmoscatter, so no test can pass or fail because of fields left by an
# earlier run or another checkout.  Set when conftest is imported, i.e. before any test
# module (the cache reads the variable at every call).
# EXCEPT: tests that check the caching itself (tests/test_cache.py, test_table_cache.py)
# point ATMOSCATTER_CACHE_DIR at their own tmp_path (fixture cache_root below).
_SESSION_CACHE = tempfile.mkdtemp(prefix="atmoscatter-test-cache-")
os.environ["ATMOSCATTER_CACHE_DIR"] = _SESSION_CACHE
atexit.register(shutil.rmtree, _SESSION_CACHE, ignore_errors=True)


@pytest.fixture
def cache_root(tmp_path, monkeypatch):
    """A cache directory of the test's own (tests of the caching itself), default size cap."""
    root = tmp_path / "cache"
    monkeypatch.setenv("ATMOSCATTER_CACHE_DIR", str(root))
    monkeypatch.delenv("ATMOSCATTER_CACHE_MAX_BYTES", raising=False)
    return root


settings.register_profile("ci", derandomize=True, deadline=None, print_blob=True)
settings.register_profile("dev", deadline=None, print_blob=True)
settings.load_profile("ci" if os.environ.get("CI") else "dev")


def _toy_prepare(scene, plan):
    # a cheap, smooth, sun-dependent sky; the turbidity term tells scenes apart in batch tests
    sun = plan.sun_direction
    t = scene.turbidity

    def evaluate(d):
        y = 1000.0 * t + 3000.0 * (d @ sun) ** 2 + 1000.0 * d[:, 2]
        return {"Y": y} if plan.quantity == "Y" else {"XYZ": np.stack([0.9 * y, y, 1.2 * y], -1)}

    return evaluate


@pytest.fixture
def toy_model():
    """Register the model ``toy`` (used by the scene/EXR/CLI/batch machinery tests)."""
    register_model(ModelAdapter(name="toy", description="toy sky", prepare=_toy_prepare,
                                error_estimate="exact (toy)"), replace=True)
    yield
    unregister_model("toy")

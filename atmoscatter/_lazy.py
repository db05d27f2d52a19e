"""First-use import of the compiled (numba) kernel modules (private).

``import atmoscatter`` must not import numba (about 0.2 s, with its LLVM bindings): every
module with compiled kernels keeps them in a private ``_*_kernels`` module that is imported
here on first use — and compiled, or loaded from numba's on-disk cache.  Without numba
(it is a declared dependency, so only in a broken environment) the callers fall back to
their NumPy implementations.
"""

from __future__ import annotations

import importlib
from functools import cache
from types import ModuleType

__all__: list[str] = []


@cache
def kernels(module: str) -> ModuleType | None:
    """The kernel module ``module`` (absolute name), or ``None`` if numba is missing."""
    try:
        return importlib.import_module(module)
    except ImportError:  # pragma: no cover - numba is a declared dependency
        return None

"""Compiled kernel of :mod:`atmoscatter.render.directions` (private; imported on first use, so that
``import atmoscatter`` does not import numba)."""

import numba


@numba.njit(cache=True, nogil=True)
def _first_non_unit_numba(d, tol):  # pragma: no cover - compiled
    for i in range(d.shape[0]):
        n2 = d[i, 0] * d[i, 0] + d[i, 1] * d[i, 1] + d[i, 2] * d[i, 2]
        if not abs(n2 - 1.0) <= tol:
            return i
    return -1

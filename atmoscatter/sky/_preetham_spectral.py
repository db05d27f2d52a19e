"""CIE D-series reconstruction of spectra from chromaticity for the Preetham sky (private).

The daylight basis ``S_0, S_1, S_2`` on a wavelength grid with its tristimulus values, and the
coefficients ``M_1, M_2`` of a chromaticity (published formulas or solved exactly), used by
:func:`atmoscatter.sky.preetham.preetham_sky_spectral`.
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np

from ..colour import spectral_to_XYZ

#: Default wavelengths of :func:`preetham_sky_spectral`: 380–780 nm every 5 nm. [nm]
DEFAULT_WAVELENGTHS = np.arange(380.0, 781.0, 5.0)
_M_METHODS = ("published", "exact")


@lru_cache(maxsize=8)
def _daylight_basis(wavelengths: tuple[float, ...]) -> tuple[np.ndarray, np.ndarray]:
    """S0, S1, S2 on ``wavelengths`` (n, 3) and their tristimulus values (3 XYZ, 3 bases).

    The basis comes from colour-science (CIE 15:2004 Table T.2, 5 nm, linearly interpolated
    as CIE recommends); the XYZ of each basis vector uses the same integration as
    :func:`atmoscatter.colour.spectral_to_XYZ`, so luminance scaling round-trips exactly.
    """
    from colour.colorimetry import SDS_BASIS_FUNCTIONS_CIE_ILLUMINANT_D_SERIES as basis

    wl = np.asarray(wavelengths)
    cols = []
    for name in ("S0", "S1", "S2"):
        sd = basis[name]
        cols.append(np.interp(wl, sd.wavelengths, sd.values))
    S = np.stack(cols, axis=-1)
    XYZ = np.asarray(spectral_to_XYZ(S.T, wl), dtype=np.float64)  # (3 bases, 3 XYZ)
    return S, np.ascontiguousarray(XYZ.T)  # XYZ columns = bases


def _daylight_M(x, y, method, basis_XYZ):
    """M1, M2 of the D-series reconstruction for chromaticity (x, y)."""
    if method == "published":
        # Wyszecki & Stiles (1982) / CIE 15; seed 004 "Preetham et al spectral radiance model".
        den = 0.0241 + 0.2562 * x - 0.7341 * y
        M1 = (-1.3515 - 1.7703 * x + 5.9114 * y) / den
        M2 = (0.0300 - 31.4424 * x + 30.0717 * y) / den
        return M1, M2
    # "exact": solve X - x(X+Y+Z) = 0, Y - y(X+Y+Z) = 0 for (M1, M2) with the tristimulus
    # values of S0, S1, S2 on the wavelength grid in use (linear in M1, M2).
    X, Y, Z = basis_XYZ  # each (3,) over bases S0, S1, S2
    Ssum = X + Y + Z
    a = X[None, :] - x[:, None] * Ssum[None, :]  # (n, 3)
    b = Y[None, :] - y[:, None] * Ssum[None, :]
    det = a[:, 1] * b[:, 2] - a[:, 2] * b[:, 1]
    M1 = (-a[:, 0] * b[:, 2] + a[:, 2] * b[:, 0]) / det
    M2 = (-a[:, 1] * b[:, 0] + a[:, 0] * b[:, 1]) / det
    return M1, M2

"""The published fit of the Preetham (1999) sky and its validity policy (private).

The coefficient tables of Preetham et al. (1999), Appendix A.2 (errata 003.3), the two
formulas evaluated from them (Perez coefficients ``[A, B, C, D, E] = a·T + b`` and the zenith
values ``Y_z, x_z, y_z``) and the turbidity policy of errata 003.4 (see the validity policy
of :mod:`atmoscatter.sky.preetham`, which re-exports the public names).
"""

from __future__ import annotations

import warnings

import numpy as np

from .._validate import as_float_array, check_option

#: Perez coefficients of the Preetham model: ``[A, B, C, D, E] = M[k] @ [T, 1]`` for
#: k = Y, x, y (rows), shape (3, 5, 2). Preetham et al. (1999), Appendix A.2; errata 003.3.
PREETHAM_DISTRIBUTION_MATRIX: np.ndarray = np.array(
    [
        [[0.1787, -1.4630], [-0.3554, 0.4275], [-0.0227, 5.3251], [0.1206, -2.5771],
         [-0.0670, 0.3703]],
        [[-0.0193, -0.2592], [-0.0665, 0.0008], [-0.0004, 0.2125], [-0.0641, -0.8989],
         [-0.0033, 0.0452]],
        [[-0.0167, -0.2608], [-0.0950, 0.0092], [-0.0079, 0.2102], [-0.0441, -1.6537],
         [-0.0109, 0.0529]],
    ]
)  # fmt: skip
PREETHAM_DISTRIBUTION_MATRIX.flags.writeable = False

#: Zenith chromaticity matrices ``(M_x, M_y)``, shape (2, 3, 4):
#: ``x_z = [T², T, 1] · M_x · [θ_s³, θ_s², θ_s, 1]ᵀ`` with θ_s in radians.
#: Preetham et al. (1999), Appendix A.2; errata 003.3.
PREETHAM_ZENITH_CHROMATICITY_MATRICES: np.ndarray = np.array(
    [
        [[0.00166, -0.00375, 0.00209, 0.0],
         [-0.02903, 0.06377, -0.03202, 0.00394],
         [0.11693, -0.21196, 0.06052, 0.25886]],
        [[0.00275, -0.00610, 0.00317, 0.0],
         [-0.04214, 0.08970, -0.04153, 0.00516],
         [0.15346, -0.26756, 0.06670, 0.26688]],
    ]
)  # fmt: skip
PREETHAM_ZENITH_CHROMATICITY_MATRICES.flags.writeable = False

#: Turbidity range of the fit (Preetham et al. 1999; errata 003.4). [1]
PREETHAM_TURBIDITY_RANGE: tuple[float, float] = (2.0, 10.0)

#: Chromaticity reported for black (zero luminance): CIE D65, 2° observer (as colour-science).
_BLACK_xy = (0.3127, 0.3290)

_OUT_OF_RANGE_POLICIES = ("warn", "raise")



class PreethamValidityWarning(UserWarning):
    """The Preetham model left its fitted domain: turbidity clamped into [2, 10], or negative
    spectral values from the D-series reconstruction (see :func:`preetham_sky_spectral`)."""


# ----------------------------------------------------------------------------------------------
# building blocks
# ----------------------------------------------------------------------------------------------
def _turbidity(turbidity, out_of_range: str, *, scalar: bool = False) -> np.ndarray:
    """Apply the validity policy to ``turbidity``; returns the (clamped) float64 array."""
    check_option(out_of_range, "out_of_range", _OUT_OF_RANGE_POLICIES)
    if type(turbidity) in (float, int) and 2.0 <= turbidity <= 10.0:  # fast path, in range
        return np.float64(turbidity)
    T = as_float_array(turbidity, "turbidity").astype(np.float64)
    if scalar and T.ndim != 0:
        raise ValueError(
            f"turbidity must be a scalar for direction-based Preetham skies, got shape {T.shape}"
        )
    bad = ~np.isfinite(T) | (T < 1.0)
    if np.any(bad):
        value = T[bad].ravel()[0] if T.ndim else T.item()
        raise ValueError(
            f"turbidity must be finite and >= 1 (T = (tau_m + tau_h)/tau_m), got {value!r}"
        )
    lo, hi = PREETHAM_TURBIDITY_RANGE
    outside = (T < lo) | (T > hi)
    if np.any(outside):
        value = T[outside].ravel()[0] if T.ndim else T.item()
        if out_of_range == "raise":
            raise ValueError(
                f"turbidity must be in [{lo}, {hi}] (range of the Preetham fit), got {value!r}"
            )
        warnings.warn(
            f"turbidity {value!r} is outside the Preetham fit's range [{lo}, {hi}]; "
            f"evaluating at the clamped turbidity {min(max(value, lo), hi)!r}",
            PreethamValidityWarning,
            stacklevel=4,
        )
        T = np.clip(T, lo, hi)
    return T


def _coefficients(T: np.ndarray) -> np.ndarray:
    M = PREETHAM_DISTRIBUTION_MATRIX
    return M[..., 0] * T[..., None, None] + M[..., 1]


def _zenith(T: np.ndarray, sun_zenith: np.ndarray) -> np.ndarray:
    """Y_z [cd m⁻²], x_z, y_z on the last axis for sun zenith in [0, π/2] (no checks)."""
    chi = (4.0 / 9.0 - T / 120.0) * (np.pi - 2.0 * sun_zenith)
    Yz = ((4.0453 * T - 4.9710) * np.tan(chi) - 0.2155 * T + 2.4192) * 1000.0
    t_pow = np.stack([T * T, T, np.ones_like(T)], axis=-1)
    s_pow = np.stack(
        [sun_zenith**3, sun_zenith**2, sun_zenith, np.ones_like(sun_zenith)], axis=-1
    )
    M = PREETHAM_ZENITH_CHROMATICITY_MATRICES
    xz = np.einsum("...i,ij,...j->...", t_pow, M[0], s_pow)
    yz = np.einsum("...i,ij,...j->...", t_pow, M[1], s_pow)
    return np.stack(np.broadcast_arrays(Yz, xz, yz), axis=-1)

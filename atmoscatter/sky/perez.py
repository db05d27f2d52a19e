"""The Perez all-weather sky distribution function.

Public objects
--------------
perez
    ``F(θ, γ) = (1 + A e^{B / cos θ}) (1 + C e^{D γ} + E cos² γ)``.

References
----------
Perez, R., Seals, R. & Michalsky, J. (1993). All-weather model for sky luminance
distribution — preliminary configuration and validation. *Solar Energy* 50(3), 235–245.
Seed 003 (Kolivand & Sunar), §5, and seed 004 (Preetham, course notes), "Perez all
weather luminance model".
"""

from __future__ import annotations

import numpy as np

from .._validate import as_float_array

__all__ = ["perez"]

#: ``e^{-745}`` is below the smallest subnormal float64, so an exponent argument clipped at
#: -745 gives exactly the limiting value 0 (for float32 the cut-off is even earlier).
_EXP_UNDERFLOW = 745.0


def _horizon_term(cos_theta: np.ndarray, B: np.ndarray) -> np.ndarray:
    """``exp(B / cos θ)`` for ``B <= 0`` and ``cos θ`` clamped to ``[0, 1]``, without warnings.

    The denominator is bounded below by ``-B/745 + tiny`` so that the quotient never falls
    below -745 (where ``exp`` is already exactly 0) and never divides by zero; ``B = 0``
    gives exactly 1 (the limit), ``cos θ = 0`` with ``B < 0`` gives 0 (the limit).
    """
    dtype = np.result_type(cos_theta, B)
    tiny = np.finfo(dtype).tiny
    c = np.clip(cos_theta, 0.0, 1.0)
    den = np.maximum(c, -B * (1.0 / _EXP_UNDERFLOW) + tiny)
    return np.exp(B / den)


def perez(theta, gamma, A, B, C, D, E):
    r"""Perez all-weather distribution function ``F(θ, γ)``.

    .. math::

        F(\theta, \gamma) = \left(1 + A\, e^{B/\cos\theta}\right)
                            \left(1 + C\, e^{D\gamma} + E \cos^2\gamma\right)

    (seed 003 §5; seed 004 "Perez all weather luminance model"; Perez et al. 1993).

    Parameters
    ----------
    theta : array_like
        Zenith angle of the view direction. [rad]
    gamma : array_like
        Angle between the view direction and the direction toward the sun. [rad]
    A, B, C, D, E : array_like
        Distribution coefficients (horizon darkening/brightening, horizon gradient,
        circumsolar intensity, circumsolar width, backscatter). All inputs broadcast. [1]

    Returns
    -------
    numpy.ndarray or float
        ``F(θ, γ)``, the broadcast shape of the inputs. [1]

    Raises
    ------
    ValueError
        If any ``B > 0``: the horizon term ``e^{B/cos θ}`` then diverges as θ → 90°, so the
        function has no finite horizon value.

    Notes
    -----
    Defined behaviour at and below the horizon: ``cos θ`` is clamped to ``[0, 1]``, so any
    ``θ >= π/2`` gives the horizon limit ``θ → 90°⁻``, where ``e^{B/cos θ} → 0`` for
    ``B < 0`` (and 1 for ``B = 0``). The quotient ``B/cos θ`` is bounded below by -745,
    below which ``exp`` is exactly zero, so no division-by-zero or overflow warning can
    occur. NaN inputs give NaN. The result has the precision of the inputs (float32 in,
    float32 out when every input is float32).
    """
    theta = as_float_array(theta, "theta")
    gamma = as_float_array(gamma, "gamma")
    A, B, C, D, E = (as_float_array(v, n) for v, n in zip((A, B, C, D, E), "ABCDE", strict=True))
    if np.any(B > 0):
        bad = np.asarray(B)[np.asarray(B) > 0].ravel()[0]
        raise ValueError(
            f"B must be <= 0 (the horizon term e^(B/cos(theta)) diverges at the horizon "
            f"for B > 0), got {bad!r}"
        )
    cos_theta = np.cos(theta)
    cos_gamma = np.cos(gamma)
    result = (1.0 + A * _horizon_term(cos_theta, B)) * (
        1.0 + C * np.exp(D * gamma) + E * cos_gamma * cos_gamma
    )
    if result.ndim == 0:
        return result[()]
    return result

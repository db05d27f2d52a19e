"""Scattering phase functions.

Public objects
--------------
- :func:`rayleigh_phase`, :func:`henyey_greenstein_phase`, :func:`cornette_shanks_phase`,
  :func:`isotropic_phase`: phase functions of the scattering-angle cosine [sr⁻¹].
- :class:`RayleighPhase`, :class:`HenyeyGreensteinPhase`, :class:`CornetteShanksPhase`,
  :class:`IsotropicPhase`: frozen, callable parameter objects used by
  :class:`atmoscatter.Constituent`.

Convention: ``cos_theta`` is the cosine of the angle between the view direction (from the
observer outward) and the direction *toward* the sun, so ``g > 0`` is forward scattering
(the bright aureole around the sun), errata 000.2.  Every phase function is normalised so
that its integral over the sphere is 1.

References
----------
- Hoffman & Preetham (2002), seed 000; Preetham (seed 004): Rayleigh ``3/(16π)(1 + cos²θ)``.
- Henyey, L. G. & Greenstein, J. L. (1941). Diffuse radiation in the galaxy. ApJ 93, 70–83
  (seeds 000/002/004; numerator corrected per errata 000.1).
- Cornette, W. M. & Shanks, J. G. (1992). Physically reasonable analytic expression for the
  single-scattering phase function. Applied Optics 31(16), 3152–3160.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ._validate import as_float_array, check_range, clamp_cosine

__all__ = [
    "rayleigh_phase",
    "henyey_greenstein_phase",
    "cornette_shanks_phase",
    "isotropic_phase",
    "RayleighPhase",
    "HenyeyGreensteinPhase",
    "CornetteShanksPhase",
    "IsotropicPhase",
]

_INV_4PI = 1.0 / (4.0 * np.pi)


def _cos(cos_theta) -> np.ndarray:
    """Validate and clamp a cosine array.

    Values within a few ulp outside [−1, 1] (rounding in dot products) are clamped;
    NaN propagates element-wise.  Values clearly outside (by more than 1e-6) raise.
    """
    mu = as_float_array(cos_theta, "cos_theta")
    with np.errstate(invalid="ignore"):
        if np.any(np.abs(mu) > 1.0 + 1e-6):
            bad = mu[np.abs(mu) > 1.0 + 1e-6].flat[0]
            raise ValueError(f"cos_theta must be in [-1, 1], got {bad!r}")
    return clamp_cosine(mu)


def _check_g(g) -> np.ndarray:
    g = as_float_array(g, "g")
    return check_range(g, "g", -1.0, 1.0, low_inclusive=False, high_inclusive=False)


def _out_dtype(mu: np.ndarray, g_raw):
    """Result precision: that of ``cos_theta`` (float32 in → float32 out); a ``g`` array
    (not a scalar parameter) takes part in the promotion."""
    gd = np.asarray(g_raw).dtype if np.ndim(g_raw) > 0 else np.float32
    return np.result_type(mu.dtype, gd, np.float32)


def _finish(value, dtype):
    out = np.asarray(value).astype(dtype, copy=False)
    return out[()] if out.ndim == 0 else out


def _hg_denominator(mu, g):
    # 1 + g² − 2gμ written as (1 − g)² + 2g(1 − μ): no cancellation when g → 1 and μ → 1
    # (forward peak) nor when g → −1 and μ → −1 (written symmetrically below).
    return np.where(g >= 0, (1.0 - g) ** 2 + 2.0 * g * (1.0 - mu), (1.0 + g) ** 2 - 2.0 * g * (1.0 + mu))


def rayleigh_phase(cos_theta):
    r"""Rayleigh phase function :math:`p(\theta) = \frac{3}{16\pi}(1 + \cos^2\theta)`.

    Parameters
    ----------
    cos_theta : array_like
        Cosine of the scattering angle (view direction vs. direction to the sun) [-].
        Values a few ulp outside [−1, 1] are clamped.

    Returns
    -------
    ndarray or float
        Phase function value [sr⁻¹]; integrates to 1 over the sphere.

    Notes
    -----
    Seed 000 (angular scattering coefficient of air), seed 004.  Exact for Rayleigh
    scattering by isotropic molecules; the depolarisation correction to the angular shape
    (≈1 %) is neglected, as in the seeds.

    Examples
    --------
    >>> round(float(rayleigh_phase(1.0)), 6)
    0.119366
    """
    mu = _cos(cos_theta)
    return (3.0 / (16.0 * np.pi)) * (1.0 + mu * mu)


def isotropic_phase(cos_theta):
    """Isotropic phase function ``1/(4π)`` [sr⁻¹], broadcast to the shape of ``cos_theta``.

    Parameters
    ----------
    cos_theta : array_like
        Cosine of the scattering angle [-] (only its shape is used).

    Returns
    -------
    ndarray
        ``1/(4π)`` [sr⁻¹] in the shape of ``cos_theta``.
    """
    mu = _cos(cos_theta)
    # NaN propagates element-wise like the other phase functions
    return np.where(np.isnan(mu), mu, np.asarray(_INV_4PI, dtype=mu.dtype))[()]


def henyey_greenstein_phase(cos_theta, g):
    r"""Henyey–Greenstein phase function.

    .. math:: p(\theta) = \frac{1 - g^2}{4\pi\,(1 + g^2 - 2g\cos\theta)^{3/2}}

    Parameters
    ----------
    cos_theta : array_like
        Cosine of the scattering angle [-].
    g : array_like
        Asymmetry parameter (mean cosine) [-], ``-1 < g < 1``; ``g > 0`` scatters forward.

    Returns
    -------
    ndarray or float
        Phase function value [sr⁻¹], computed in float64 and returned in the precision of
        ``cos_theta`` (float32 in → float32 out).

    Raises
    ------
    ValueError
        If ``|g| >= 1`` (the function degenerates to a delta) or ``g`` is not finite.

    Notes
    -----
    Seeds 000 (numerator corrected per errata 000.1), 002, 004.  The denominator is
    evaluated as ``(1 − g)² + 2g(1 − cos θ)`` (and the mirrored form for ``g < 0``) so the
    forward peak stays accurate as ``g → ±1``; normalisation holds to 1e-10 (adaptive quadrature) for
    ``|g| ≤ 0.999``.

    Examples
    --------
    >>> round(float(henyey_greenstein_phase(0.0, 0.0) * 4 * np.pi), 12)
    1.0
    """
    mu = _cos(cos_theta)
    dtype = _out_dtype(mu, g)
    mu64, g = mu.astype(np.float64), _check_g(g).astype(np.float64)
    return _finish((1.0 - g) * (1.0 + g) * _INV_4PI / _hg_denominator(mu64, g) ** 1.5, dtype)


def cornette_shanks_phase(cos_theta, g):
    r"""Cornette–Shanks (1992) phase function.

    .. math:: p(\theta) = \frac{3}{8\pi}\,\frac{(1 - g^2)(1 + \cos^2\theta)}
              {(2 + g^2)(1 + g^2 - 2g\cos\theta)^{3/2}}

    A Henyey–Greenstein lobe multiplied by the Rayleigh factor ``1 + cos²θ`` and
    renormalised: it tends to the Rayleigh phase as ``g → 0`` and gives a more realistic
    backscatter for aerosols (used for Mie scattering by Bruneton & Neyret 2008).

    Parameters
    ----------
    cos_theta : array_like
        Cosine of the scattering angle [-].
    g : array_like
        Shape parameter [-], ``-1 < g < 1``.  Note: the mean cosine of this function is
        not ``g`` (see :attr:`CornetteShanksPhase.asymmetry`).

    Returns
    -------
    ndarray or float
        Phase function value [sr⁻¹]; integrates to 1 over the sphere (to 1e-10).  Computed
        in float64, returned in the precision of ``cos_theta``.

    Raises
    ------
    ValueError
        If ``|g| >= 1``.
    """
    mu = _cos(cos_theta)
    dtype = _out_dtype(mu, g)
    mu, g = mu.astype(np.float64), _check_g(g).astype(np.float64)
    return _finish(
        (3.0 / (8.0 * np.pi))
        * (1.0 - g)
        * (1.0 + g)
        * (1.0 + mu * mu)
        / ((2.0 + g * g) * _hg_denominator(mu, g) ** 1.5),
        dtype,
    )


def _cs_asymmetry(g: float) -> float:
    # Mean cosine of the Cornette–Shanks function, closed form:
    # <μ> = 3g(4 + g²) / (5(2 + g²))   (Cornette & Shanks 1992, Eq. 12).
    return 3.0 * g * (4.0 + g * g) / (5.0 * (2.0 + g * g))


@dataclass(frozen=True)
class RayleighPhase:
    """Rayleigh phase function as a parameter object (see :func:`rayleigh_phase`)."""

    def __call__(self, cos_theta):
        return rayleigh_phase(cos_theta)

    @property
    def asymmetry(self) -> float:
        """Mean cosine of the scattering angle [-] (0 for Rayleigh)."""
        return 0.0


@dataclass(frozen=True)
class IsotropicPhase:
    """Isotropic phase function as a parameter object (see :func:`isotropic_phase`)."""

    def __call__(self, cos_theta):
        return isotropic_phase(cos_theta)

    @property
    def asymmetry(self) -> float:
        """Mean cosine of the scattering angle [-] (0)."""
        return 0.0


@dataclass(frozen=True)
class HenyeyGreensteinPhase:
    """Henyey–Greenstein phase function with asymmetry ``g`` (see :func:`henyey_greenstein_phase`).

    Parameters
    ----------
    g : float
        Asymmetry parameter [-], ``-1 < g < 1``; default 0.8 (Bruneton 2017 Earth aerosols).
    """

    g: float = 0.8

    def __post_init__(self):
        _check_g(self.g)
        object.__setattr__(self, "g", float(self.g))

    def __call__(self, cos_theta):
        return henyey_greenstein_phase(cos_theta, self.g)

    @property
    def asymmetry(self) -> float:
        """Mean cosine of the scattering angle [-] (equal to ``g``)."""
        return self.g


@dataclass(frozen=True)
class CornetteShanksPhase:
    """Cornette–Shanks phase function with parameter ``g`` (see :func:`cornette_shanks_phase`).

    Parameters
    ----------
    g : float
        Shape parameter [-], in (−1, 1); g > 0 scatters forward (its mean cosine is
        :attr:`asymmetry`, not ``g``).
    """

    g: float = 0.8

    def __post_init__(self):
        _check_g(self.g)
        object.__setattr__(self, "g", float(self.g))

    def __call__(self, cos_theta):
        return cornette_shanks_phase(cos_theta, self.g)

    @property
    def asymmetry(self) -> float:
        """Mean cosine of the scattering angle [-], ``3g(4 + g²)/(5(2 + g²))``."""
        return _cs_asymmetry(self.g)

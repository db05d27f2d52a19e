"""CIE overcast and CIE clear-sky luminance distributions (seed 004).

Public objects
--------------
cie_overcast_luminance, cie_overcast_sky
    Moon & Spencer (1942) overcast sky, adopted by the CIE (1955; CIE S 011 / ISO 15469
    standard overcast sky): ``Y = Y_z (1 + 2 cos θ)/3``.
cie_clear_sky_luminance, cie_clear_sky
    Kittler's clear sky, CIE (1973) standard clear sky (CIE 110-1994):
    ``Y = Y_z f(γ) φ(θ) / (f(θ_s) φ(0))`` with ``f(γ) = 0.91 + 10 e^{−3γ} + 0.45 cos²γ`` and
    ``φ(θ) = 1 − e^{−0.32/cos θ}``.
cie_zenith_luminance, CIE_ZENITH_LUMINANCE_METHODS
    Absolute zenith luminance the relative distributions are scaled by (``method=``).
cie_overcast_zenith_luminance_from_illuminance
    The exact relation ``Y_z = 9 E_h / (7π)`` between the overcast zenith luminance and the
    horizontal illuminance it produces.

Zenith luminance (the scaling)
------------------------------
The CIE distributions are *relative* (seed 004: "The CIE luminance models provide us with
relative luminance and not absolute luminance"); every function here takes the zenith
luminance ``Y_z`` [cd m⁻²] explicitly. :func:`cie_zenith_luminance` offers cited choices:

* ``"krochmann"`` (overcast): ``Y_z = 123 + 8600 sin h`` [cd m⁻²], h the solar altitude —
  Krochmann, J. (1963), "Über die Horizontalbeleuchtungsstärke der Tagesbeleuchtung",
  *Lichttechnik* 15, 559–562; the formula behind the overcast zenith brightness of
  Radiance's ``gensky`` (``8.6 sin h + 0.123`` kcd m⁻²).
* ``"preetham"`` (clear): the zenith luminance of Preetham et al. (1999), Appendix A.2
  (errata 003.3), a function of turbidity and sun zenith (fit range T = 2–10).

The ASRC–CIE blend (seed 004, [Littlefair1994]; Perez, Michalsky & Seals 1992) is **not
implemented**: its weights of the four component skies are fitted functions of the sky
clearness ε and brightness Δ whose coefficients are not in the seeds or the errata, and we
could not obtain them from a citable primary source; the component skies it also needs (the
high-turbidity clear sky and Nakamura's intermediate sky) have the same problem.

Behaviour at the edges: view directions at or below the horizon take the horizon value
(``cos θ`` clamped to 0; for the clear sky ``φ → 1`` as ``cos θ → 0⁺``). A sun below the
horizon gives zero luminance for the clear sky (as for the Preetham sky); the overcast
distribution does not depend on the sun (its zenith luminance does: Krochmann's formula is
used for ``h ≥ 0`` and gives 0 below the horizon).
"""

from __future__ import annotations

import math

import numpy as np

from .._validate import as_float_array, check_option, check_positive
from . import _hemisphere
from ._preetham_eval import _sun, _views
from .perez import _horizon_term
from .preetham import preetham_zenith

__all__ = [
    "CIE_ZENITH_LUMINANCE_METHODS",
    "cie_overcast_luminance",
    "cie_overcast_sky",
    "cie_clear_sky_luminance",
    "cie_clear_sky",
    "cie_zenith_luminance",
    "cie_overcast_zenith_luminance_from_illuminance",
]


def _zenith_luminance_value(zenith_luminance):
    return check_positive(zenith_luminance, "zenith_luminance", allow_zero=True, unit="cd m^-2")


def cie_overcast_luminance(view_zenith, zenith_luminance):
    """CIE standard overcast sky luminance ``Y = Y_z (1 + 2 cos θ)/3`` (seed 004).

    Parameters
    ----------
    view_zenith : array_like
        Zenith angle θ of the view direction; θ ≥ π/2 gives the horizon value ``Y_z/3``. [rad]
    zenith_luminance : array_like
        Zenith luminance ``Y_z`` ≥ 0, broadcast against ``view_zenith`` (see
        :func:`cie_zenith_luminance`). [cd m⁻²]

    Returns
    -------
    numpy.ndarray or float
        Luminance [cd m⁻²]. The horizon is 1/3 as bright as the zenith (Moon & Spencer 1942).
    """
    theta = as_float_array(view_zenith, "view_zenith")
    Yz = _zenith_luminance_value(zenith_luminance)
    c = np.clip(np.cos(theta), 0.0, 1.0)
    out = Yz * (1.0 + 2.0 * c) / 3.0
    return out[()] if out.ndim == 0 else out


def _clear_indicatrix(gamma, cos_gamma):
    """Kittler's scattering indicatrix ``f(γ) = 0.91 + 10 e^{−3γ} + 0.45 cos²γ``."""
    return 0.91 + 10.0 * np.exp(-3.0 * gamma) + 0.45 * cos_gamma * cos_gamma


def _clear_gradation(cos_theta):
    """Gradation ``φ(θ) = 1 − e^{−0.32/cos θ}``, with the horizon limit 1 for cos θ ≤ 0."""
    return 1.0 - _horizon_term(cos_theta, np.asarray(-0.32, dtype=np.result_type(cos_theta, 1.0)))


_PHI_ZENITH = 1.0 - math.exp(-0.32)


def cie_clear_sky_luminance(view_zenith, gamma, sun_zenith, zenith_luminance):
    r"""CIE standard clear-sky luminance (Kittler 1967; CIE 1973; seed 004).

    .. math::

        Y = Y_z \frac{(0.91 + 10 e^{-3\gamma} + 0.45\cos^2\gamma)(1 - e^{-0.32/\cos\theta})}
                     {(0.91 + 10 e^{-3\theta_s} + 0.45\cos^2\theta_s)(1 - e^{-0.32})}

    Parameters
    ----------
    view_zenith : array_like
        Zenith angle θ of the view direction; θ ≥ π/2 gives the horizon value. [rad]
    gamma : array_like
        Angle γ between view direction and sun. [rad]
    sun_zenith : array_like
        Solar zenith θ_s in [0, π]; above π/2 the luminance is 0. [rad]
    zenith_luminance : array_like
        Zenith luminance ``Y_z`` ≥ 0 (see :func:`cie_zenith_luminance`). [cd m⁻²]

    Returns
    -------
    numpy.ndarray or float
        Luminance [cd m⁻²], broadcast shape of the inputs; equal to ``Y_z`` at the zenith.
    """
    theta = as_float_array(view_zenith, "view_zenith")
    gamma = as_float_array(gamma, "gamma")
    ts = as_float_array(sun_zenith, "sun_zenith")
    with np.errstate(invalid="ignore"):
        if np.any((ts < 0) | (ts > np.pi)):
            raise ValueError(f"sun_zenith must be in [0, pi] rad, got {np.asarray(ts).ravel()[0]!r}")
    Yz = _zenith_luminance_value(zenith_luminance)
    num = _clear_indicatrix(gamma, np.cos(gamma)) * _clear_gradation(np.cos(theta))
    ts_c = np.minimum(ts, np.pi / 2)
    den = _clear_indicatrix(ts_c, np.cos(ts_c)) * _PHI_ZENITH
    out = np.where(ts > np.pi / 2, 0.0, Yz * num / den)
    return out[()] if out.ndim == 0 else out


def cie_overcast_sky(view_directions, zenith_luminance):
    """CIE overcast luminance for view directions (..., 3) (x = east, y = north, z = up).

    Parameters
    ----------
    view_directions : array_like
        View directions, shape (..., 3); normalised internally; NaN gives NaN.
    zenith_luminance : float
        Zenith luminance ``Y_z`` ≥ 0. [cd m⁻²]

    Returns
    -------
    numpy.ndarray
        Luminance [cd m⁻²], shape ``view_directions.shape[:-1]``; float32 in → float32 out.
    """
    v = _views(view_directions)
    Yz = float(_zenith_luminance_value(zenith_luminance))
    with np.errstate(invalid="ignore", divide="ignore"):
        c = v[..., 2] / np.sqrt(np.sum(v * v, axis=-1))
    c = np.clip(c, 0.0, 1.0)
    return (Yz * (1.0 + 2.0 * c) / 3.0).astype(v.dtype, copy=False)


def cie_clear_sky(view_directions, sun_direction, zenith_luminance):
    """CIE clear-sky luminance for view directions (..., 3) and a sun direction (3,).

    Same model as :func:`cie_clear_sky_luminance`; γ is computed as
    ``2 atan2(|v̂ − ŝ|, |v̂ + ŝ|)`` (accurate at the sun and the anti-solar point).

    Parameters
    ----------
    view_directions : array_like
        View directions, shape (..., 3), x = east, y = north, z = up; normalised internally.
    sun_direction : array_like
        Direction toward the sun, shape (3,); below the horizon the sky is dark (0).
    zenith_luminance : float
        Zenith luminance ``Y_z`` ≥ 0. [cd m⁻²]

    Returns
    -------
    numpy.ndarray
        Luminance [cd m⁻²], shape ``view_directions.shape[:-1]``; float32 in → float32 out.
    """
    v = _views(view_directions)
    sun = _sun(sun_direction)
    Yz = float(_zenith_luminance_value(zenith_luminance))
    if sun[2] < 0.0:
        return _hemisphere.dark_sky(v)
    vh, gamma = _hemisphere.unit_views_and_sun_angle(v, sun)
    out = cie_clear_sky_luminance(np.arccos(np.clip(vh[..., 2], -1, 1)), gamma, math.acos(sun[2]), Yz)
    return np.asarray(out, dtype=v.dtype)


def _krochmann(sun_zenith, turbidity):
    h_sin = np.cos(sun_zenith)
    return np.where(h_sin >= 0.0, 123.0 + 8600.0 * h_sin, 0.0)


def _preetham_zenith(sun_zenith, turbidity):
    if turbidity is None:
        raise ValueError("method='preetham' needs a turbidity (fit range 2-10)")
    return preetham_zenith(turbidity, sun_zenith)[..., 0]


#: Registry of zenith-luminance formulas for :func:`cie_zenith_luminance`.
CIE_ZENITH_LUMINANCE_METHODS = {
    "krochmann": _krochmann,  # overcast; Krochmann (1963)
    "preetham": _preetham_zenith,  # clear; Preetham et al. (1999) App. A.2
}


def cie_zenith_luminance(sun_zenith, *, method="krochmann", turbidity=None):
    """Absolute zenith luminance to scale the CIE distributions.

    Parameters
    ----------
    sun_zenith : array_like
        Solar zenith angle in [0, π]. [rad]
    method : {"krochmann", "preetham"}
        ``"krochmann"`` (overcast skies): ``123 + 8600 sin h`` cd m⁻², h = π/2 − θ_s, 0 for
        a sun below the horizon (Krochmann 1963). ``"preetham"`` (clear skies): Preetham et
        al. (1999) ``Y_z(T, θ_s)``, with that module's turbidity policy.
    turbidity : float, optional
        Needed by ``"preetham"``. [1]

    Returns
    -------
    numpy.ndarray or float
        Zenith luminance [cd m⁻²].
    """
    check_option(method, "method", CIE_ZENITH_LUMINANCE_METHODS)
    ts = as_float_array(sun_zenith, "sun_zenith")
    with np.errstate(invalid="ignore"):
        if np.any((ts < 0) | (ts > np.pi)):
            raise ValueError(f"sun_zenith must be in [0, pi] rad, got {np.asarray(ts).ravel()[0]!r}")
    out = np.asarray(CIE_ZENITH_LUMINANCE_METHODS[method](ts, turbidity))
    return out[()] if out.ndim == 0 else out


def cie_overcast_zenith_luminance_from_illuminance(horizontal_illuminance):
    """Zenith luminance of the CIE overcast sky that gives a horizontal illuminance.

    ``E_h = ∫ Y cos θ dΩ = Y_z · 2π ∫₀^{π/2} (1 + 2 cos θ)/3 · cos θ sin θ dθ = (7π/9) Y_z``,
    so ``Y_z = 9 E_h / (7π)`` (exact for the distribution; tested against quadrature).

    Parameters
    ----------
    horizontal_illuminance : array_like
        Diffuse horizontal illuminance from the sky, ≥ 0. [lx]

    Returns
    -------
    numpy.ndarray or float
        Zenith luminance [cd m⁻²].
    """
    E = check_positive(horizontal_illuminance, "horizontal_illuminance", allow_zero=True, unit="lx")
    out = 9.0 * E / (7.0 * np.pi)
    return out[()] if np.ndim(out) == 0 else out

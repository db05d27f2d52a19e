r"""Real spherical harmonics of a sky: the basis, projection, reconstruction and irradiance.

Public objects
--------------
- :func:`sh_count`, :func:`sh_index`, :func:`real_sph_harm`: the real spherical-harmonic basis.
- :func:`sh_project`, :func:`sh_evaluate`: projection of a sky onto real SH up to a given
  order and reconstruction from the coefficients.
- :func:`sh_irradiance`: irradiance from SH coefficients (convolution with the clamped
  cosine, Ramamoorthi & Hanrahan 2001) — the ambient term a renderer needs.
- :func:`clamped_cosine_sh_coefficients`: the clamped-cosine kernel's coefficients Â_l.

Spherical-harmonic convention
-----------------------------
Orthonormal real spherical harmonics, ``∫_{S²} Y_lm Y_l'm' dΩ = δ_ll' δ_mm'``:

.. math::

    Y_{l0} = N_{l0} P_l(\cos\theta), \quad
    Y_{lm} = \sqrt2 N_{lm} P_l^m(\cos\theta)\cos m\varphi, \quad
    Y_{l,-m} = \sqrt2 N_{lm} P_l^m(\cos\theta)\sin m\varphi \quad (m > 0),

with :math:`N_{lm} = \sqrt{(2l+1)/(4\pi)\,(l-m)!/(l+m)!}`, θ the zenith angle (from +z, up)
and φ = atan2(y, x) the **mathematical** azimuth, from east (+x) toward north (+y) —
not the geographic azimuth (from north toward east) used elsewhere in the package; this keeps
the usual Cartesian forms.  By default the associated Legendre functions :math:`P_l^m` carry
**no Condon–Shortley phase** (``(−1)^m``), so that

``Y_00 = 1/(2√π)``, ``Y_1,−1 = √(3/4π)·y``, ``Y_10 = √(3/4π)·z``, ``Y_11 = √(3/4π)·x``

as in Ramamoorthi & Hanrahan (2001) and most real-time graphics code.  Pass
``condon_shortley=True`` to include the phase (then ``Y_11 = −√(3/4π)·x``).  In terms of
the complex harmonics of ``scipy.special.sph_harm_y`` (which include the phase), the default
basis is ``Y_lm = √2 (−1)^m Re Y_l^m`` for m > 0 and ``√2 (−1)^m Im Y_l^|m|`` for m < 0.  Coefficients are stored flat with index
``i = l(l + 1) + m`` (``l = 0…order``, ``m = −l…l``), ``(order + 1)²`` in all, channels on
the last axis.

References
----------
- R. Ramamoorthi, P. Hanrahan, "An efficient representation for irradiance environment
  maps", SIGGRAPH 2001 (clamped-cosine coefficients Â_l).
"""

from __future__ import annotations

from collections.abc import Callable
from math import factorial, lgamma

import numpy as np

from .._validate import as_float_array, check_option, clamp_cosine
from .quadrature import DEFAULT_N_THETA, _check_count, _is_sky_image, _sample_sky

__all__ = [
    "sh_count",
    "sh_index",
    "real_sph_harm",
    "sh_project",
    "sh_evaluate",
    "sh_irradiance",
    "clamped_cosine_sh_coefficients",
]


def sh_count(order: int) -> int:
    """Number of real SH coefficients up to and including ``order``: ``(order + 1)²``.

    Parameters
    ----------
    order : int
        Highest degree l, ≥ 0.

    Returns
    -------
    int
        ``(order + 1)²``.
    """
    order = _check_count(order, "order", 0)
    return (order + 1) ** 2


def sh_index(l, m):  # noqa: E741 - l is the conventional degree symbol
    """Flat coefficient index ``l(l + 1) + m`` of degree ``l`` ≥ 0 and order ``|m| ≤ l``.

    Parameters
    ----------
    l : int or array_like of int
        Degree, ≥ 0.
    m : int or array_like of int
        Order, ``|m| ≤ l``.

    Returns
    -------
    int or ndarray of int
        Flat index (an int for scalar input).
    """
    la, ma = np.asarray(l), np.asarray(m)
    if np.any(la < 0) or np.any(np.abs(ma) > la):
        raise ValueError(f"sh_index needs l >= 0 and |m| <= l, got l={l!r}, m={m!r}")
    out = la * (la + 1) + ma
    return int(out) if out.ndim == 0 else out


def _order_from_count(n: int) -> int:
    order = int(round(np.sqrt(n))) - 1
    if (order + 1) ** 2 != n:
        raise ValueError(
            f"coefficients must have (order + 1)**2 entries on their first axis, got {n}"
        )
    return order


MAX_SH_ORDER: int = 40
"""Highest supported order (``lpmv`` stays accurate to ~1e-12 relative up to here)."""


def real_sph_harm(order: int, directions, *, condon_shortley: bool = False):
    r"""Real orthonormal spherical harmonics ``Y_lm`` up to ``order`` at unit directions.

    Parameters
    ----------
    order : int
        Highest degree L (0 ≤ L ≤ 40).
    directions : array_like, shape (..., 3)
        Unit vectors in the local frame (x east, y north, z up); normalised here.
    condon_shortley : bool
        Include the ``(−1)^m`` Condon–Shortley phase (default ``False``; see the module
        docstring for the convention).

    Returns
    -------
    ndarray, shape (..., (order + 1)²)
        ``Y[..., l(l+1)+m]``, normalised so that ``∫ Y² dΩ = 1`` (Ω in sr).

    Notes
    -----
    Associated Legendre functions from :func:`scipy.special.lpmv`; checked against
    :func:`scipy.special.sph_harm_y` in the tests (≤ 1e-12).
    """
    from scipy.special import lpmv

    order = _check_count(order, "order", 0)
    if order > MAX_SH_ORDER:
        raise ValueError(f"order must be in [0, {MAX_SH_ORDER}], got {order}")
    d = as_float_array(directions, "directions")
    if d.shape[-1:] != (3,):
        raise ValueError(f"directions must have shape (..., 3), got {d.shape}")
    d = d.astype(np.float64)
    norm = np.linalg.norm(d, axis=-1)
    with np.errstate(invalid="ignore", divide="ignore"):
        d = d / norm[..., None]
    mu = clamp_cosine(d[..., 2])
    phi = np.arctan2(d[..., 1], d[..., 0])
    out = np.empty(d.shape[:-1] + ((order + 1) ** 2,))
    for m in range(order + 1):
        cos_m, sin_m = (np.cos(m * phi), np.sin(m * phi)) if m else (None, None)
        sign = 1.0 if (condon_shortley or m % 2 == 0) else -1.0  # lpmv includes (−1)^m
        for l in range(m, order + 1):  # noqa: E741
            # N_lm via log-gamma so large l does not overflow the factorials.
            nlm = np.sqrt((2 * l + 1) / (4.0 * np.pi) * np.exp(lgamma(l - m + 1) - lgamma(l + m + 1)))
            p = sign * nlm * lpmv(m, l, mu)
            if m == 0:
                out[..., l * (l + 1)] = p
            else:
                out[..., l * (l + 1) + m] = np.sqrt(2.0) * p * cos_m
                out[..., l * (l + 1) - m] = np.sqrt(2.0) * p * sin_m
    return out


def sh_project(
    sky: Callable | np.ndarray,
    order: int = 4,
    *,
    directions=None,
    weights=None,
    domain: str = "sphere",
    n_theta: int | None = None,
    n_phi: int | None = None,
    condon_shortley: bool = False,
):
    r"""Project a sky onto real spherical harmonics: ``c_lm = ∫ f(ω) Y_lm(ω) dΩ``.

    Parameters
    ----------
    sky : callable, array_like or SkyImage
        ``sky(directions (N, 3)) -> (N,) or (N, C)``, sampled values with ``directions``
        and ``weights`` [sr], or a rendered :class:`~atmoscatter.render.SkyImage` (its
        luminance [cd m⁻²] with the pixel solid angles).
    order : int
        Highest SH degree L (default 4 → 25 coefficients).
    directions, weights : array_like, optional
        Direction set and solid angles for sampled values.
    domain : {"sphere", "upper"}
        ``"sphere"``: the function on the whole sphere.  ``"upper"``: the function is taken as
        zero below the horizon (a sky without ground) and only the dome is sampled, which
        integrates the horizon discontinuity exactly.
    n_theta, n_phi : int, optional
        Quadrature resolution for a callable (per hemisphere); default
        ``max(48, 2·(order + 1))`` and ``2·n_theta``.  Exact for skies band-limited to
        degree ≤ 2·n_theta − 1 − order in cos θ (see :func:`sphere_quadrature`).
    condon_shortley : bool
        Basis convention (default: no Condon–Shortley phase).

    Returns
    -------
    ndarray, shape ((order + 1)²,) or ((order + 1)², C)
        Coefficients in the units of ``sky`` × sr.

    Examples
    --------
    >>> import numpy as np
    >>> c = sh_project(lambda d: np.ones(len(d)), order=2)   # c_00 = 4π · Y_00 = 2√π
    >>> print(f"{c[0]:.6f} {2 * np.sqrt(np.pi):.6f} {abs(c[1:]).max() < 1e-12}")
    3.544908 3.544908 True
    """
    check_option(domain, "domain", ("sphere", "upper"))
    order = _check_count(order, "order", 0)
    if n_theta is None:
        n_theta = max(DEFAULT_N_THETA, 2 * (order + 1))
    vals, dirs, w = _sample_sky(sky, directions, weights, domain=domain, n_theta=n_theta,
                                n_phi=n_phi)
    if domain == "upper" and (_is_sky_image(sky) or not callable(sky)):
        w = np.where(dirs[:, 2] > 0.0, w, 0.0)
    y = real_sph_harm(order, dirs, condon_shortley=condon_shortley)
    vals = vals.astype(np.float64, copy=False)
    yw = y * w[:, None]
    if vals.ndim == 1:
        return yw.T @ vals
    return np.tensordot(yw, vals, axes=(0, 0))


def sh_evaluate(coefficients, directions, *, condon_shortley: bool = False):
    r"""Reconstruct ``f(ω) = Σ c_lm Y_lm(ω)`` from SH coefficients.

    Parameters
    ----------
    coefficients : array_like, shape ((L + 1)²,) or ((L + 1)², C)
        As returned by :func:`sh_project` (same convention!).
    directions : array_like, shape (..., 3)
        Unit directions (local frame).

    Returns
    -------
    ndarray, shape (...) or (..., C)
    """
    c = as_float_array(coefficients, "coefficients").astype(np.float64)
    if c.ndim not in (1, 2):
        raise ValueError(f"coefficients must have shape (n,) or (n, C), got {c.shape}")
    order = _order_from_count(c.shape[0])
    y = real_sph_harm(order, directions, condon_shortley=condon_shortley)
    return y @ c


def clamped_cosine_sh_coefficients(order: int) -> np.ndarray:
    r"""Convolution factors ``Â_l`` of the clamped cosine ``max(cos θ, 0)``, l = 0…order.

    ``Â_0 = π``, ``Â_1 = 2π/3``, ``Â_l = 0`` for odd l > 1 and, for even l,
    ``Â_l = 2π (−1)^{l/2−1} / ((l + 2)(l − 1)) · l! / (2^l ((l/2)!)²)``
    (Ramamoorthi & Hanrahan 2001, Eq. 8–9; ``Â_2 = π/4``, ``Â_4 = −π/24``).

    Parameters
    ----------
    order : int
        Highest degree l, ≥ 0.

    Returns
    -------
    ndarray, shape (order + 1,)
        ``Â_l`` [sr] for l = 0…order.
    """
    order = _check_count(order, "order", 0)
    a = np.zeros(order + 1)
    for l in range(order + 1):  # noqa: E741
        if l == 0:
            a[l] = np.pi
        elif l == 1:
            a[l] = 2.0 * np.pi / 3.0
        elif l % 2 == 0:
            h = l // 2
            a[l] = (2.0 * np.pi * (-1.0) ** (h - 1) / ((l + 2) * (l - 1))
                    * factorial(l) / (2.0**l * factorial(h) ** 2))
    return a


def sh_irradiance(coefficients, normals, *, condon_shortley: bool = False):
    r"""Irradiance ``E(n) = ∫ L(ω) max(n·ω, 0) dΩ`` from the SH coefficients of ``L``.

    ``E(n) = Σ_lm Â_l c_lm Y_lm(n)`` (Ramamoorthi & Hanrahan 2001).  Exact when ``L`` is
    band-limited to the coefficients' order; with order 2 the error is below ~3 % of the
    irradiance for any ``L ≥ 0`` (their bound), order 4 is much better.  The whole sphere is
    a source: project with ``domain="upper"`` to exclude the ground.

    Parameters
    ----------
    coefficients : array_like, shape ((L + 1)²,) or ((L + 1)², C)
    normals : array_like, shape (..., 3)
        Plane normals (local frame).

    Returns
    -------
    ndarray, shape (...) or (..., C)
        Units of the radiance × sr (W m⁻², or lx from cd m⁻²).
    """
    c = as_float_array(coefficients, "coefficients").astype(np.float64)
    order = _order_from_count(c.shape[0])
    a = clamped_cosine_sh_coefficients(order)
    per_coef = np.repeat(a, 2 * np.arange(order + 1) + 1)
    scaled = c * (per_coef if c.ndim == 1 else per_coef[:, None])
    return sh_evaluate(scaled, normals, condon_shortley=condon_shortley)

"""Preetham, Shirley & Smits (1999) analytic daylight model.

Public objects
--------------
PREETHAM_DISTRIBUTION_MATRIX
    Perez coefficients ``[A, B, C, D, E] = a·T + b`` for Y, x and y.
PREETHAM_ZENITH_CHROMATICITY_MATRICES
    ``M_x`` and ``M_y`` of the zenith chromaticity polynomials.
PreethamValidityWarning
    Warning issued when the turbidity is clamped into the fit's range.
preetham_distribution_coefficients, preetham_zenith
    The model's building blocks as functions of turbidity and sun zenith.
preetham_Yxy
    Yxy from angles (θ, γ, θ_s), fully broadcasting.
preetham_sky, preetham_sky_Yxy, preetham_sky_rgb, preetham_sky_spectral
    The sky for arrays of view directions in the local frame (x = east, y = north, z = up):
    CIE XYZ, Yxy, linear RGB (through colour-science) and spectral radiance (CIE D-series).

Model (seed 003 §5–6, seed 004, errata 003.3)::

    Y = Y_z F_Y(θ, γ) / F_Y(0, θ_s),  x = x_z F_x(θ, γ) / F_x(0, θ_s),  y = y_z F_y(θ, γ) / F_y(0, θ_s)
    F(θ, γ) = (1 + A e^{B/cos θ}) (1 + C e^{Dγ} + E cos²γ)                     (Perez et al. 1993)
    Y_z = [(4.0453 T − 4.9710) tan χ − 0.2155 T + 2.4192] kcd m⁻²,  χ = (4/9 − T/120)(π − 2θ_s)
    x_z = [T², T, 1] M_x [θ_s³, θ_s², θ_s, 1]ᵀ,   y_z likewise with M_y

Validity policy
---------------
The fit is documented for turbidity 2 ≤ T ≤ 10 and the sun above the horizon (errata 003.4).

* ``T < 1`` or non-finite: :class:`ValueError` (``T = (τ_m + τ_h)/τ_m ≥ 1`` by definition).
* ``1 ≤ T < 2`` or ``T > 10``: with ``out_of_range="warn"`` (default) a
  :class:`PreethamValidityWarning` is issued and the model is evaluated at ``T`` clamped to
  ``[2, 10]``; with ``out_of_range="raise"`` a :class:`ValueError`. Unclamped, the fit turns
  negative (the zenith factor ``1 + A e^{B}`` crosses zero near T ≈ 1.6; ``Y_z`` at a
  horizon sun is negative for T > 11.2).
* Sun below the horizon (``θ_s > 90°``): the sky is dark, every output is exactly 0 (Yxy
  gives ``Y = 0`` with the D65 chromaticity, as colour-science does for black). No warning:
  night is normal use. At ``θ_s = 90°`` exactly the model is evaluated (finite, positive).
* View directions below the horizon are evaluated at the horizon (``cos θ`` clamped to 0;
  γ from the true direction), so the output is continuous and non-negative.

Inside that domain the outputs are finite and non-negative (tested on a dense grid).

References
----------
Preetham, A. J., Shirley, P. & Smits, B. (1999). A practical analytic model for daylight.
*Proceedings of SIGGRAPH 99*, 91–100, Appendix A.2. Perez, R., Seals, R. & Michalsky, J.
(1993). All-weather model for sky luminance distribution. *Solar Energy* 50, 235–245.
Wyszecki, G. & Stiles, W. S. (1982). *Color Science*, 2nd ed., §3.3.4 (CIE daylight basis).
"""

from __future__ import annotations

import warnings
from functools import lru_cache

import numpy as np

from .._validate import as_float_array, check_option
from ..colour import K_M, XYZ_to_linear_rgb, cmf_weights
from ._preetham_eval import _CHUNK, _KIND_RGB, _KIND_XYZ, _KIND_YXY, _evaluate
from ._preetham_fit import (
    PREETHAM_DISTRIBUTION_MATRIX,
    PREETHAM_TURBIDITY_RANGE,
    PREETHAM_ZENITH_CHROMATICITY_MATRICES,
    PreethamValidityWarning,
    _BLACK_xy,
    _coefficients,
    _turbidity,
    _zenith,
)
from ._preetham_spectral import _M_METHODS, DEFAULT_WAVELENGTHS, _daylight_basis, _daylight_M
from .perez import _horizon_term

__all__ = [
    "PREETHAM_DISTRIBUTION_MATRIX",
    "PREETHAM_ZENITH_CHROMATICITY_MATRICES",
    "PREETHAM_TURBIDITY_RANGE",
    "PreethamValidityWarning",
    "preetham_distribution_coefficients",
    "preetham_zenith",
    "preetham_Yxy",
    "preetham_sky",
    "preetham_sky_Yxy",
    "preetham_sky_rgb",
    "preetham_sky_spectral",
]


# ----------------------------------------------------------------------------------------------
# building blocks
# ----------------------------------------------------------------------------------------------
def preetham_distribution_coefficients(turbidity, *, out_of_range: str = "warn") -> np.ndarray:
    """Perez distribution coefficients of the Preetham model.

    ``[A, B, C, D, E] = a·T + b`` with the (a, b) pairs of Preetham et al. (1999),
    Appendix A.2 (seed 003 §6, errata 003.3).

    Parameters
    ----------
    turbidity : array_like
        Linke-type turbidity ``T = (τ_m + τ_h)/τ_m``; fit range 2–10 (see the module's
        validity policy). [1]
    out_of_range : {"warn", "raise"}
        Policy for ``T`` outside [2, 10]: warn and clamp, or raise ``ValueError``.

    Returns
    -------
    numpy.ndarray
        Shape ``T.shape + (3, 5)``: rows Y, x, y; columns A, B, C, D, E. [1]
    """
    T = _turbidity(turbidity, out_of_range)
    return _coefficients(T)


def preetham_zenith(turbidity, sun_zenith, *, out_of_range: str = "warn") -> np.ndarray:
    """Zenith luminance and chromaticity of the Preetham sky.

    ``Y_z = [(4.0453 T − 4.9710) tan χ − 0.2155 T + 2.4192]`` kcd m⁻² with
    ``χ = (4/9 − T/120)(π − 2θ_s)``, and ``x_z``, ``y_z`` from the cubic-in-θ_s, quadratic-in-T
    polynomials of Preetham et al. (1999), Appendix A.2 (seed 003 §6, errata 003.3).

    Parameters
    ----------
    turbidity : array_like
        Turbidity (fit range 2–10; see the validity policy). [1]
    sun_zenith : array_like
        Solar zenith angle, broadcast against ``turbidity``. [rad]
    out_of_range : {"warn", "raise"}
        Turbidity policy outside [2, 10].

    Returns
    -------
    numpy.ndarray
        ``(Y_z [cd m⁻²], x_z, y_z)`` on the last axis. For a sun below the horizon
        (``θ_s > π/2``) ``Y_z = 0`` and ``(x_z, y_z)`` is D65's chromaticity.

    Raises
    ------
    ValueError
        For ``sun_zenith`` outside [0, π] or a turbidity violating the policy.
    """
    T = _turbidity(turbidity, out_of_range)
    ts = as_float_array(sun_zenith, "sun_zenith").astype(np.float64)
    if np.any((ts < 0) | (ts > np.pi)):
        bad = ts[(ts < 0) | (ts > np.pi)].ravel()[0] if ts.ndim else ts.item()
        raise ValueError(f"sun_zenith must be in [0, pi] rad, got {bad!r}")
    night = ts > np.pi / 2
    out = _zenith(T, np.minimum(ts, np.pi / 2))
    if np.any(night):
        out = np.where(night[..., None], np.array([0.0, *_BLACK_xy]), out)
    return out


def preetham_Yxy(view_zenith, gamma, sun_zenith, turbidity, *, out_of_range: str = "warn"):
    """Preetham sky Yxy from angles (broadcasting NumPy evaluation).

    ``Y = Y_z F_Y(θ, γ)/F_Y(0, θ_s)`` and likewise for x, y (seed 004; errata 003.3),
    with :func:`atmoscatter.perez` as ``F``.

    Parameters
    ----------
    view_zenith : array_like
        Zenith angle θ of the view direction; values ≥ π/2 give the horizon value. [rad]
    gamma : array_like
        Angle γ between view direction and sun, in [0, π]. [rad]
    sun_zenith : array_like
        Solar zenith θ_s in [0, π]; above π/2 the result is dark (Y = 0). [rad]
    turbidity : array_like
        Turbidity, fit range 2–10 (see the validity policy). [1]
    out_of_range : {"warn", "raise"}
        Turbidity policy outside [2, 10].

    Returns
    -------
    numpy.ndarray
        ``(Y [cd m⁻²], x, y)`` on the last axis, broadcast shape of the inputs; float64.
    """
    T = _turbidity(turbidity, out_of_range)
    theta = as_float_array(view_zenith, "view_zenith").astype(np.float64)
    gamma = as_float_array(gamma, "gamma").astype(np.float64)
    ts = as_float_array(sun_zenith, "sun_zenith").astype(np.float64)
    if np.any((ts < 0) | (ts > np.pi)):
        bad = ts[(ts < 0) | (ts > np.pi)].ravel()[0] if ts.ndim else ts.item()
        raise ValueError(f"sun_zenith must be in [0, pi] rad, got {bad!r}")
    night = ts > np.pi / 2
    ts_c = np.minimum(ts, np.pi / 2)
    coef = _coefficients(T)  # (..., 3, 5)
    zen = _zenith(T, ts_c)  # (..., 3)
    A, B, C, D, E = (coef[..., i] for i in range(5))  # each (..., 3)
    cos_t = np.cos(theta)[..., None]
    g = gamma[..., None]
    cg = np.cos(g)
    F = (1.0 + A * _horizon_term(cos_t, B)) * (1.0 + C * np.exp(D * g) + E * cg * cg)
    cs = np.cos(ts_c)[..., None]
    F0 = (1.0 + A * np.exp(B)) * (1.0 + C * np.exp(D * ts_c[..., None]) + E * cs * cs)
    out = zen * F / F0
    if np.any(night):
        out = np.where(night[..., None], np.array([0.0, *_BLACK_xy]), out)
    return out


# ----------------------------------------------------------------------------------------------
# direction-based evaluation (the machinery is in ._preetham_eval)
# ----------------------------------------------------------------------------------------------
def preetham_sky(
    view_directions, sun_direction, turbidity, *, out_of_range="warn", backend="auto"
):
    """Preetham sky in CIE XYZ for arrays of view directions.

    ``Y = Y_z F_Y(θ, γ)/F_Y(0, θ_s)``, ``x``, ``y`` likewise (seed 003 §5–6, seed 004,
    errata 003.3), then ``X = x Y / y``, ``Z = (1 − x − y) Y / y``. Exact to the published
    model (float64: ≤ 1e-12 relative to a scalar transcription of the formulas).

    Parameters
    ----------
    view_directions : array_like
        Unit view directions, shape (..., 3), local frame x = east, y = north, z = up.
        float32 input gives float32 output (compiled path: table interpolation of the
        Perez factors, within 1e-5 relative of float64, measured ≤ 4e-6); anything else is
        evaluated in float64 from the formulas.
        Non-unit vectors are normalised; NaN (or a zero vector) gives NaN.
    sun_direction : array_like
        Direction toward the sun, shape (3,), same frame (normalised internally).
    turbidity : float
        Turbidity (scalar), fit range 2–10; see the module's validity policy. [1]
    out_of_range : {"warn", "raise"}
        Turbidity outside [2, 10]: warn (:class:`PreethamValidityWarning`) and clamp, or raise.
    backend : {"auto", "numba", "numpy"}
        ``"auto"`` uses the compiled kernel (threaded over the cores for large calls) when numba
        is installed, else chunked NumPy.

    Returns
    -------
    numpy.ndarray
        CIE 1931 XYZ [cd m⁻²] on the last axis, shape of ``view_directions``. All zeros for a
        sun below the horizon; views below the horizon take the horizon value.

    Examples
    --------
    >>> import numpy as np, atmoscatter as ac
    >>> sun = np.array([0.0, np.sin(np.radians(40)), np.cos(np.radians(40))])
    >>> XYZ = ac.preetham_sky([0.0, 0.0, 1.0], sun, 3.0)
    >>> round(float(XYZ[1]) / 1000, 3)   # zenith luminance Y_z [kcd m^-2]
    8.211
    """
    return _evaluate(
        view_directions, sun_direction, turbidity, _KIND_XYZ, None, out_of_range, backend
    )


def preetham_sky_Yxy(
    view_directions, sun_direction, turbidity, *, out_of_range="warn", backend="auto"
):
    """Preetham sky as CIE Yxy (luminance [cd m⁻²], chromaticity x, y) on the last axis.
    Parameters
    ----------
    view_directions : array_like
        Unit view directions, shape (..., 3), local frame x = east, y = north, z = up.
        float32 input gives float32 output (compiled path: table interpolation of the
        Perez factors, within 1e-5 relative of float64, measured ≤ 4e-6); anything else is
        evaluated in float64 from the formulas.
        Non-unit vectors are normalised; NaN (or a zero vector) gives NaN.
    sun_direction : array_like
        Direction toward the sun, shape (3,), same frame (normalised internally).
    turbidity : float
        Turbidity (scalar), fit range 2–10; see the module's validity policy. [1]
    out_of_range : {"warn", "raise"}
        Turbidity outside [2, 10]: warn (:class:`PreethamValidityWarning`) and clamp, or raise.
    backend : {"auto", "numba", "numpy"}
        ``"auto"`` uses the compiled kernel (threaded over the cores for large calls) when numba
        is installed, else chunked NumPy.

    Returns
    -------
    numpy.ndarray
        ``(Y [cd m⁻²], x, y)`` on the last axis (note the Yxy order, not colour-science's xyY).
    """
    return _evaluate(
        view_directions, sun_direction, turbidity, _KIND_YXY, None, out_of_range, backend
    )


@lru_cache(maxsize=32)
def _xyz_to_rgb_matrix(colourspace: str) -> np.ndarray:
    """The linear XYZ → RGB matrix of ``colourspace`` as the colour wrappers apply it.

    Obtained by applying :func:`atmoscatter.XYZ_to_linear_rgb` (colour-science's
    normalised primary matrix, no chromatic adaptation) to the unit vectors, so no matrix is
    copied by hand and the fused kernel agrees with the wrapper by construction.
    """
    m = np.ascontiguousarray(
        np.asarray(XYZ_to_linear_rgb(np.eye(3), colourspace=colourspace), dtype=np.float64).T
    )
    m.flags.writeable = False
    return m


def preetham_sky_rgb(
    view_directions,
    sun_direction,
    turbidity,
    *,
    colourspace="sRGB",
    out_of_range="warn",
    backend="auto",
):
    """Preetham sky in linear RGB (XYZ → RGB through colour-science).

    The linear transform is the one of :func:`atmoscatter.colour.XYZ_to_linear_rgb` for
    ``colourspace`` (default linear sRGB / Rec. 709 primaries, no encoding curve), fused
    into the per-direction kernel.

    Parameters
    ----------
    view_directions : array_like
        Unit view directions, shape (..., 3), local frame x = east, y = north, z = up.
        float32 input gives float32 output (compiled path: table interpolation of the
        Perez factors, within 1e-5 relative of float64, measured ≤ 4e-6); anything else is
        evaluated in float64 from the formulas.
        Non-unit vectors are normalised; NaN (or a zero vector) gives NaN.
    sun_direction : array_like
        Direction toward the sun, shape (3,), same frame (normalised internally).
    turbidity : float
        Turbidity (scalar), fit range 2–10; see the module's validity policy. [1]
    colourspace : str
        A colour-science RGB colourspace name (``colour.RGB_COLOURSPACES``). [default "sRGB"]
    out_of_range : {"warn", "raise"}
        Turbidity outside [2, 10]: warn (:class:`PreethamValidityWarning`) and clamp, or raise.
    backend : {"auto", "numba", "numpy"}
        ``"auto"`` uses the compiled kernel (threaded over the cores for large calls) when numba
        is installed, else chunked NumPy.

    Returns
    -------
    numpy.ndarray
        Linear RGB on the last axis, scaled so that luminance is in cd m⁻² (out-of-gamut
        colours may have negative components; nothing is clipped).
    """
    matrix = _xyz_to_rgb_matrix(colourspace)
    return _evaluate(
        view_directions, sun_direction, turbidity, _KIND_RGB, matrix, out_of_range, backend
    )


# ----------------------------------------------------------------------------------------------
# spectral radiance (CIE D-series reconstruction)
# ----------------------------------------------------------------------------------------------
def preetham_sky_spectral(
    view_directions,
    sun_direction,
    turbidity,
    wavelengths=None,
    *,
    m_coefficients="published",
    clip_negative=False,
    out_of_range="warn",
    backend="auto",
):
    """Preetham sky spectral radiance from the CIE D-series reconstruction.

    For each direction the model's (x, y) give ``M1``, ``M2`` and
    ``S_D(λ) = S_0(λ) + M_1 S_1(λ) + M_2 S_2(λ)`` (seed 004; Wyszecki & Stiles 1982), which
    is scaled so that ``683 lm/W ∫ L(λ) ȳ(λ) dλ`` equals the model's luminance Y.

    Parameters
    ----------
    view_directions : array_like
        Unit view directions, shape (..., 3), local frame x = east, y = north, z = up.
        float32 input gives float32 output (compiled path: table interpolation of the
        Perez factors, within 1e-5 relative of float64, measured ≤ 4e-6); anything else is
        evaluated in float64 from the formulas.
        Non-unit vectors are normalised; NaN (or a zero vector) gives NaN.
    sun_direction : array_like
        Direction toward the sun, shape (3,), same frame (normalised internally).
    turbidity : float
        Turbidity (scalar), fit range 2–10; see the module's validity policy. [1]
    wavelengths : array_like, optional
        Strictly increasing wavelengths in [300, 830] nm; default 380–780 nm every 5 nm. [nm]
    m_coefficients : {"published", "exact"}
        ``"published"``: the printed M1, M2 formulas (seed 004; CIE 15), whose 4-digit
        coefficients reproduce (x, y) to ~1e-4 after integration; ``"exact"``: M1, M2 solved
        from the chromaticity equations with the basis' tristimulus values on ``wavelengths``,
        reproducing (x, y) to rounding.
    clip_negative : bool
        The D-series basis was fitted to daylight; for chromaticities far from the daylight
        locus (low sun: the yellowish sky near the horizon and sun has x ≈ 0.43, y ≈ 0.47)
        ``S_D`` turns negative at short wavelengths (down to −60 % of the peak at θ_s = 90°,
        T = 2). ``False`` (default): keep the reconstruction (exact round trip) and issue a
        :class:`PreethamValidityWarning` when any value is negative; ``True``: set negative
        values to 0 and rescale each spectrum to keep its luminance Y (its chromaticity then
        moves toward the spectrum locus; no warning).
    out_of_range : {"warn", "raise"}
        Turbidity outside [2, 10]: warn (:class:`PreethamValidityWarning`) and clamp, or raise.
    backend : {"auto", "numba", "numpy"}
        ``"auto"`` uses the compiled kernel (threaded over the cores for large calls) when numba
        is installed, else chunked NumPy.

    Returns
    -------
    numpy.ndarray
        Spectral radiance [W m⁻² sr⁻¹ nm⁻¹], shape ``view_directions.shape[:-1] + (n_wl,)``.
        Integrating it with the CIE 1931 CMFs (``atmoscatter.spectral_to_XYZ``) gives back the
        model's Y exactly and its (x, y) to the accuracy stated for ``m_coefficients``.
    """
    check_option(m_coefficients, "m_coefficients", _M_METHODS)
    wl = DEFAULT_WAVELENGTHS if wavelengths is None else as_float_array(wavelengths, "wavelengths")
    wl = np.asarray(wl, dtype=np.float64)
    if wl.ndim != 1 or wl.size < 2 or np.any(np.diff(wl) <= 0):
        raise ValueError(
            f"wavelengths must be a strictly increasing 1-D array of >= 2 values [nm], got shape {wl.shape}"
        )
    if wl[0] < 300.0 or wl[-1] > 830.0:
        raise ValueError(
            f"wavelengths must lie in [300, 830] nm (range of the CIE daylight basis), "
            f"got [{wl[0]}, {wl[-1]}]"
        )
    Yxy = preetham_sky_Yxy(
        view_directions, sun_direction, turbidity, out_of_range=out_of_range, backend=backend
    )
    dtype = Yxy.dtype
    S, basis_XYZ = _daylight_basis(tuple(wl.tolist()))
    flat = Yxy.reshape(-1, 3).astype(np.float64)
    out = np.empty((flat.shape[0], wl.size), dtype=dtype)
    with np.errstate(invalid="ignore", divide="ignore"):  # NaN directions stay NaN
        for start in range(0, flat.shape[0], max(1, _CHUNK // 4)):
            sl = slice(start, start + max(1, _CHUNK // 4))
            Y, x, y = flat[sl, 0], flat[sl, 1], flat[sl, 2]
            M1, M2 = _daylight_M(x, y, m_coefficients, basis_XYZ)
            w = np.stack([np.ones_like(M1), M1, M2], axis=-1)  # (n, 3)
            Y_D = w @ basis_XYZ[1]  # luminance of the unscaled S_D
            scale = np.where(Y > 0.0, Y / np.where(Y > 0.0, Y_D, 1.0), 0.0)
            scale = np.where(np.isnan(Y), np.nan, scale)
            out[sl] = (w * scale[:, None]) @ S.T
    negative = out < 0
    if np.any(negative):
        if clip_negative:
            rows = negative.any(axis=1)
            part = np.maximum(out[rows].astype(np.float64), 0.0)
            Y_clip = part @ (K_M * cmf_weights(wl)[:, 1])
            Y_want = flat[rows, 0]
            with np.errstate(invalid="ignore", divide="ignore"):
                k = np.where(Y_clip > 0, Y_want / np.where(Y_clip > 0, Y_clip, 1.0), 0.0)
            out[rows] = part * k[:, None]
        else:
            warnings.warn(
                f"{int(negative.any(axis=1).sum())} spectra of the CIE D-series reconstruction "
                "have negative values (chromaticity far from the daylight locus); pass "
                "clip_negative=True to clip them at 0 (keeping Y)",
                PreethamValidityWarning,
                stacklevel=2,
            )
    return out.reshape(Yxy.shape[:-1] + (wl.size,))

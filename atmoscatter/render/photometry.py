"""Radiance per unit solar irradiance → absolute units: CIE XYZ [cd m⁻²] and spectral radiance.

Public objects
--------------
:func:`rgb_sampling_matrix`
    The power-law expansion of radiance sampled at a few wavelengths (RGB sampling:
    three) to a 380–780 nm grid.

The physical models and Hoffman–Preetham return radiance per unit extraterrestrial
irradiance [sr⁻¹]; their adapters (:mod:`atmoscatter.render.physical_adapters`) convert it
with :func:`_per_irradiance_converter`: times the ASTM G-173 ETR band-averaged over each
sample's interval at the scene's Earth–Sun distance (:func:`_band_etr`), integrated with
the CIE 1931 2° CMFs (K_m = 683 lm W⁻¹).  The sun disc of the evaluator uses the same
:data:`FINE_GRID` and band-averaged ETR.
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np

__all__ = ["rgb_sampling_matrix"]



#: Fine grid [nm] on which RGB samples are expanded to a spectrum.
FINE_GRID = np.arange(380.0, 780.0 + 0.5, 5.0)


def rgb_sampling_matrix(sample_wavelengths, grid=FINE_GRID) -> np.ndarray:
    """Matrix ``A`` (n_samples, n_grid): ``log f(grid) = log f(samples) @ A``.

    Piecewise-linear interpolation in ``log λ`` between the (sorted) samples,
    linear extrapolation with the end segments' slopes: a power law
    ``f ∝ λ^p`` is reproduced exactly on the whole grid.

    Parameters
    ----------
    sample_wavelengths : array_like, shape (n_samples,)
        Wavelengths [nm] at which ``f`` is known, in any order, at least 2, positive,
        finite and distinct.
    grid : array_like, shape (n_grid,), optional
        Wavelengths [nm] > 0 to expand to (default :data:`FINE_GRID`, 380–780 nm every
        5 nm).

    Returns
    -------
    ndarray, shape (n_samples, n_grid)
        float64 weights; row ``i`` belongs to ``sample_wavelengths[i]`` (input order).  Each
        column has at most two non-zero entries and sums to 1; outside the samples' range
        the extrapolation gives one negative entry.

    Raises
    ------
    ValueError
        If fewer than 2 sample wavelengths are given, or any sample or grid wavelength is
        not positive and finite, or two samples are equal.
    """
    wl = np.asarray(sample_wavelengths, dtype=float).ravel()
    g = np.asarray(grid, dtype=float).ravel()
    if wl.size < 2:
        raise ValueError("RGB sampling needs at least 2 sample wavelengths")
    for name, v in (("sample_wavelengths", wl), ("grid", g)):
        if not np.all(np.isfinite(v) & (v > 0)):
            raise ValueError(f"{name} must be positive and finite [nm], got {v.tolist()!r}")
    if np.unique(wl).size != wl.size:
        raise ValueError(f"sample_wavelengths must be distinct, got {wl.tolist()!r}")
    lam = np.log(wl)
    order = np.argsort(lam)
    ls = lam[order]
    x = np.log(g)
    seg = np.clip(np.searchsorted(ls, x) - 1, 0, ls.size - 2)
    t = (x - ls[seg]) / (ls[seg + 1] - ls[seg])
    A_sorted = np.zeros((ls.size, x.size))
    cols = np.arange(x.size)
    A_sorted[seg, cols] = 1.0 - t
    A_sorted[seg + 1, cols] = t
    A = np.empty_like(A_sorted)
    A[order] = A_sorted
    return A


def _band_etr(wavelengths, distance_au):
    """ETR [W m⁻² nm⁻¹] averaged over each sample's interval (midpoints to neighbours)."""
    from ..solar import extraterrestrial_irradiance, solar_spectrum_table  # noqa: PLC0415

    wl = np.asarray(wavelengths, dtype=float)
    tw, te = solar_spectrum_table()
    if wl.size == 1:
        return extraterrestrial_irradiance(wl, distance_au=distance_au)
    srt = np.sort(wl)
    edges = np.concatenate([[srt[0] - 0.5 * (srt[1] - srt[0])], 0.5 * (srt[1:] + srt[:-1]),
                            [srt[-1] + 0.5 * (srt[-1] - srt[-2])]])
    out = np.empty(srt.size)
    for i in range(srt.size):
        a, b = edges[i], edges[i + 1]
        inside = (tw > a) & (tw < b)
        x = np.concatenate([[a], tw[inside], [b]])
        y = np.interp(x, tw, te)
        out[i] = np.trapezoid(y, x) / (b - a)
    res = np.empty_like(out)
    res[np.searchsorted(srt, wl)] = out
    return res / distance_au**2


#: Exponent grid of the power-law integral tables (p in f ∝ λ^p, clipped to this range).
_P_GRID = np.linspace(-40.0, 40.0, 1601)


@lru_cache(maxsize=16)
def _power_law_tables(sample_wavelengths: tuple):
    """Integrals ``H_i(p) = K_m Σ_λ w(λ) E(λ) cmf(λ) (λ/λ_i)^p`` over segment i's range.

    With f(λ) = f_i (λ/λ_i)^{p_i} on segment i (the power-law expansion of
    :func:`rgb_sampling_matrix`), ``XYZ = Σ_i f_i H_i(p_i)`` exactly; H_i is
    tabulated against p (1 nm grid 380–780 nm, ETR band-averaged over 1 nm, at
    1 AU) and interpolated linearly (relative error ~1e-5).
    """
    from ..colour import K_M, cmf_weights  # noqa: PLC0415

    lam = np.asarray(sample_wavelengths, dtype=float)
    order = np.argsort(lam)
    ls = lam[order]
    grid = np.arange(380.0, 780.0 + 0.5, 1.0)
    w = K_M * cmf_weights(grid) * _band_etr(grid, 1.0)[:, None]  # (n_grid, 3)
    seg = np.clip(np.searchsorted(ls, grid, side="right") - 1, 0, ls.size - 2)
    H = np.empty((ls.size - 1, _P_GRID.size, 3))
    for i in range(ls.size - 1):
        m = seg == i
        x = np.log(grid[m] / ls[i])  # (k,)
        H[i] = np.exp(np.outer(_P_GRID, x)) @ w[m]
    return order, ls, H


def _per_irradiance_converter(wavelengths, rgb_sampled, plan):
    """``convert(f)``: radiance per unit solar irradiance f (n, n_wl) [sr⁻¹] → plan's outputs.

    Multiplies by the band-averaged ASTM G-173 ETR at the scene's Earth–Sun
    distance and integrates with the CIE 1931 CMFs (K_m = 683 lm W⁻¹).  RGB
    samples are expanded to a 380–780 nm spectrum as a power law between the
    samples (:func:`rgb_sampling_matrix`); that integral is evaluated exactly
    per segment from tabulated ``H_i(p)`` (:func:`_power_law_tables`).  Only
    ȳ is used when ``plan.quantity == "Y"``.
    """
    from ..colour import K_M, cmf_weights  # noqa: PLC0415

    wl = np.asarray(wavelengths, dtype=float)
    E = _band_etr(wl, plan.distance_au)
    channels = [1] if plan.quantity == "Y" else [0, 1, 2]
    if rgb_sampled:
        order, ls, H = _power_law_tables(tuple(float(w) for w in wl))
        H = H / plan.distance_au**2
        dlog = np.log(ls[1:] / ls[:-1])
    else:
        order = np.argsort(wl)
        W = np.empty((wl.size, 3))
        W[order] = cmf_weights(wl[order])
        W *= (K_M * E)[:, None]
        Wq = W[:, channels]

    def convert(f):
        f = np.maximum(np.asarray(f, dtype=float), 0.0)
        out = {}
        if rgb_sampled:
            fs = f[:, order]
            logf = np.log(np.maximum(fs, 1e-300))
            res = np.zeros((len(f), len(channels)))
            for i in range(ls.size - 1):
                p = np.clip((logf[:, i + 1] - logf[:, i]) / dlog[i], _P_GRID[0], _P_GRID[-1])
                for j, c in enumerate(channels):
                    res[:, j] += fs[:, i] * np.interp(p, _P_GRID, H[i, :, c])
        else:
            res = f @ Wq
        if plan.quantity == "spectral":
            out["spectral"] = f * E
        if plan.quantity == "Y":
            out["Y"] = res[..., 0]
        else:
            out["XYZ"] = res
        return out

    return convert

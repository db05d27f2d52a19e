"""Scattering and absorption coefficients of air molecules, haze and ozone.

Public objects
--------------
- :func:`rayleigh_scattering`: total Rayleigh scattering coefficient of a gas [m⁻¹].
- :func:`junge_k_factor`, :func:`mie_scattering`, :func:`mie_absorption`: haze (aerosol)
  coefficients with the Junge spectral shape, magnitude fixed by the turbidity.
- :func:`ozone_absorption`: ozone absorption coefficient from a shipped cross-section table.

References
----------
- Seeds 000, 002, 004 (Rayleigh with the King correction factor; Junge/Mie shape).
- Preetham, A. J., Shirley, P. & Smits, B. (1999). A practical analytic model for daylight.
  SIGGRAPH 99 (turbidity ``T = (τ_m + τ_h)/τ_m``; errata 004.3).
- Bullrich, K. (1964). Scattered radiation in the atmosphere. Adv. Geophys. 10 (K(λ), via
  seed 004: "K varies from 0.656 for 400 nm to 0.69 for 770 nm").
- Serdyuchenko, A. et al. (2014). High spectral resolution ozone absorption cross-sections.
  Atmos. Meas. Tech. 7, 625–636 (ozone, 233 K, binned to 10 nm as in Bruneton 2017).
"""

from __future__ import annotations

from functools import lru_cache
from importlib import resources

import numpy as np

from ._validate import as_float_array, check_positive, check_range

__all__ = [
    "rayleigh_scattering",
    "junge_k_factor",
    "mie_scattering",
    "mie_absorption",
    "ozone_absorption",
    "DOBSON_UNIT",
]

#: Molecules per m² in one Dobson unit [m⁻²] (WMO definition: 2.6867e20).
DOBSON_UNIT: float = 2.6867e20


def _wavelength(wavelength) -> np.ndarray:
    return check_positive(as_float_array(wavelength, "wavelength"), "wavelength", unit="nm")


def _like_input(result, lam: np.ndarray):
    """Cast a float64 result to the wavelength's precision (float32 in → float32 out)."""
    out = np.asarray(result).astype(np.result_type(lam, np.float32), copy=False)
    return out[()] if out.ndim == 0 else out


def rayleigh_scattering(
    wavelength,
    *,
    refractive_index=1.0003,
    number_density=2.545e25,
    depolarization=0.035,
):
    r"""Total Rayleigh scattering coefficient of a gas.

    .. math:: \beta_R(\lambda) = \frac{8\pi^3 (n^2 - 1)^2}{3 N \lambda^4}
              \,\frac{6 + 3 p_n}{6 - 7 p_n}

    Parameters
    ----------
    wavelength : array_like
        Wavelength [nm], > 0.
    refractive_index : array_like
        Refractive index ``n`` of the gas at ``number_density`` [-], ≥ 1 (default 1.0003,
        seed 000).
    number_density : array_like
        Molecular number density ``N`` [m⁻³], > 0 (default 2.545e25, seed 000).
    depolarization : array_like
        Depolarisation factor ``p_n`` [-], in [0, 6/7) (default 0.035, seed 000; errata
        004.1).  ``(6 + 3p_n)/(6 − 7p_n)`` is the King correction factor.

    Returns
    -------
    ndarray or float
        Scattering coefficient [m⁻¹], broadcast over all inputs.

    Notes
    -----
    Seed 000 (Rayleigh coefficient with King factor; errata 000.4), seed 002 Eq. 2.1,
    seed 004.  With the defaults: 6.95e-6, 1.18e-5, 2.44e-5 m⁻¹ at 650, 570, 475 nm
    (seed 000).  Accuracy: with these defaults the cross section ``β/N`` is 14 % (400 nm),
    18 % (550 nm) and 20 % (700 nm) *above* Bodhaine et al. (1999): ``n − 1 = 3.0e-4``
    overstates the refractivity of air (2.78e-4 at 550 nm and 288 K), partly offset in the
    blue by ignoring its dispersion.  Given Bodhaine's refractive index, King factor and
    number density, the formula reproduces his cross sections to 4e-4 (the Lorentz–Lorenz
    factor ``(3/(n² + 2))²`` it omits); both measured in ``tests/test_scattering.py``.
    Computed in float64; the result has the precision of ``wavelength`` (float32 in →
    float32 out).

    Examples
    --------
    >>> f"{float(rayleigh_scattering(650.0)):.3g}"
    '6.95e-06'
    """
    lam_in = _wavelength(wavelength)
    lam = lam_in.astype(np.float64) * 1e-9
    n = check_range(refractive_index, "refractive_index", 1.0, np.inf)
    N = check_positive(number_density, "number_density", unit="m^-3")
    p = check_range(depolarization, "depolarization", 0.0, 6.0 / 7.0, high_inclusive=False)
    n2m1 = (n - 1.0) * (n + 1.0)  # n² − 1 without cancellation
    king = (6.0 + 3.0 * p) / (6.0 - 7.0 * p)
    return _like_input(8.0 * np.pi**3 * n2m1**2 / (3.0 * N * lam**4) * king, lam_in)


# K(λ): seed 004 quotes Bullrich (1964) through Preetham: 0.656 at 400 nm rising to 0.69 at
# 770 nm.  The published table is not reproduced in the seeds; we interpolate linearly
# between those two end points and hold the end values outside [400, 770] nm.  The
# resulting spectral shape differs from a constant K by < 5 % over the visible.
_K_NODES = (np.array([400.0, 770.0]), np.array([0.656, 0.69]))


def junge_k_factor(wavelength):
    """Junge-law factor K(λ) [-] of the haze scattering formula (seed 002 Eq. 3.1, seed 004).

    Linear in wavelength from 0.656 at 400 nm to 0.69 at 770 nm (the two values seed 004
    quotes from Bullrich 1964), constant outside that range.
    """
    lam = _wavelength(wavelength)
    return np.interp(lam, *_K_NODES)


def _junge_shape(lam, v):
    # β ∝ λ^{-(v−2)} K(λ)   (seed 002 Eq. 3.1, seed 004; the magnitude comes from turbidity)
    return lam ** (-(v - 2.0)) * junge_k_factor(lam)


def mie_scattering(
    wavelength,
    *,
    turbidity=2.0,
    reference_wavelength=550.0,
    molecular_scale_height=8000.0,
    haze_scale_height=1200.0,
    junge_exponent=4.0,
):
    r"""Sea-level haze (Mie) scattering coefficient fixed by the turbidity.

    Shape: the Junge law of seeds 002/004, ``β_h(λ) ∝ λ^{−(v−2)} K(λ)``.  Magnitude:
    Preetham et al. (1999) define turbidity as ``T = (τ_m + τ_h)/τ_m`` (errata 004.3), so
    at the reference wavelength

    .. math:: \beta_h(\lambda_\mathrm{ref}) H_h = (T - 1)\, \beta_R(\lambda_\mathrm{ref}) H_m

    with vertical optical depths written as sea-level coefficient × scale height.

    Parameters
    ----------
    wavelength : array_like
        Wavelength [nm], > 0.
    turbidity : array_like
        Turbidity ``T`` [-], ≥ 1 (1 = no haze; ≈2 very clear, ≈6 hazy, ≥10 very hazy).
    reference_wavelength : float
        Wavelength [nm] at which the turbidity ratio holds (default 550 nm).
    molecular_scale_height, haze_scale_height : float
        Exponential scale heights [m] used to turn coefficients into vertical optical
        depths (defaults 8000 and 1200, Bruneton 2017; seed 000 uses optical lengths
        8400 and 1250, ratio 6.72 vs 6.67).
    junge_exponent : float
        Junge exponent ``v`` [-] (default 4, seeds 002/004), > 2.

    Returns
    -------
    ndarray or float
        Haze scattering coefficient at sea level [m⁻¹]; 0 for ``T = 1``.

    Notes
    -----
    The literal seed formula ``0.434 c π (2π/λ)^{v−2} K`` with Preetham's ``c(T)`` and λ in
    metres gives values orders of magnitude above seed 000's haze table (errata 004.3), so
    only its spectral shape is used.  The molecular optical depth uses
    :func:`rayleigh_scattering` with its defaults.  For ``T = 2`` and the defaults this gives
    β_h(550 nm) ≈ 9.0e-5 m⁻¹ — between seed 000's light and heavy haze rows.
    """
    lam_in = _wavelength(wavelength)
    lam = lam_in.astype(np.float64)
    T = check_range(turbidity, "turbidity", 1.0, np.inf)
    lam_ref = float(_wavelength(reference_wavelength))
    Hm = check_positive(molecular_scale_height, "molecular_scale_height", unit="m")
    Hh = check_positive(haze_scale_height, "haze_scale_height", unit="m")
    v = check_range(junge_exponent, "junge_exponent", 2.0, np.inf, low_inclusive=False)
    beta_ref = (T - 1.0) * rayleigh_scattering(lam_ref) * Hm / Hh
    return _like_input(beta_ref * _junge_shape(lam, v) / _junge_shape(lam_ref, v), lam_in)


def mie_absorption(wavelength, *, single_scattering_albedo=0.9, **mie_kwargs):
    """Haze absorption coefficient [m⁻¹] for a given single-scattering albedo ω.

    ``β_abs = β_sca (1 − ω)/ω`` with ``β_sca`` from :func:`mie_scattering` (keywords are
    passed on).  Default ω = 0.9 (Bruneton 2017).  ``ω`` must be in (0, 1].
    """
    w = check_range(single_scattering_albedo, "single_scattering_albedo", 0.0, 1.0, low_inclusive=False)
    sca = mie_scattering(wavelength, **mie_kwargs)
    return _like_input(sca * (1.0 - w) / w, np.asarray(sca))


@lru_cache(maxsize=1)
def _ozone_table():
    path = resources.files("atmoscatter") / "data" / "ozone_cross_section.csv"
    data = np.loadtxt(str(path), delimiter=",", comments="#")
    return data[:, 0], data[:, 1]


def ozone_absorption(wavelength, *, column=300.0, layer_thickness=15000.0):
    """Peak ozone absorption coefficient [m⁻¹] for a column of ``column`` Dobson units.

    Cross-sections [m²] at 233 K (Serdyuchenko et al. 2014, averaged over 10 nm bins from
    360 to 830 nm; shipped in ``atmoscatter/data/ozone_cross_section.csv``), interpolated
    linearly in wavelength and held constant outside the table.  The number density at the
    peak is ``column·DU / layer_thickness``, where ``layer_thickness`` [m] is the integral of
    the relative density profile (15 km for the 10–25–40 km tent of Bruneton 2017).

    Parameters
    ----------
    wavelength : array_like
        Wavelength [nm].
    column : float
        Total ozone column [DU] (default 300), ≥ 0.
    layer_thickness : float
        Integral of the relative density profile [m] (default 15000).
    """
    lam = _wavelength(wavelength)
    col = check_positive(column, "column", allow_zero=True, unit="DU")
    thick = check_positive(layer_thickness, "layer_thickness", unit="m")
    wl, sigma = _ozone_table()
    return _like_input(np.interp(lam, wl, sigma) * col * DOBSON_UNIT / thick, lam)

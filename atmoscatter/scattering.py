"""Scattering and absorption coefficients of air molecules, haze and ozone.

Public objects
--------------
- :func:`rayleigh_scattering`: total Rayleigh scattering coefficient of a gas [m⁻¹]
  (the seed formula with the King factor; seed-000 constants by default).
- :func:`rayleigh_scattering_standard_air`: Rayleigh scattering of real dry air
  (Bodhaine et al. 1999: Peck & Reeder refractivity, Bates King factor, CO₂ 360 ppm).
- :func:`air_king_factor`: King correction factor of dry air (Bodhaine et al. 1999).
- :data:`STANDARD_AIR_SCALE_HEIGHT`: exponential scale height that gives standard air's
  sea-level column (Bodhaine's ``P A/(m_a g)``).
- :func:`junge_k_factor`, :func:`haze_extinction`, :func:`mie_scattering`,
  :func:`mie_absorption`: haze (aerosol) coefficients with the Junge spectral shape, whose
  *extinction* is fixed by the turbidity ``T = (τ_m + τ_h)/τ_m`` at 550 nm.
- :func:`ozone_absorption`: ozone absorption coefficient from a shipped cross-section table.

References
----------
- Seeds 000, 002, 004 (Rayleigh with the King correction factor; Junge/Mie shape).
- Preetham, A. J., Shirley, P. & Smits, B. (1999). A practical analytic model for daylight.
  SIGGRAPH 99 (turbidity ``T = (τ_m + τ_h)/τ_m``; errata 004.3).
- Bodhaine, B. A., Wood, N. B., Dutton, E. G. & Slusser, J. R. (1999). On Rayleigh optical
  depth calculations. J. Atmos. Oceanic Technol. 16, 1854–1861 (their Eqs. for the
  refractivity of air after Peck & Reeder 1972 with the CO₂ correction, the King factor of
  air after Bates 1984, the cross section with the Lorentz–Lorenz factor, the sea-level
  column ``P A/(m_a g)`` with g at the column's mass-weighted height; Table 3).
- Peck, E. R. & Reeder, K. (1972). Dispersion of air. JOSA 62, 958–962.
- Bates, D. R. (1984). Rayleigh scattering by air. Planet. Space Sci. 32, 785–790.
- Bucholtz, A. (1995). Rayleigh-scattering calculations for the terrestrial atmosphere.
  Appl. Opt. 34, 2765–2773 (standard air 288.15 K, 1013.25 hPa; same physics).
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
    "rayleigh_scattering_standard_air",
    "air_king_factor",
    "STANDARD_AIR_TEMPERATURE",
    "STANDARD_AIR_PRESSURE",
    "STANDARD_CO2_PPM",
    "STANDARD_AIR_SCALE_HEIGHT",
    "TURBIDITY_REFERENCE_WAVELENGTH",
    "junge_k_factor",
    "haze_extinction",
    "mie_scattering",
    "mie_absorption",
    "ozone_absorption",
    "DOBSON_UNIT",
]

#: Molecules per m² in one Dobson unit [m⁻²] (WMO definition: 2.6867e20).
DOBSON_UNIT: float = 2.6867e20

#: Temperature of standard air [K] (Bodhaine et al. 1999; Bucholtz 1995): 15 °C.
STANDARD_AIR_TEMPERATURE: float = 288.15
#: Pressure of standard air [Pa] (1013.25 hPa, Bodhaine et al. 1999; Bucholtz 1995).
STANDARD_AIR_PRESSURE: float = 101325.0
#: CO₂ mixing ratio of Bodhaine et al.'s (1999) Table 3 [ppm by volume].
STANDARD_CO2_PPM: float = 360.0
#: Wavelength [nm] at which the turbidity ``T = (τ_m + τ_h)/τ_m`` is defined in this package.
#: Preetham et al. (1999) and errata 004.3 give the ratio but not a wavelength; 550 nm is the
#: customary reference of aerosol optical depth and visual range (near the photopic peak).
TURBIDITY_REFERENCE_WAVELENGTH: float = 550.0

_BOLTZMANN = 1.380649e-23  # [J K⁻¹] (SI 2019, exact)
_AVOGADRO = 6.02214076e23  # [mol⁻¹] (SI 2019, exact)


def _bodhaine_column_gravity(latitude_deg: float = 45.0, altitude: float = 0.0) -> float:
    """Gravity [m s⁻²] Bodhaine et al. (1999) use for the column above ``altitude`` [m].

    Their Eqs. (10)–(11) (List 1968): sea-level ``g₀(φ)`` and its height dependence,
    evaluated at the mass-weighted column height ``z_c = 0.73737 z + 5517.56`` m.
    """
    c2 = np.cos(np.radians(2.0 * latitude_deg))
    g0 = 980.6160 * (1.0 - 0.0026373 * c2 + 0.0000059 * c2**2)  # [cm s⁻²]
    zc = 0.73737 * altitude + 5517.56  # [m]
    g = (g0 - (3.085462e-4 + 2.27e-7 * c2) * zc + (7.254e-11 + 1.0e-13 * c2) * zc**2
         - (1.517e-17 + 6e-20 * c2) * zc**3)
    return float(g) / 100.0


def _air_molar_mass(co2_ppm: float) -> float:
    """Mean molar mass of dry air [kg mol⁻¹] (Bodhaine et al. 1999: 15.0556 C + 28.9595 g)."""
    return (15.0556 * co2_ppm * 1e-6 + 28.9595) * 1e-3


#: Sea-level column of standard air [m⁻²]: ``P A/(m_a g)`` of Bodhaine et al. (1999) at
#: 1013.25 hPa, 45° latitude, 360 ppm CO₂ (g at the column's mass-weighted height).
_STANDARD_AIR_COLUMN: float = STANDARD_AIR_PRESSURE * _AVOGADRO / (
    _air_molar_mass(STANDARD_CO2_PPM) * _bodhaine_column_gravity())
#: Number density of standard air [m⁻³]: ``P/(k_B T)`` at 288.15 K, 101325 Pa (2.5469e25;
#: Bodhaine et al. 1999 quote 2.546899e19 cm⁻³).
_STANDARD_AIR_NUMBER_DENSITY: float = STANDARD_AIR_PRESSURE / (_BOLTZMANN * STANDARD_AIR_TEMPERATURE)

#: Scale height [m] of an exponential molecular profile that holds standard air's sea-level
#: column over the standard-air number density: ``H = [P A/(m_a g)] / N_s`` = ``k T/(m g)``
#: with Bodhaine et al.'s (1999) column gravity (45°, sea level) — about 8.45 km.  With it the
#: vertical Rayleigh optical depth ``β_R(sea level)·H`` is Bodhaine's ``σ P A/(m_a g)``
#: (0.0971 at 550 nm), where an 8 km scale height would give 5 % less.
STANDARD_AIR_SCALE_HEIGHT: float = _STANDARD_AIR_COLUMN / _STANDARD_AIR_NUMBER_DENSITY


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


def _air_refractivity_300ppm(lam_um):
    """``n_s − 1`` of standard air with 300 ppm CO₂ (Peck & Reeder 1972; Bodhaine Eq. 4)."""
    s2 = lam_um**-2
    return (8060.51 + 2480990.0 / (132.274 - s2) + 17455.7 / (39.32957 - s2)) * 1e-8


def air_king_factor(wavelength, *, co2_ppm=STANDARD_CO2_PPM):
    """King correction factor ``F_air(λ)`` of dry air [-] (Bodhaine et al. 1999, Eq. 23).

    Volume-weighted mean of N₂ (78.084 %), O₂ (20.946 %), Ar (0.934 %, F = 1) and CO₂
    (F = 1.15), with Bates' (1984) dispersion ``F_N₂ = 1.034 + 3.17e-4 λ⁻²`` and
    ``F_O₂ = 1.096 + 1.385e-3 λ⁻² + 1.448e-4 λ⁻⁴`` (λ in µm).  1.0488 at 550 nm.

    Parameters
    ----------
    wavelength : array_like
        Wavelength [nm], > 0 (Bates' fits cover 200–1000 nm and beyond in the IR).
    co2_ppm : float
        CO₂ mixing ratio [ppm], ≥ 0 (default 360, Bodhaine's Table 3).

    Returns
    -------
    ndarray
        King factor [-], in the shape of ``wavelength``.
    """
    lam_in = _wavelength(wavelength)
    l2 = (lam_in.astype(np.float64) * 1e-3) ** -2
    c = float(check_positive(co2_ppm, "co2_ppm", allow_zero=True, unit="ppm")) * 1e-4  # [%]
    f_n2 = 1.034 + 3.17e-4 * l2
    f_o2 = 1.096 + 1.385e-3 * l2 + 1.448e-4 * l2**2
    f = (78.084 * f_n2 + 20.946 * f_o2 + 0.934 + 1.15 * c) / (78.084 + 20.946 + 0.934 + c)
    return _like_input(f, lam_in)


def rayleigh_scattering_standard_air(
    wavelength,
    *,
    temperature=STANDARD_AIR_TEMPERATURE,
    pressure=STANDARD_AIR_PRESSURE,
    co2_ppm=STANDARD_CO2_PPM,
):
    r"""Rayleigh scattering coefficient of real dry air (Bodhaine et al. 1999).

    .. math:: \sigma(\lambda) = \frac{24\pi^3 (n_s^2 - 1)^2}{\lambda^4 N_s^2 (n_s^2 + 2)^2}
              F_\mathrm{air}(\lambda), \qquad \beta_R = \sigma\, \frac{p}{k_B T}

    ``n_s`` is the refractive index of standard air (288.15 K, 1013.25 hPa) after Peck &
    Reeder (1972) with Bodhaine's CO₂ correction ``(n − 1) ∝ 1 + 0.54 (C − 0.0003)``,
    ``N_s = P_s/(k_B T_s)`` its number density, ``F_air`` the King factor
    (:func:`air_king_factor`).  The cross section σ is independent of the density
    (Lorentz–Lorenz), so the coefficient scales with the ideal-gas number density ``p/(k_B T)``.

    Parameters
    ----------
    wavelength : array_like
        Wavelength [nm], > 0 (Peck & Reeder's fit: 230–1690 nm).
    temperature : array_like
        Air temperature [K], > 0 (default 288.15).
    pressure : array_like
        Air pressure [Pa], > 0 (default 101325).
    co2_ppm : float
        CO₂ mixing ratio [ppm] (default 360).

    Returns
    -------
    ndarray or float
        Scattering coefficient [m⁻¹], broadcast over the inputs.

    Notes
    -----
    At 550 nm and the defaults: σ = 4.511e-31 m², β = 1.149e-5 m⁻¹ — 15 % below the seed-000
    constants of :func:`rayleigh_scattering` (1.356e-5 m⁻¹).  Accuracy: reproduces the
    optical depths of Bodhaine et al. (1999) Table 3 (σ times their column) to < 2e-4 over
    400–700 nm, and Nicolet's (1984) fit to Bates (1984) within its stated ±0.5 %; both
    checked in ``tests/test_scattering.py``.  Same physics as Bucholtz (1995), whose
    standard-air coefficients differ by a few tenths of a percent (Edlén refractivity,
    another King factor).

    Examples
    --------
    >>> f"{float(rayleigh_scattering_standard_air(550.0)):.4g}"
    '1.149e-05'
    """
    lam_in = _wavelength(wavelength)
    lam_um = lam_in.astype(np.float64) * 1e-3
    T = check_positive(temperature, "temperature", unit="K")
    p = check_positive(pressure, "pressure", unit="Pa")
    c = float(check_positive(co2_ppm, "co2_ppm", allow_zero=True, unit="ppm"))
    nm1 = _air_refractivity_300ppm(lam_um) * (1.0 + 0.54 * (c * 1e-6 - 0.0003))
    n2m1 = nm1 * (nm1 + 2.0)  # n² − 1
    n2p2 = n2m1 + 3.0  # n² + 2
    Ns = _STANDARD_AIR_NUMBER_DENSITY
    lam_m = lam_um * 1e-6
    sigma = 24.0 * np.pi**3 * n2m1**2 / (lam_m**4 * Ns**2 * n2p2**2) * air_king_factor(lam_in, co2_ppm=c)
    return _like_input(sigma * p / (_BOLTZMANN * T), lam_in)


# K(λ): seed 004 quotes Bullrich (1964) through Preetham: 0.656 at 400 nm rising to 0.69 at
# 770 nm.  The published table is not reproduced in the seeds; we interpolate linearly
# between those two end points and hold the end values outside [400, 770] nm.  The
# resulting spectral shape differs from a constant K by < 5 % over the visible.
_K_NODES = (np.array([400.0, 770.0]), np.array([0.656, 0.69]))


def junge_k_factor(wavelength):
    """Junge-law factor K(λ) [-] of the haze scattering formula (seed 002 Eq. 3.1, seed 004).

    Linear in wavelength from 0.656 at 400 nm to 0.69 at 770 nm (the two values seed 004
    quotes from Bullrich 1964), constant outside that range.

    Parameters
    ----------
    wavelength : array_like
        Wavelength [nm].

    Returns
    -------
    ndarray
        K(λ) [-].
    """
    lam = _wavelength(wavelength)
    return np.interp(lam, *_K_NODES)


def _junge_shape(lam, v):
    # β ∝ λ^{-(v−2)} K(λ)   (seed 002 Eq. 3.1, seed 004; the magnitude comes from turbidity)
    return lam ** (-(v - 2.0)) * junge_k_factor(lam)


def haze_extinction(
    wavelength,
    *,
    turbidity=2.0,
    reference_wavelength=TURBIDITY_REFERENCE_WAVELENGTH,
    molecular_scattering=None,
    molecular_scale_height=STANDARD_AIR_SCALE_HEIGHT,
    haze_scale_height=1200.0,
    junge_exponent=4.0,
):
    r"""Sea-level haze (aerosol) *extinction* coefficient fixed by the turbidity.

    Turbidity is the ratio of the total to the molecular vertical optical depth (Preetham
    et al. 1999; errata 004.3), ``T = (τ_m + τ_h)/τ_m``, with τ_m the molecular (Rayleigh)
    *scattering* optical depth and τ_h the haze *extinction* (scattering + absorption)
    optical depth, both at ``reference_wavelength`` (550 nm).  Ozone absorption is not part
    of τ_m.  With optical depths written as sea-level coefficient × column length:

    .. math:: \beta_{h,\mathrm{ext}}(\lambda_\mathrm{ref})\, H_h
              = (T - 1)\, \beta_R(\lambda_\mathrm{ref})\, H_m

    and the Junge spectral shape of seeds 002/004, ``β_h(λ) ∝ λ^{−(v−2)} K(λ)``.

    Parameters
    ----------
    wavelength : array_like
        Wavelength [nm], > 0.
    turbidity : array_like
        Turbidity ``T`` [-], ≥ 1 (1 = no haze; ≈2 very clear, ≈3 clear, ≈6 hazy).
    reference_wavelength : float
        Wavelength [nm] at which the turbidity ratio holds (default 550 nm,
        :data:`TURBIDITY_REFERENCE_WAVELENGTH`).  At other wavelengths the ratio follows from
        the two spectral shapes (≈ λ⁻⁴ for air, ≈ λ⁻¹·⁹ for the haze).
    molecular_scattering : float, optional
        Molecular scattering coefficient at sea level and ``reference_wavelength`` [m⁻¹];
        default :func:`rayleigh_scattering_standard_air` (1.149e-5 m⁻¹ at 550 nm).  Pass the
        air coefficient of the model that uses the haze, so T refers to *its* air.
    molecular_scale_height, haze_scale_height : float
        Column lengths ``∫ρ(z)dz`` of the relative density profiles [m] — the scale height
        for an exponential profile of unbounded extent (defaults
        :data:`STANDARD_AIR_SCALE_HEIGHT` ≈ 8.45 km and 1.2 km, Bruneton 2017).
    junge_exponent : float
        Junge exponent ``v`` [-] (default 4, seeds 002/004), > 2.

    Returns
    -------
    ndarray or float
        Haze extinction coefficient at sea level [m⁻¹]; 0 for ``T = 1``.

    Notes
    -----
    The literal seed formula ``0.434 c π (2π/λ)^{v−2} K`` with Preetham's ``c(T)`` and λ in
    metres gives values orders of magnitude above seed 000's haze table (errata 004.3), so
    only its spectral shape is used.  The shape's Ångström exponent is
    ``α = v − 2 − d ln K/d ln λ`` ≈ 1.92 at 550 nm for v = 4 — bluer than typical continental
    aerosol (α ≈ 1–1.5, Ångström 1929's 1.3), as in Preetham et al. (1999).  For ``T = 2`` and
    the defaults: β_h(550 nm) = 8.09e-5 m⁻¹ (τ_h = 0.0971).
    """
    lam_in = _wavelength(wavelength)
    lam = lam_in.astype(np.float64)
    T = check_range(turbidity, "turbidity", 1.0, np.inf)
    lam_ref = float(_wavelength(reference_wavelength))
    Hm = check_positive(molecular_scale_height, "molecular_scale_height", unit="m")
    Hh = check_positive(haze_scale_height, "haze_scale_height", unit="m")
    v = check_range(junge_exponent, "junge_exponent", 2.0, np.inf, low_inclusive=False)
    if molecular_scattering is None:
        b_m = float(rayleigh_scattering_standard_air(lam_ref))
    else:
        b_m = check_positive(molecular_scattering, "molecular_scattering", unit="m^-1")
    beta_ref = (T - 1.0) * b_m * Hm / Hh
    return _like_input(beta_ref * _junge_shape(lam, v) / _junge_shape(lam_ref, v), lam_in)


def mie_scattering(wavelength, *, turbidity=2.0, single_scattering_albedo=0.9, **haze_kwargs):
    r"""Sea-level haze (Mie) *scattering* coefficient [m⁻¹] for a turbidity.

    ``β_sca = ω β_ext`` with the extinction ``β_ext`` of :func:`haze_extinction` (which
    fixes ``T = (τ_m + τ_h)/τ_m`` by *extinction*; keywords are passed on), so scattering
    plus :func:`mie_absorption` with the same ω is the turbidity's haze.

    Parameters
    ----------
    wavelength : array_like
        Wavelength [nm], > 0.
    turbidity : array_like
        Turbidity ``T`` [-], ≥ 1.
    single_scattering_albedo : float
        Haze single-scattering albedo ω [-], in (0, 1] (default 0.9: Bruneton 2017; OPAC's
        continental-polluted aerosol has 0.89 at 550 nm and 80 % humidity, Hess et al. 1998).
    **haze_kwargs
        ``reference_wavelength``, ``molecular_scattering``, ``molecular_scale_height``,
        ``haze_scale_height``, ``junge_exponent`` (see :func:`haze_extinction`).

    Returns
    -------
    ndarray or float
        Haze scattering coefficient at sea level [m⁻¹]; 0 for ``T = 1``.
    """
    w = check_range(single_scattering_albedo, "single_scattering_albedo", 0.0, 1.0, low_inclusive=False)
    ext = haze_extinction(wavelength, turbidity=turbidity, **haze_kwargs)
    return _like_input(ext * w, np.asarray(ext))


def mie_absorption(wavelength, *, turbidity=2.0, single_scattering_albedo=0.9, **haze_kwargs):
    """Haze absorption coefficient [m⁻¹]: ``(1 − ω) β_ext`` (:func:`haze_extinction`).

    With the same arguments, ``mie_scattering + mie_absorption = haze_extinction``: the
    turbidity fixes the extinction whatever ω is.  Default ω = 0.9 (Bruneton 2017);
    ``ω`` must be in (0, 1].

    Parameters
    ----------
    wavelength : array_like
        Wavelength [nm].
    turbidity : float
        Turbidity [-], ≥ 1.
    single_scattering_albedo : float
        ω [-], in (0, 1].
    **haze_kwargs
        Further arguments of :func:`haze_extinction`.

    Returns
    -------
    ndarray
        Absorption coefficient at sea level [m⁻¹].
    """
    w = check_range(single_scattering_albedo, "single_scattering_albedo", 0.0, 1.0, low_inclusive=False)
    ext = haze_extinction(wavelength, turbidity=turbidity, **haze_kwargs)
    return _like_input(ext * (1.0 - w), np.asarray(ext))


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

    Returns
    -------
    ndarray
        Absorption coefficient at the peak of the ozone layer [m⁻¹].
    """
    lam = _wavelength(wavelength)
    col = check_positive(column, "column", allow_zero=True, unit="DU")
    thick = check_positive(layer_thickness, "layer_thickness", unit="m")
    wl, sigma = _ozone_table()
    return _like_input(np.interp(lam, wl, sigma) * col * DOBSON_UNIT / thick, lam)

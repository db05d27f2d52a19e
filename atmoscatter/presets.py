"""Ready-made atmospheres with cited constants.

Public objects
--------------
- :func:`earth_atmosphere`: Earth with real (standard) air and Bruneton's (2017) aerosol,
  ozone and radii (errata "reference constants"); ``rayleigh="bruneton"`` for his air.
- :func:`bruneton_atmosphere`: Bruneton's (2017) Earth exactly as published (seed-000 air).
- :func:`earth_turbidity_atmosphere`: Earth whose haze *extinction* is set by the turbidity
  ``T = (τ_m + τ_h)/τ_m`` at 550 nm (Preetham 1999; errata 004.3).
- :data:`EARTH_RAYLEIGH`: the air models the Earth presets accept.
- :func:`mars_atmosphere`: a Mars-like atmosphere (CO₂ Rayleigh + dust).
- :func:`keller_bohn_atmosphere`: reproduces the parameters of seed 002 (labelled look).
- :data:`PRESETS`: name → constructor registry (used by scenes and the CLI).

References
----------
- Bruneton, E. (2017). Precomputed atmospheric scattering: a new implementation.
  Planet radius 6360 km, top 6420 km, Rayleigh scale height 8 km, Mie scale height 1.2 km,
  Mie single-scattering albedo 0.9, g = 0.8, ozone 300 DU in a 10–25–40 km tent.
- NASA Mars Fact Sheet (Williams, D. R., NSSDCA, 2024): mean radius 3389.5 km, surface
  pressure 6.36 mbar, scale height 11.1 km, surface temperature ≈ 210 K.
- Sneep, M. & Ubachs, W. (2005). Direct measurement of the Rayleigh scattering cross section
  in various gases. JQSRT 92, 293–310: CO₂ King factor ≈ 1.14 (depolarisation ≈ 0.08).
- Old, J. G., Gentili, K. L. & Peck, E. R. (1971), JOSA 61, 89: CO₂ refractivity
  (n − 1) ≈ 4.49e-4 at 0 °C, 1 atm (N = 2.687e25 m⁻³).
- Lemmon, M. T. et al. (2004). Atmospheric imaging results from the Mars Exploration Rovers.
  Science 306, 1753: visible dust optical depth typically 0.3–1 (we take 0.5).
- Tomasko, M. G. et al. (1999), JGR 104, 8987, and Wolff, M. J. et al. (2009), JGR 114:
  Martian dust asymmetry g ≈ 0.6–0.7 and single-scattering albedo ≈ 0.97 in the red,
  lower in the blue.
- Keller, P. & Bohn, C.-A. (seed 002): Earth radii, scale heights 8 km / 1.2 km,
  Rayleigh ∝ λ⁻⁴, Mie ∝ λ⁻² (Table 1), three RGB samples.
- Bodhaine, B. A. et al. (1999). On Rayleigh optical depth calculations. JAOT 16, 1854:
  standard air (:func:`atmoscatter.rayleigh_scattering_standard_air`), sea-level Rayleigh
  optical depth 0.0971 at 550 nm (their Table 3).
- Hess, M., Koepke, P. & Schult, I. (1998). Optical properties of aerosols and clouds: the
  software package OPAC. BAMS 79, 831–844: continental aerosols at 550 nm have
  single-scattering albedo ≈ 0.89 (continental polluted, 80 % humidity; OPAC 3.1 output) to
  ≈ 0.97 (clean) and asymmetry g ≈ 0.70.

Aerosol model behind the turbidity
----------------------------------
:func:`earth_turbidity_atmosphere` uses one aerosol type whose amount is set by ``T``:

- **Amount**: vertical haze extinction optical depth ``τ_h = (T − 1) τ_m`` at 550 nm, τ_m the
  preset's own Rayleigh optical depth there (0.0971 for standard air), both integrated over
  the preset's exact profiles from the ground to the top (errata 004.3).
- **Spectral shape (size distribution)**: the Junge power law of seeds 002/004 with
  exponent v = 4, ``β ∝ λ^{−(v−2)} K(λ)`` with Bullrich's K(λ) (0.656 at 400 nm to 0.69 at
  770 nm, via seed 004): an Ångström exponent ≈ 1.9 at 550 nm.
- **Absorption**: single-scattering albedo ω = 0.9 at every wavelength (Bruneton 2017;
  within the OPAC continental range 0.89–0.97 of Hess et al. 1998), i.e. 10 % of the haze
  extinction is absorption — the turbidity counts it (extinction, not scattering).
- **Phase function**: Henyey–Greenstein with g = 0.8 (Bruneton 2017; more forward than
  OPAC's continental g ≈ 0.70 at 550 nm — pass ``g=0.7`` for that aerosol).
- **Vertical profile**: exponential, 1.2 km scale height (Bruneton 2017).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np

from ._validate import as_float_array, check_option, check_positive, check_range
from .atmosphere import Atmosphere, Constituent
from .phase import HenyeyGreensteinPhase, RayleighPhase
from .profiles import ExponentialProfile, TentProfile
from .scattering import (
    STANDARD_AIR_SCALE_HEIGHT,
    TURBIDITY_REFERENCE_WAVELENGTH,
    haze_extinction,
    ozone_absorption,
    rayleigh_scattering,
    rayleigh_scattering_standard_air,
)

__all__ = [
    "EARTH_PLANET_RADIUS",
    "EARTH_TOP_RADIUS",
    "EARTH_RAYLEIGH",
    "earth_atmosphere",
    "bruneton_atmosphere",
    "earth_turbidity_atmosphere",
    "mars_atmosphere",
    "keller_bohn_atmosphere",
    "PRESETS",
    "atmosphere_preset",
]

#: Earth ground radius [m] (Bruneton 2017).
EARTH_PLANET_RADIUS: float = 6.36e6
#: Earth top-of-atmosphere radius [m] (Bruneton 2017).
EARTH_TOP_RADIUS: float = 6.42e6
_RGB = (680.0, 550.0, 440.0)

# Bruneton (2017) Mie: Ångström β = 5.328e-3 at α = 0 gives a wavelength-independent
# extinction k·β/H = 5.328e-3/1200 m = 4.44e-6 m⁻¹; scattering = 0.9 × extinction.
_BRUNETON_MIE_EXTINCTION = 5.328e-3 / 1200.0
#: Haze (aerosol) scale height [m] (Bruneton 2017).
_HAZE_SCALE_HEIGHT = 1200.0


def _wl(wavelengths) -> np.ndarray:
    wl = check_positive(as_float_array(wavelengths, "wavelengths"), "wavelengths", unit="nm")
    return np.atleast_1d(wl).astype(float)


#: Air models of the Earth presets: ``"standard"`` — real dry air (Bodhaine et al. 1999,
#: :func:`rayleigh_scattering_standard_air`, 288.15 K, 1013.25 hPa, 360 ppm CO₂) with the
#: scale height :data:`STANDARD_AIR_SCALE_HEIGHT` ≈ 8.45 km that holds its sea-level
#: column (τ_R(550 nm) = 0.0970); ``"bruneton"`` — the seed-000 constants of
#: :func:`rayleigh_scattering` (n = 1.0003, N = 2.545e25 m⁻³, p_n = 0.035; within 1 % of
#: Bruneton's 5.802, 13.558, 33.1 e-6 m⁻¹ at 680/550/440 nm) with an 8 km scale height
#: (τ_R(550 nm) = 0.108, 12 % above real air), for comparison with the literature.
EARTH_RAYLEIGH: dict[str, str] = {
    "standard": "real dry air, Bodhaine et al. (1999), scale height 8.45 km",
    "bruneton": "Bruneton (2017) / seed 000 constants, scale height 8 km",
}


def _rayleigh_model(rayleigh: str):
    """(β_R(λ) callable, scale height [m]) of the named air model."""
    check_option(rayleigh, "rayleigh", EARTH_RAYLEIGH)
    if rayleigh == "standard":
        return rayleigh_scattering_standard_air, STANDARD_AIR_SCALE_HEIGHT
    return rayleigh_scattering, 8000.0


def _rayleigh(wl, rayleigh: str = "standard") -> Constituent:
    beta, h = _rayleigh_model(rayleigh)
    return Constituent(
        name="rayleigh",
        scattering=beta(wl),
        absorption=0.0,
        profile=ExponentialProfile(h),
        phase=RayleighPhase(),
    )


def _column_length(scale_height: float, thickness: float) -> float:
    """``∫₀^Z e^{−z/H} dz = H (1 − e^{−Z/H})`` [m]: the exact vertical column of an
    exponential profile in an atmosphere ``Z`` thick (``−expm1`` avoids cancellation)."""
    return -scale_height * float(np.expm1(-thickness / scale_height))


def _ozone(wl) -> Constituent:
    return Constituent(
        name="ozone",
        scattering=np.zeros_like(wl),
        absorption=ozone_absorption(wl),
        profile=TentProfile(25e3, 15e3),
        phase=RayleighPhase(),
    )


def earth_atmosphere(
    wavelengths: Sequence[float] = _RGB, *, ozone: bool = True, rayleigh: str = "standard"
) -> Atmosphere:
    """Earth's clear atmosphere: real air with Bruneton's (2017) aerosol, ozone and radii.

    Rayleigh (``rayleigh="standard"``, the default): real dry air after Bodhaine et al.
    (1999) — 4.26e-5, 1.149e-5, 4.31e-6 m⁻¹ at 400/550/700 nm at sea level
    (:func:`rayleigh_scattering_standard_air`) — with the scale height
    :data:`STANDARD_AIR_SCALE_HEIGHT` ≈ 8.45 km, so the vertical Rayleigh optical depth is
    0.0970 at 550 nm (Bodhaine's Table 3: 0.09707; the 60 km top removes 8e-4 of it).
    ``rayleigh="bruneton"``: the seed-000 constants (5.8e-6, 1.35e-5, 3.3e-5 m⁻¹ at
    680/550/440 nm; Bruneton uses 5.802, 13.558, 33.1 e-6) with an 8 km scale height —
    14–20 % above real air per molecule, 12 % in optical depth (see :data:`EARTH_RAYLEIGH`).
    Mie: extinction 4.44e-6 m⁻¹ (wavelength independent), albedo 0.9, HG g = 0.8, scale
    height 1.2 km (Bruneton 2017); optional ozone (300 DU, tent 10–25–40 km).

    Parameters
    ----------
    wavelengths : sequence of float
        Sample wavelengths [nm] (default 680, 550, 440: R, G, B).
    ozone : bool
        Include ozone absorption (needs wavelengths within 360–830 nm for meaningful
        values; the table is held constant outside).
    rayleigh : {"standard", "bruneton"}
        Air model (:data:`EARTH_RAYLEIGH`).

    Returns
    -------
    Atmosphere
        Air, aerosol and (optionally) ozone between 6360 and 6420 km radius.
    """
    wl = _wl(wavelengths)
    mie_ext = np.full_like(wl, _BRUNETON_MIE_EXTINCTION)
    cons = [
        _rayleigh(wl, rayleigh),
        Constituent(
            name="mie",
            scattering=0.9 * mie_ext,
            absorption=0.1 * mie_ext,
            profile=ExponentialProfile(1200.0),
            phase=HenyeyGreensteinPhase(0.8),
        ),
    ]
    if ozone:
        cons.append(_ozone(wl))
    name = "earth" if rayleigh == "standard" else "bruneton"
    return Atmosphere(EARTH_PLANET_RADIUS, EARTH_TOP_RADIUS, tuple(wl), tuple(cons), name=name)


def bruneton_atmosphere(wavelengths: Sequence[float] = _RGB, *, ozone: bool = True) -> Atmosphere:
    """Bruneton's (2017) reference Earth as published: ``earth_atmosphere(rayleigh="bruneton")``.

    Seed-000 Rayleigh constants with an 8 km scale height (τ_R(550 nm) = 0.108), Mie and
    ozone as in :func:`earth_atmosphere`.  For comparisons with the literature that uses
    these constants (Bruneton & Neyret 2008, Bruneton 2017 and renderers built on them).

    Parameters
    ----------
    wavelengths : sequence of float
        Sample wavelengths [nm] (default 680, 550, 440: R, G, B).
    ozone : bool
        Include ozone absorption.

    Returns
    -------
    Atmosphere
        The atmosphere (radii 6360/6420 km).
    """
    return earth_atmosphere(wavelengths, ozone=ozone, rayleigh="bruneton")


def earth_turbidity_atmosphere(
    turbidity: float,
    wavelengths: Sequence[float] = _RGB,
    *,
    ozone: bool = True,
    single_scattering_albedo: float = 0.9,
    g: float = 0.8,
    rayleigh: str = "standard",
) -> Atmosphere:
    """Earth atmosphere whose haze extinction is fixed by the turbidity ``T`` (Preetham 1999).

    ``T = (τ_m + τ_h)/τ_m`` at 550 nm (:data:`TURBIDITY_REFERENCE_WAVELENGTH`; errata
    004.3): τ_m is the vertical optical depth of the preset's Rayleigh constituent, τ_h the
    vertical *extinction* (scattering + absorption) optical depth of its haze, both
    integrated over the exact profiles from the ground to the 60 km top; ozone absorption
    is not part of either.  So ``T·τ_m = τ_m + τ_h`` holds exactly at 550 nm for any albedo.
    The aerosol model (see the module notes): Junge spectral shape (v = 4, Bullrich's K(λ),
    :func:`atmoscatter.haze_extinction`), single-scattering albedo
    ``single_scattering_albedo`` (0.9, Bruneton 2017), HG asymmetry ``g`` (0.8, Bruneton
    2017), exponential profile with a 1.2 km scale height.  Air: :data:`EARTH_RAYLEIGH`
    (``"standard"``: real air, τ_m = 0.0970).  At ``T = 1`` the haze constituent is omitted
    entirely (no haze work is done).

    Parameters
    ----------
    turbidity : float
        Turbidity [-], ≥ 1.
    wavelengths : sequence of float
        Sample wavelengths [nm].
    ozone : bool
        Include ozone absorption.
    single_scattering_albedo : float
        Haze albedo [-], in (0, 1].
    g : float
        Haze HG asymmetry [-], in (−1, 1).
    rayleigh : {"standard", "bruneton"}
        Air model; T refers to that air's optical depth.

    Returns
    -------
    Atmosphere
        Air, the turbidity's haze (omitted at ``T = 1``) and optionally ozone.

    Notes
    -----
    Earlier versions set the haze *scattering* optical depth to ``(T − 1) τ_m`` and added
    absorption on top, so the extinction turbidity was 2.11 / 3.22 / 6.56 for nominal
    2 / 3 / 6, and the air was the seed-000 one.
    """
    T = float(check_range(turbidity, "turbidity", 1.0, np.inf))
    w = float(check_range(single_scattering_albedo, "single_scattering_albedo", 0.0, 1.0, low_inclusive=False))
    wl = _wl(wavelengths)
    ray = _rayleigh(wl, rayleigh)
    cons = [ray]
    if T > 1.0:
        beta_r, h_r = _rayleigh_model(rayleigh)
        thickness = EARTH_TOP_RADIUS - EARTH_PLANET_RADIUS
        ext = haze_extinction(
            wl,
            turbidity=T,
            reference_wavelength=TURBIDITY_REFERENCE_WAVELENGTH,
            molecular_scattering=float(beta_r(TURBIDITY_REFERENCE_WAVELENGTH)),
            molecular_scale_height=_column_length(h_r, thickness),
            haze_scale_height=_column_length(_HAZE_SCALE_HEIGHT, thickness),
        )
        cons.append(
            Constituent(
                name="mie",
                scattering=ext * w,
                absorption=ext * (1.0 - w),
                profile=ExponentialProfile(_HAZE_SCALE_HEIGHT),
                phase=HenyeyGreensteinPhase(g),
            )
        )
    if ozone:
        cons.append(_ozone(wl))
    suffix = "" if rayleigh == "standard" else f"-{rayleigh}"
    return Atmosphere(EARTH_PLANET_RADIUS, EARTH_TOP_RADIUS, tuple(wl), tuple(cons),
                      name=f"earth-T{T:g}{suffix}")


# Mars: CO₂ at the mean surface: N = p/(k T) = 636 Pa / (1.380649e-23 J/K · 210 K).
_MARS_N = 636.0 / (1.380649e-23 * 210.0)
_MARS_N_MINUS_1 = 4.49e-4 * _MARS_N / 2.687e25  # refractivity scales with density
_MARS_DUST_TAU = 0.5
_MARS_DUST_H = 11100.0
# representative dust single-scattering albedo per wavelength (red high, blue lower)
_MARS_DUST_ALBEDO = (np.array([440.0, 550.0, 680.0]), np.array([0.80, 0.94, 0.97]))


def mars_atmosphere(wavelengths: Sequence[float] = _RGB, *, dust_optical_depth: float = _MARS_DUST_TAU) -> Atmosphere:
    """A Mars-like atmosphere: thin CO₂ (Rayleigh) and suspended dust.

    Planet radius 3389.5 km, top 3389.5 + 100 km (NASA fact sheet; scale height 11.1 km).
    CO₂ Rayleigh scattering from :func:`rayleigh_scattering` with N = 2.19e23 m⁻³ (636 Pa,
    210 K), (n − 1) scaled from 4.49e-4 at STP, depolarisation 0.08 (Sneep & Ubachs 2005).
    Dust: wavelength-independent extinction giving ``dust_optical_depth`` (default 0.5,
    Lemmon et al. 2004) with an 11.1 km scale height, HG g = 0.65 and a single-scattering
    albedo of 0.97/0.94/0.80 at 680/550/440 nm, interpolated (representative of Tomasko et
    al. 1999 and Wolff et al. 2009) — the blue absorption gives the butterscotch sky and
    blue sunsets.  An approximate, Mars-*like* preset for rendering and validation, not a
    retrieval of a particular day.

    Parameters
    ----------
    wavelengths : sequence of float
        Sample wavelengths [nm].
    dust_optical_depth : float
        Vertical optical depth of the dust [-], ≥ 0.

    Returns
    -------
    Atmosphere
        CO₂ and dust between 3389.5 and 3489.5 km radius.
    """
    wl = _wl(wavelengths)
    tau = float(check_range(dust_optical_depth, "dust_optical_depth", 0.0, np.inf))
    R = 3.3895e6
    ray = Constituent(
        name="rayleigh",
        scattering=rayleigh_scattering(
            wl, refractive_index=1.0 + _MARS_N_MINUS_1, number_density=_MARS_N, depolarization=0.08
        ),
        absorption=0.0,
        profile=ExponentialProfile(_MARS_DUST_H),
        phase=RayleighPhase(),
    )
    cons = [ray]
    if tau > 0:
        ext = tau / _MARS_DUST_H
        alb = np.interp(wl, *_MARS_DUST_ALBEDO)
        cons.append(
            Constituent(
                name="dust",
                scattering=ext * alb,
                absorption=ext * (1.0 - alb),
                profile=ExponentialProfile(_MARS_DUST_H),
                phase=HenyeyGreensteinPhase(0.65),
            )
        )
    return Atmosphere(R, R + 100e3, tuple(wl), tuple(cons), name="mars")


def keller_bohn_atmosphere(
    wavelengths: Sequence[float] = (650.0, 570.0, 475.0),
    *,
    turbidity: float = 1.0,
    mie_coefficient_red: float = 2.0e-5,
    g: float = 0.8,
) -> Atmosphere:
    """The parameters of seed 002 (Keller & Bohn), as a physical atmosphere.

    Earth radii (6360/6420 km), exponential densities with 8 km (molecules) and 1.2 km
    (aerosols) scale heights (seed 002 Eq. 6.1 and its text), and the *shapes* of its
    Table 1: Rayleigh ``β_R(λ_red)·λ_red⁴/λ⁴`` and Mie ``β_M(λ_red)·λ_red²/λ²``.  Table 1
    drops all constants (errata 002.2); we restore the physical magnitude of Rayleigh at
    the red sample (:func:`rayleigh_scattering`) and take ``mie_coefficient_red``
    (default 2e-5 m⁻¹, seed 000's light haze in the red) for Mie; the seed's
    ``atmosphereTurbidity`` multiplies both coefficients.  Its phase functions (Rayleigh
    ``1 + 0.5cos²θ``, HG without 1/4π) are artistic normalisations: here the true
    normalised Rayleigh and HG phases are used.  This is a labelled interpretation that
    reproduces the seed's look, not a measured atmosphere.  The seed's wavelengths are not
    given; the default RGB samples are seed 000's 650/570/475 nm.

    Parameters
    ----------
    wavelengths : sequence of float
        Sample wavelengths [nm]; the first is the "red" reference of Table 1.
    turbidity : float
        The seed's ``atmosphereTurbidity`` [-], a factor on both coefficients, > 0.
    mie_coefficient_red : float
        Mie scattering coefficient at the red wavelength [m⁻¹], ≥ 0.
    g : float
        Henyey–Greenstein asymmetry of the aerosol [-], in (−1, 1).

    Returns
    -------
    Atmosphere
        The atmosphere (radii 6360/6420 km).
    """
    wl = _wl(wavelengths)
    k = float(check_positive(turbidity, "turbidity"))
    lam_red = float(np.max(wl))
    ray = rayleigh_scattering(lam_red) * (lam_red / wl) ** 4 * k
    mie = float(check_positive(mie_coefficient_red, "mie_coefficient_red", allow_zero=True)) * (lam_red / wl) ** 2 * k
    cons = (
        Constituent("rayleigh", ray, 0.0, ExponentialProfile(8000.0), RayleighPhase()),
        Constituent("mie", mie, 0.0, ExponentialProfile(1200.0), HenyeyGreensteinPhase(g)),
    )
    return Atmosphere(EARTH_PLANET_RADIUS, EARTH_TOP_RADIUS, tuple(wl), cons, name="keller_bohn")


#: Registry of preset names → constructors (``atmosphere_preset(name, **kwargs)``).
PRESETS: dict[str, Callable[..., Atmosphere]] = {
    "earth": earth_atmosphere,
    "bruneton": bruneton_atmosphere,
    "earth_turbidity": earth_turbidity_atmosphere,
    "mars": mars_atmosphere,
    "keller_bohn": keller_bohn_atmosphere,
}


def atmosphere_preset(name: str, **kwargs) -> Atmosphere:
    """Build the preset ``name`` (one of :data:`PRESETS`), passing ``kwargs`` on.

    Parameters
    ----------
    name : str
        Preset name, a key of :data:`PRESETS`.
    **kwargs
        Keyword arguments of that preset's function (e.g. ``wavelengths`` [nm],
        ``turbidity``).

    Returns
    -------
    Atmosphere
        The preset atmosphere.
    """
    if name not in PRESETS:
        raise ValueError(f"atmosphere preset {name!r} is not valid; choose one of {sorted(PRESETS)}")
    return PRESETS[name](**kwargs)

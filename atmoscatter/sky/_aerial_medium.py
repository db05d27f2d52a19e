"""Air, haze and sunlight of the Hoffman–Preetham model (seed 000; private).

The R, G, B sample wavelengths and zenith optical lengths of seed 000, the haze presets of
its Table 1 (:class:`HazePreset`, errata 000.3), the haze of a given turbidity, air's
Rayleigh coefficients, the extraterrestrial sun as linear RGB and the sunlight after
extinction along the Iqbal optical lengths.  The public names are re-exported by
:mod:`atmoscatter.sky.aerial`, whose docstring describes the model.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from .._validate import as_float_array, check_option, check_positive, check_range
from ..colour import XYZ_to_linear_rgb, spectral_to_XYZ
from ..optical_length import relative_optical_length
from ..scattering import (
    TURBIDITY_REFERENCE_WAVELENGTH,
    haze_extinction,
    rayleigh_scattering,
    rayleigh_scattering_standard_air,
)
from ..solar import extraterrestrial_irradiance

#: R, G, B sample wavelengths of seed 000 ("Air Molecules and Rayleigh Scattering"). [nm]
HOFFMAN_PREETHAM_WAVELENGTHS: tuple[float, float, float] = (650.0, 570.0, 475.0)
#: Optical length of the atmosphere at the zenith for air molecules (seed 000 "Sunlight";
#: seed 004 "Atmosphere"). [m]
AIR_ZENITH_OPTICAL_LENGTH: float = 8400.0
#: Optical length at the zenith for haze (seed 000: "a reasonable value"; seed 004). [m]
HAZE_ZENITH_OPTICAL_LENGTH: float = 1250.0


@dataclass(frozen=True)
class HazePreset:
    """Haze parameters for the Hoffman–Preetham model.

    Attributes
    ----------
    name : str
        Identifier (key of :data:`HAZE_PRESETS`).
    scattering : tuple of float
        ``β_scHaze`` at the R, G, B wavelengths of seed 000 (650, 570, 475 nm). [m⁻¹]
    g : float
        Henyey–Greenstein asymmetry, ``0 ≤ g < 1`` (forward scattering). [1]
    absorption : tuple of float
        ``β_abHaze`` at R, G, B (seed 000: 0 to about 5e-5, usually negligible). [m⁻¹]
    note : str
        Provenance.
    """

    name: str
    scattering: tuple[float, float, float]
    g: float
    absorption: tuple[float, float, float] = (0.0, 0.0, 0.0)
    note: str = ""

    def __post_init__(self):
        check_positive(self.scattering, "scattering", allow_zero=True, unit="m^-1")
        check_positive(self.absorption, "absorption", allow_zero=True, unit="m^-1")
        check_range(self.g, "g", -1.0, 1.0, low_inclusive=False, high_inclusive=False)
        if np.shape(self.scattering) != (3,) or np.shape(self.absorption) != (3,):
            raise ValueError("scattering and absorption must have 3 values (R, G, B)")

    @property
    def extinction(self) -> np.ndarray:
        """``β_exHaze = β_scHaze + β_abHaze`` at R, G, B. [m⁻¹]"""
        return np.asarray(self.scattering) + np.asarray(self.absorption)


_TABLE1 = (
    "Seed 000 Table 1 as corrected by errata 000.3 (scattering columns R, G, B at 650, 570, "
    "475 nm). The table's g column is unreadable; g is OUR INTERPRETATION, chosen to grow with "
    "β as the text says and positive (forward) per errata 000.2: "
)
#: Haze presets from seed 000 Table 1 (errata 000.3). The scattering values are the table's;
#: the asymmetry g of each is an interpretation (the column is garbled), absorption is 0.
HAZE_PRESETS: dict[str, HazePreset] = {
    "light_haze": HazePreset(
        "light_haze", (2e-5, 3e-5, 4e-5), 0.70, note=_TABLE1 + "g = 0.70 (typical aerosol)."
    ),
    "heavy_haze": HazePreset(
        "heavy_haze", (8e-5, 1e-4, 1.2e-4), 0.75, note=_TABLE1 + "g = 0.75."
    ),
    "light_fog": HazePreset(
        "light_fog", (9e-4, 1e-3, 1.1e-3), 0.80, note=_TABLE1 + "g = 0.80."
    ),
    "heavy_fog": HazePreset(
        "heavy_fog", (1e-2, 1e-2, 1e-2), 0.85, note=_TABLE1 + "g = 0.85 (fog droplets)."
    ),
}


# ----------------------------------------------------------------------------------------------
# coefficients and sunlight
# ----------------------------------------------------------------------------------------------
#: Air models of :func:`hoffman_preetham_air_scattering`.
_AIR_MODELS = {"seed000": rayleigh_scattering, "standard": rayleigh_scattering_standard_air}


def hoffman_preetham_air_scattering(wavelengths=HOFFMAN_PREETHAM_WAVELENGTHS, *, air="seed000") -> np.ndarray:
    """Air's Rayleigh scattering coefficient for the Hoffman–Preetham model. [m⁻¹]

    ``air="seed000"`` (default, the seed's model): ``n = 1.0003``, ``N = 2.545e25 m⁻³``,
    ``p_n = 0.035`` (via :func:`atmoscatter.rayleigh_scattering`); at 650, 570, 475 nm:
    6.95e-6, 1.18e-5, 2.44e-5 m⁻¹ (errata 000.4).  ``air="standard"``: real dry air,
    :func:`atmoscatter.rayleigh_scattering_standard_air` (Bodhaine et al. 1999), 15 % lower
    at 550 nm; with the 8.4 km optical length its zenith optical depth is 0.0965 at 550 nm.

    Parameters
    ----------
    wavelengths : array_like
        Wavelengths [nm] (default 650, 570, 475: the seed's R, G, B).
    air : {"seed000", "standard"}
        Air model.

    Returns
    -------
    ndarray
        Rayleigh scattering coefficient at sea level [m⁻¹], one per wavelength.
    """
    check_option(air, "air", _AIR_MODELS)
    return np.asarray(_AIR_MODELS[air](np.asarray(wavelengths, dtype=np.float64)), dtype=np.float64)


def turbidity_haze(
    turbidity,
    wavelengths=HOFFMAN_PREETHAM_WAVELENGTHS,
    *,
    air="standard",
    single_scattering_albedo=0.9,
    g=0.8,
    air_zenith_length=AIR_ZENITH_OPTICAL_LENGTH,
    haze_zenith_length=HAZE_ZENITH_OPTICAL_LENGTH,
) -> HazePreset:
    """Haze of turbidity ``T`` for the Hoffman–Preetham model (and :func:`aerial_perspective`).

    The haze *extinction* at 550 nm satisfies ``β_exHaze s_haze = (T − 1) β_scAir s_air``
    with the model's zenith optical lengths (8.4 km air, 1.25 km haze; seed 000), i.e.
    ``T = (τ_m + τ_h)/τ_m`` (Preetham 1999, errata 004.3) as in
    :func:`atmoscatter.earth_turbidity_atmosphere`; Junge spectral shape
    (:func:`atmoscatter.haze_extinction`), ``ω = single_scattering_albedo`` (0.9) and HG
    ``g`` (0.8), the aerosol of the physical presets (Bruneton 2017).  For comparison, seed
    000's Table 1 rows correspond (green, 570 nm, seed air) to T ≈ 1.4 (light haze),
    2.3 (heavy haze), 14 (light fog) and 130 (heavy fog).

    Parameters
    ----------
    turbidity : float
        Turbidity [-], ≥ 1 (1: no haze; scattering and absorption 0).
    wavelengths : sequence of 3 float
        R, G, B wavelengths [nm] (default 650, 570, 475).
    air : {"standard", "seed000"}
        Air whose optical depth defines T (:func:`hoffman_preetham_air_scattering`).
    single_scattering_albedo : float
        Haze albedo ω [-], in (0, 1].
    g : float
        HG asymmetry [-], in (−1, 1).
    air_zenith_length, haze_zenith_length : float
        Zenith optical lengths [m] (8400, 1250).

    Returns
    -------
    HazePreset
        Scattering ``ω β_ext`` and absorption ``(1 − ω) β_ext`` at the three wavelengths.
    """
    T = float(check_range(turbidity, "turbidity", 1.0, np.inf))
    w = float(check_range(single_scattering_albedo, "single_scattering_albedo", 0.0, 1.0, low_inclusive=False))
    wl = np.asarray(as_float_array(wavelengths, "wavelengths"), dtype=np.float64)
    if wl.shape != (3,):
        raise ValueError(f"wavelengths must have 3 values (R, G, B), got shape {wl.shape}")
    b_ref = float(hoffman_preetham_air_scattering(TURBIDITY_REFERENCE_WAVELENGTH, air=air))
    ext = np.asarray(haze_extinction(
        wl, turbidity=T, molecular_scattering=b_ref,
        molecular_scale_height=float(check_positive(air_zenith_length, "air_zenith_length", unit="m")),
        haze_scale_height=float(check_positive(haze_zenith_length, "haze_zenith_length", unit="m")),
    ), dtype=np.float64)
    return HazePreset(
        f"turbidity {T:g}", tuple(float(x) for x in ext * w), float(g),
        absorption=tuple(float(x) for x in ext * (1.0 - w)),
        note=(f"T = (tau_m + tau_h)/tau_m = {T:g} at 550 nm by extinction ({air} air, "
              f"{air_zenith_length:g} m / {haze_zenith_length:g} m optical lengths); Junge v = 4, "
              f"omega = {w:g}, HG g = {g:g}"),
    )


@lru_cache(maxsize=16)
def _solar_rgb(colourspace: str) -> np.ndarray:
    wl = np.arange(360.0, 831.0, 1.0)
    XYZ = spectral_to_XYZ(extraterrestrial_irradiance(wl), wl)
    rgb = np.asarray(XYZ_to_linear_rgb(XYZ, colourspace=colourspace), dtype=np.float64)
    rgb.flags.writeable = False
    return rgb


def solar_illuminance_rgb(colourspace: str = "sRGB") -> np.ndarray:
    """Extraterrestrial solar illuminance as linear RGB (the default ``E_sun⁰``).

    The ASTM G-173 ETR spectrum (:func:`atmoscatter.extraterrestrial_irradiance`, 1 AU),
    integrated with the CIE 1931 CMFs at 683 lm/W (Y ≈ 133 klx, cf. the luminous solar
    constant 133.8 klx of Darula, Kittler & Gueymard 2005) and converted to linear RGB of
    ``colourspace``. [lx]

    Parameters
    ----------
    colourspace : str
        colour-science RGB colourspace name (default ``"sRGB"``).

    Returns
    -------
    ndarray, shape (3,)
        Linear RGB illuminance [lx].
    """
    return _solar_rgb(colourspace).copy()


def _coefficients(haze, air_scattering, beta_sc_haze=None, beta_ab_haze=None, g=None):
    """Resolve (β_scAir, β_exAir, β_scHaze, β_exHaze, g) as float64 arrays (C,)."""
    b_air = (
        hoffman_preetham_air_scattering()
        if air_scattering is None
        else check_positive(air_scattering, "air_scattering", allow_zero=True, unit="m^-1")
    )
    if haze is None:
        preset = HazePreset("none", (0.0, 0.0, 0.0), 0.0)
    elif isinstance(haze, HazePreset):
        preset = haze
    else:
        check_option(haze, "haze", HAZE_PRESETS)
        preset = HAZE_PRESETS[haze]
    sc = np.asarray(preset.scattering if beta_sc_haze is None else beta_sc_haze, dtype=np.float64)
    ab = np.asarray(preset.absorption if beta_ab_haze is None else beta_ab_haze, dtype=np.float64)
    check_positive(sc, "haze_scattering", allow_zero=True, unit="m^-1")
    check_positive(ab, "haze_absorption", allow_zero=True, unit="m^-1")
    gg = preset.g if g is None else float(check_range(g, "g", -1.0, 1.0, low_inclusive=False, high_inclusive=False))
    return np.asarray(b_air, np.float64), np.asarray(b_air, np.float64), sc, sc + ab, gg


def hoffman_preetham_sunlight(
    sun_zenith,
    beta_ex_air,
    beta_ex_haze,
    *,
    sun_irradiance=None,
    air_zenith_length=AIR_ZENITH_OPTICAL_LENGTH,
    haze_zenith_length=HAZE_ZENITH_OPTICAL_LENGTH,
    method="iqbal",
):
    """Sunlight after extinction, ``E_sun = E_sun⁰ F_ex(s_air, s_haze)`` (seed 000 "Sunlight").

    ``s_air = 8.4 km · m(θ_s)``, ``s_haze = 1.25 km · m(θ_s)`` with ``m`` the relative
    optical length of seed 000 Eq. 5 (:func:`atmoscatter.relative_optical_length`,
    ``method="iqbal"``).

    Parameters
    ----------
    sun_zenith : array_like
        Solar zenith angle ≥ 0; above π/2 (sun below the horizon) ``E_sun = 0``. [rad]
    beta_ex_air, beta_ex_haze : array_like
        Extinction coefficients per channel (last axis). [m⁻¹]
    sun_irradiance : array_like, optional
        ``E_sun⁰`` per channel; default :func:`solar_illuminance_rgb` (3 channels). [lx or
        the caller's unit]
    air_zenith_length, haze_zenith_length : float
        Zenith optical lengths (defaults 8400 m and 1250 m, seed 000). [m]
    method : {"iqbal", "kasten_young"}
        Relative optical length formula.

    Returns
    -------
    numpy.ndarray
        ``E_sun``, shape ``sun_zenith.shape + (C,)``.
    """
    ts = as_float_array(sun_zenith, "sun_zenith")
    b_air = check_positive(beta_ex_air, "beta_ex_air", allow_zero=True, unit="m^-1")
    b_haze = check_positive(beta_ex_haze, "beta_ex_haze", allow_zero=True, unit="m^-1")
    E0 = solar_illuminance_rgb() if sun_irradiance is None else as_float_array(sun_irradiance, "sun_irradiance")
    la = float(check_positive(air_zenith_length, "air_zenith_length", allow_zero=True, unit="m"))
    lh = float(check_positive(haze_zenith_length, "haze_zenith_length", allow_zero=True, unit="m"))
    m = np.asarray(relative_optical_length(ts, method=method))[..., None]
    tau = b_air * (la * m) + b_haze * (lh * m)
    E = E0 * np.exp(-tau)
    return np.where(ts[..., None] > np.pi / 2, 0.0, E)

"""Tests for atmoscatter.presets: Earth (Bruneton), Earth by turbidity, Mars, Keller–Bohn."""

from __future__ import annotations

import numpy as np
import pytest
from colour.phenomena import rayleigh_optical_depth

import atmoscatter as ac

RGB = (680.0, 550.0, 440.0)


@pytest.mark.parametrize("name", sorted(ac.PRESETS))
def test_each_preset_builds(name):
    atm = ac.atmosphere_preset(name) if name != "earth_turbidity" else ac.atmosphere_preset(name, turbidity=3.0)
    assert isinstance(atm, ac.Atmosphere)
    assert atm.top_radius > atm.planet_radius
    assert all(c.extinction_array.shape == (atm.n_wavelengths,) for c in atm.constituents)
    tau = atm.vertical_optical_depth()
    assert np.all(np.isfinite(tau)) and np.all(tau > 0)
    # with other wavelengths (5 channels)
    wl = [420.0, 480.0, 550.0, 610.0, 680.0]
    kw = {"turbidity": 3.0} if name == "earth_turbidity" else {}
    atm5 = ac.atmosphere_preset(name, wavelengths=wl, **kw)
    assert atm5.n_wavelengths == 5


def test_unknown_preset_lists_options():
    with pytest.raises(ValueError, match=r"'venus'.*\['earth', 'earth_turbidity', 'keller_bohn', 'mars'\]"):
        ac.atmosphere_preset("venus")


def test_earth_rayleigh_matches_bruneton():
    # Bruneton (2017) Rayleigh scattering at 680/550/440 nm: (5.802, 13.558, 33.1)e-6 m⁻¹
    atm = ac.earth_atmosphere()
    np.testing.assert_allclose(atm.constituent("rayleigh").scattering_array, [5.802e-6, 13.558e-6, 33.1e-6], rtol=0.01)
    assert atm.constituent("rayleigh").profile == ac.ExponentialProfile(8000.0)
    assert atm.planet_radius == 6.36e6 and atm.top_radius == 6.42e6


def test_earth_mie_and_ozone_match_bruneton():
    atm = ac.earth_atmosphere()
    mie = atm.constituent("mie")
    # Bruneton (2017): Mie extinction 5.328e-3/1200 m (Ångström β, α = 0), albedo 0.9,
    # g = 0.8, scale height 1.2 km
    np.testing.assert_allclose(mie.extinction_array, 5.328e-3 / 1200.0, rtol=1e-12)
    np.testing.assert_allclose(mie.single_scattering_albedo, 0.9, rtol=1e-12)
    assert mie.phase == ac.HenyeyGreensteinPhase(0.8)
    assert mie.profile == ac.ExponentialProfile(1200.0)
    # Bruneton (2017) ozone absorption at the layer peak: (0.650, 1.881, 0.085)e-6 m⁻¹ at
    # 680/550/440 nm, 300 DU in a 10–25–40 km tent (our 10 nm-bin interpolation: 5 %)
    oz = atm.constituent("ozone")
    np.testing.assert_allclose(oz.absorption_array, [0.650e-6, 1.881e-6, 0.085e-6], rtol=0.05)
    assert oz.profile == ac.TentProfile(25e3, 15e3)
    assert not np.any(oz.scattering_array)
    # total ozone column = 300 DU: ∫ n dz = peak·15 km
    col = oz.absorption_array / np.interp(RGB, *_ozone_table()) * 15e3 / ac.DOBSON_UNIT
    np.testing.assert_allclose(col, 300.0, rtol=1e-12)
    assert [c.name for c in ac.earth_atmosphere(ozone=False).constituents] == ["rayleigh", "mie"]


def _ozone_table():
    from importlib import resources

    path = resources.files("atmoscatter") / "data" / "ozone_cross_section.csv"
    data = np.loadtxt(str(path), delimiter=",", comments="#")
    return data[:, 0], data[:, 1]


def test_earth_rayleigh_optical_depth_vs_bodhaine():
    # vertical Rayleigh optical depth of the preset vs Bodhaine et al. (1999) (colour-science,
    # sea level, 1013.25 hPa): the seed-000 constants are 14–20 % high (see test_scattering)
    tau = ac.earth_atmosphere(ozone=False).without("mie").vertical_optical_depth()
    ref = rayleigh_optical_depth(np.asarray(RGB) * 1e-7)
    ratio = tau / ref
    assert np.all(ratio > 1.05) and np.all(ratio < 1.25)


def test_earth_turbidity_one_has_no_haze():
    atm = ac.earth_turbidity_atmosphere(1.0)
    assert "mie" not in [c.name for c in atm.constituents]
    with pytest.raises(KeyError):
        atm.constituent("mie")


@pytest.mark.parametrize("T", [2.0, 4.5, 10.0])
def test_earth_turbidity_definition(T):
    # Preetham (1999): T = (τ_m + τ_h)/τ_m at 550 nm, τ = β·H (errata 004.3)
    atm = ac.earth_turbidity_atmosphere(T, wavelengths=[550.0], ozone=False, single_scattering_albedo=1.0)
    tau_m = atm.constituent("rayleigh").scattering_array[0] * 8000.0
    tau_h = atm.constituent("mie").scattering_array[0] * 1200.0
    assert (tau_m + tau_h) / tau_m == pytest.approx(T, rel=1e-12)
    # haze albedo and phase as requested
    atm2 = ac.earth_turbidity_atmosphere(T, single_scattering_albedo=0.8, g=0.7)
    mie = atm2.constituent("mie")
    np.testing.assert_allclose(mie.single_scattering_albedo, 0.8, rtol=1e-12)
    assert mie.phase.g == 0.7
    assert atm2.name == f"earth-T{T:g}"


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"turbidity": 0.9}, "turbidity"),
        ({"turbidity": np.nan}, "turbidity"),
        ({"turbidity": 2.0, "single_scattering_albedo": 0.0}, "single_scattering_albedo"),
        ({"turbidity": 2.0, "g": 1.0}, "g"),
        ({"turbidity": 2.0, "wavelengths": [550.0, -1.0]}, "wavelengths"),
    ],
)
def test_earth_turbidity_bad_input(kwargs, match):
    with pytest.raises(ValueError, match=match):
        ac.earth_turbidity_atmosphere(**kwargs)


def test_mars_preset_physically_sane():
    atm = ac.mars_atmosphere(RGB)
    assert atm.planet_radius == 3.3895e6  # NASA Mars fact sheet
    ray = atm.constituent("rayleigh")
    tau_r = ray.scattering_array * ray.profile.scale_height  # (680, 550, 440)
    # Rayleigh optical depth is small: an independent estimate scales Earth's Bodhaine
    # (1999) optical depth (colour-science) by the column mass ratio (636 Pa/3.71 m s⁻² vs
    # 101325 Pa/9.80665 m s⁻², NASA fact sheets), molecules per kg (28.97/44.01) and the
    # CO₂/air cross-section ratio ((4.49/2.93)² refractivity at STP, Old et al. 1971 / Edlén;
    # King factors 1.14/1.05, Sneep & Ubachs 2005 / Bodhaine 1999).
    earth = rayleigh_optical_depth(550e-7)
    estimate = earth * (636.0 / 3.71) / (101325.0 / 9.80665) * (28.97 / 44.01) * (4.49 / 2.93) ** 2 * 1.14 / 1.05
    assert 1e-3 < tau_r[1] < 1e-2
    assert tau_r[1] == pytest.approx(estimate, rel=0.15)
    np.testing.assert_allclose(tau_r * np.asarray(RGB) ** 4, tau_r[0] * 680.0**4, rtol=1e-12)
    # dust: vertical optical depth as requested (100 km / 11.1 km: truncation e^{−9})
    for tau in (0.2, 0.5, 1.5):
        dust = ac.mars_atmosphere(RGB, dust_optical_depth=tau).without("rayleigh")
        np.testing.assert_allclose(dust.vertical_optical_depth(), tau, rtol=2e-4)
    d = atm.constituent("dust")
    # dust is redder than air: absorbs more in the blue (albedo lower), scatters forward
    alb = d.single_scattering_albedo
    assert alb[2] < alb[1] < alb[0] <= 1.0
    assert 0.5 < d.phase.g < 0.8
    # dust dominates the Rayleigh optical depth
    assert np.all(atm.vertical_optical_depth() > 10 * tau_r)
    assert [c.name for c in ac.mars_atmosphere(dust_optical_depth=0.0).constituents] == ["rayleigh"]
    with pytest.raises(ValueError, match="dust_optical_depth"):
        ac.mars_atmosphere(dust_optical_depth=-0.1)


def test_keller_bohn_preset_shapes():
    # seed 002 Table 1: Rayleigh ∝ λ_red⁴/λ⁴, Mie ∝ λ_red²/λ² (errata 002.2); radii and
    # scale heights of seed 002 / Bruneton
    wl = np.array([650.0, 570.0, 475.0])
    atm = ac.keller_bohn_atmosphere()
    ray = atm.constituent("rayleigh").scattering_array
    mie = atm.constituent("mie").scattering_array
    np.testing.assert_allclose(ray, ac.rayleigh_scattering(650.0) * (650.0 / wl) ** 4, rtol=1e-12)
    np.testing.assert_allclose(mie, 2e-5 * (650.0 / wl) ** 2, rtol=1e-12)
    assert atm.constituent("rayleigh").profile.scale_height == 8000.0
    assert atm.constituent("mie").profile.scale_height == 1200.0
    assert atm.planet_radius == 6.36e6 and atm.top_radius == 6.42e6
    # seed 000 Rayleigh at its own red sample: 6.95e-6
    assert f"{ray[0]:.3g}" == "6.95e-06"
    # the seed's atmosphereTurbidity multiplies both
    atm2 = ac.keller_bohn_atmosphere(turbidity=2.0)
    np.testing.assert_allclose(atm2.constituent("rayleigh").scattering_array, 2 * ray, rtol=1e-14)
    np.testing.assert_allclose(atm2.constituent("mie").scattering_array, 2 * mie, rtol=1e-14)
    with pytest.raises(ValueError, match="turbidity"):
        ac.keller_bohn_atmosphere(turbidity=0.0)
    with pytest.raises(ValueError, match="mie_coefficient_red"):
        ac.keller_bohn_atmosphere(mie_coefficient_red=-1.0)


@pytest.mark.parametrize("bad", [[-440.0], [np.nan], [0.0]])
def test_preset_bad_wavelengths(bad):
    with pytest.raises(ValueError, match="wavelengths"):
        ac.earth_atmosphere(bad)
    with pytest.raises(ValueError, match="wavelengths"):
        ac.mars_atmosphere(bad)

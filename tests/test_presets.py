"""Tests for atmoscatter.presets: Earth (real air / Bruneton), Earth by turbidity, Mars, Keller–Bohn."""

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
    with pytest.raises(ValueError, match=r"'venus'.*\['bruneton', 'earth', 'earth_turbidity', 'keller_bohn', 'mars'\]"):
        ac.atmosphere_preset("venus")


def test_bruneton_rayleigh_matches_bruneton():
    # Bruneton (2017) Rayleigh scattering at 680/550/440 nm: (5.802, 13.558, 33.1)e-6 m⁻¹,
    # scale height 8 km — kept as the named variant rayleigh="bruneton" / bruneton_atmosphere
    for atm in (ac.earth_atmosphere(rayleigh="bruneton"), ac.bruneton_atmosphere()):
        np.testing.assert_allclose(atm.constituent("rayleigh").scattering_array,
                                   [5.802e-6, 13.558e-6, 33.1e-6], rtol=0.01)
        assert atm.constituent("rayleigh").profile == ac.ExponentialProfile(8000.0)
        assert atm.planet_radius == 6.36e6 and atm.top_radius == 6.42e6
        assert atm.name == "bruneton"
    with pytest.raises(ValueError, match="rayleigh"):
        ac.earth_atmosphere(rayleigh="seed")


def test_earth_default_is_standard_air():
    # the default Earth uses real air: sea-level β_R = σ·N_s.  Bodhaine et al. (1999)
    # Table 3: τ(550 nm) = 0.09707 over their column 2.1520e25 cm⁻² (P N_A/(m_a g), see
    # the scale-height test) is σ = 4.5106e-27 cm²; × N_s = 2.546899e19 cm⁻³ (their
    # standard air) = 1.1488e-5 m⁻¹ (table rounding 5e-5 relative).  Bucholtz's (1995)
    # standard-air fit gives 1.1481e-5 m⁻¹.  Tolerance 1e-3 covers both.
    atm = ac.earth_atmosphere()
    ray = atm.constituent("rayleigh")
    assert ray.scattering_array[1] == pytest.approx(1.1488e-5, rel=1e-3)
    np.testing.assert_allclose(ray.scattering_array, ac.rayleigh_scattering_standard_air(RGB), rtol=1e-14)
    assert ray.profile == ac.ExponentialProfile(ac.STANDARD_AIR_SCALE_HEIGHT)
    assert atm.name == "earth"


def test_standard_air_scale_height_is_the_hydrostatic_column():
    # H = k T/(m g): the sea-level column P N_A/(m_a g) over N_s = P/(k T).  Independent
    # evaluation with Bodhaine et al.'s (1999) constants: m_a = 28.9595 + 15.0556·C g/mol
    # (C = 360e-6), g at the column's mass-weighted height z_c = 5517.56 m, 45° latitude
    # (their Eq. 11 with cos 2φ = 0): g = 980.616 − 3.085462e-4 z_c + 7.254e-11 z_c²
    # − 1.517e-17 z_c³ cm s⁻².
    zc = 5517.56
    g = (980.616 - 3.085462e-4 * zc + 7.254e-11 * zc**2 - 1.517e-17 * zc**3) / 100.0
    m = (28.9595 + 15.0556 * 360e-6) * 1e-3 / 6.02214076e23
    H = 1.380649e-23 * 288.15 / (m * g)
    assert ac.STANDARD_AIR_SCALE_HEIGHT == pytest.approx(H, rel=1e-12)
    assert 8440.0 < H < 8460.0


def test_earth_rayleigh_optical_depth_vs_bodhaine_table3():
    """Vertical Rayleigh optical depth of the default Earth by independent quadrature.

    ``scipy.integrate.quad`` of β_R·exp(−z/H) from the ground to the 60 km top, against
    Bodhaine et al. (1999) Table 3 (sea level, 1013.25 hPa, 45° N, 360 ppm): 0.09707 at
    550 nm, 0.36022 at 400 nm, 0.03642 at 700 nm.  The preset's column is Bodhaine's minus
    what lies above 60 km, e^{−60/8.45} = 8.3e-4 of it; the table's 5-digit rounding adds
    ≤ 1.4e-4 relative: tolerance 1.2e-3.
    """
    from scipy.integrate import quad

    wl = [400.0, 550.0, 700.0]
    atm = ac.earth_atmosphere(wl, ozone=False)
    ray = atm.constituent("rayleigh")
    H = ray.profile.scale_height
    top = atm.top_radius - atm.planet_radius
    col, _ = quad(lambda z: np.exp(-z / H), 0.0, top, epsabs=0.0, epsrel=1e-12)
    tau = ray.scattering_array * col
    np.testing.assert_allclose(tau, [0.36022, 0.09707, 0.03642], rtol=1.2e-3)
    # and the Bruneton variant is 11–12 % above (its 14–20 % higher cross section times
    # its 8 km scale height, 5 % below the real column)
    bru = ac.earth_atmosphere(wl, ozone=False, rayleigh="bruneton").constituent("rayleigh")
    col8, _ = quad(lambda z: np.exp(-z / 8000.0), 0.0, top, epsabs=0.0, epsrel=1e-12)
    ratio = bru.scattering_array * col8 / tau
    assert np.all(ratio > 1.07) and np.all(ratio < 1.16)


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


def test_bruneton_rayleigh_optical_depth_vs_bodhaine():
    # vertical Rayleigh optical depth of the Bruneton variant vs Bodhaine et al. (1999)
    # (colour-science, sea level, 1013.25 hPa): the seed-000 constants are 14–20 % high
    # per molecule (see test_scattering), the 8 km scale height 5 % short of the column
    tau = ac.bruneton_atmosphere(ozone=False).without("mie").vertical_optical_depth()
    ref = rayleigh_optical_depth(np.asarray(RGB) * 1e-7)
    ratio = tau / ref
    assert np.all(ratio > 1.05) and np.all(ratio < 1.25)


def test_earth_turbidity_one_has_no_haze():
    atm = ac.earth_turbidity_atmosphere(1.0)
    assert "mie" not in [c.name for c in atm.constituents]
    with pytest.raises(KeyError):
        atm.constituent("mie")


def _quad_tau(constituent, top):
    """Vertical optical depth of ``constituent`` by adaptive quadrature of its profile."""
    from scipy.integrate import quad

    col, _ = quad(lambda z: float(constituent.profile.density(z)), 0.0, top, epsabs=0.0, epsrel=1e-12)
    return constituent.extinction_array * col


@pytest.mark.parametrize("rayleigh", ["standard", "bruneton"])
@pytest.mark.parametrize("T", [2.0, 3.0, 6.0, 10.0])
@pytest.mark.parametrize("omega", [0.9, 0.6, 1.0])
def test_earth_turbidity_is_the_extinction_ratio(T, omega, rayleigh):
    """``T·τ_m = τ_m + τ_h`` at 550 nm (Preetham 1999; errata 004.3), by extinction.

    τ_m: the Rayleigh constituent, τ_h: the haze's scattering + absorption, each integrated
    independently with ``scipy.integrate.quad`` over its profile from the ground to the top
    (relative accuracy 1e-12): holds to 1e-9 whatever the albedo or the air model.
    """
    atm = ac.earth_turbidity_atmosphere(T, wavelengths=[440.0, 550.0, 680.0], ozone=False,
                                        single_scattering_albedo=omega, rayleigh=rayleigh)
    top = atm.top_radius - atm.planet_radius
    tau_m = _quad_tau(atm.constituent("rayleigh"), top)[1]
    tau_h = _quad_tau(atm.constituent("mie"), top)[1]
    assert T * tau_m == pytest.approx(tau_m + tau_h, rel=1e-9)
    # the haze's albedo is as asked: the turbidity counts its absorption
    np.testing.assert_allclose(atm.constituent("mie").single_scattering_albedo, omega, rtol=1e-12)
    if rayleigh == "standard":  # τ_m is real air's: Bodhaine Table 3 0.09707 less 8.3e-4 above 60 km
        assert tau_m == pytest.approx(0.09707, rel=1.2e-3)


def test_earth_turbidity_old_scattering_definition_is_gone():
    # The reported bug: haze *scattering* (T − 1)·τ_m plus 10 % absorption gave extinction
    # turbidities 1 + (T − 1)/0.9 = 2.11, 3.22, 6.56 for nominal 2, 3, 6.
    for T in (2.0, 3.0, 6.0):
        atm = ac.earth_turbidity_atmosphere(T, wavelengths=[550.0], ozone=False)
        tau = atm.vertical_optical_depth()[0]
        tau_m = atm.without("mie").vertical_optical_depth()[0]
        assert tau / tau_m == pytest.approx(T, rel=1e-12)
        assert abs(tau / tau_m - (1 + (T - 1) / 0.9)) > 0.1


def test_earth_turbidity_phase_albedo_and_name():
    atm2 = ac.earth_turbidity_atmosphere(4.5, single_scattering_albedo=0.8, g=0.7)
    mie = atm2.constituent("mie")
    np.testing.assert_allclose(mie.single_scattering_albedo, 0.8, rtol=1e-12)
    assert mie.phase.g == 0.7
    assert mie.profile == ac.ExponentialProfile(1200.0)
    assert atm2.name == "earth-T4.5"
    assert ac.earth_turbidity_atmosphere(3.0, rayleigh="bruneton").name == "earth-T3-bruneton"


def test_earth_turbidity_haze_spectral_shape():
    # Junge v = 4 with Bullrich's K(λ) (seed 004; errata 004.3): β ∝ λ⁻² K(λ), K linear
    # from 0.656 (400 nm) to 0.69 (770 nm)
    wl = np.array([400.0, 550.0, 770.0])
    ext = ac.earth_turbidity_atmosphere(3.0, wavelengths=wl).constituent("mie").extinction_array
    K = 0.656 + (wl - 400.0) * (0.69 - 0.656) / 370.0
    np.testing.assert_allclose(ext / ext[1], (550.0 / wl) ** 2 * K / K[1], rtol=1e-12)


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"turbidity": 0.9}, "turbidity"),
        ({"turbidity": np.nan}, "turbidity"),
        ({"turbidity": 2.0, "single_scattering_albedo": 0.0}, "single_scattering_albedo"),
        ({"turbidity": 2.0, "g": 1.0}, "g"),
        ({"turbidity": 2.0, "wavelengths": [550.0, -1.0]}, "wavelengths"),
        ({"turbidity": 2.0, "rayleigh": "seed"}, "rayleigh"),
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

"""Tests for atmoscatter.solar: the shipped ASTM G173-03 extraterrestrial spectrum."""

from __future__ import annotations

import numpy as np
import pytest

import atmoscatter as ac


def test_table_integral_vs_published_totals():
    # ASTM G173-03 ETR integrates to 1348 W m⁻² over 280–4000 nm (Gueymard 2004; the
    # standard's stated total); the total solar irradiance (Kopp & Lean 2011) is 1361 W m⁻²,
    # which includes the spectrum outside the table
    wl, e = ac.solar_spectrum_table()
    total = float(np.sum(0.5 * (e[1:] + e[:-1]) * np.diff(wl)))
    assert total == pytest.approx(1348.0, rel=0.01)
    assert total < 1361.0
    assert ac.SOLAR_CONSTANT == pytest.approx(total, rel=1e-12)
    assert wl[0] == 280.0 and wl[-1] == 4000.0
    assert np.all(np.diff(wl) > 0)
    assert np.all(e >= 0)


def test_table_agrees_with_pvlib_copy():
    # independent copy of the same standard: pvlib.spectrum.get_reference_spectra
    # ('ASTM G173-03', column 'extraterrestrial')
    pvlib = pytest.importorskip("pvlib")
    ref = pvlib.spectrum.get_reference_spectra()["extraterrestrial"]
    wl, e = ac.solar_spectrum_table()
    np.testing.assert_allclose(e, np.interp(wl, ref.index.to_numpy(), ref.to_numpy()), rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(
        ac.extraterrestrial_irradiance([400.25, 550.0, 1000.5]),
        np.interp([400.25, 550.0, 1000.5], ref.index.to_numpy(), ref.to_numpy()),
        rtol=1e-12,
    )


def test_table_is_read_only():
    wl, e = ac.solar_spectrum_table()
    with pytest.raises(ValueError):
        e[0] = 0.0


def test_inverse_square_distance():
    wl = np.array([450.0, 550.0, 650.0])
    e1 = ac.extraterrestrial_irradiance(wl)
    for d in (0.983, 1.0167, 1.524):  # perihelion, aphelion, Mars
        np.testing.assert_allclose(ac.extraterrestrial_irradiance(wl, distance_au=d), e1 / d**2, rtol=1e-14)


def test_broadcasting():
    wl = np.array([450.0, 550.0, 650.0])
    d = np.array([[0.98], [1.0], [1.02], [1.5]])
    out = ac.extraterrestrial_irradiance(wl, distance_au=d)
    assert out.shape == (4, 3)
    np.testing.assert_allclose(out[1], ac.extraterrestrial_irradiance(wl), rtol=1e-15)
    assert ac.extraterrestrial_irradiance(np.full((2, 5), 500.0)).shape == (2, 5)
    assert np.ndim(ac.extraterrestrial_irradiance(500.0)) == 0


@pytest.mark.parametrize("bad", [279.9, 4000.1, [500.0, 5000.0], 100.0])
def test_out_of_range_wavelength(bad):
    with pytest.raises(ValueError, match=r"wavelength must be in \[280.0, 4000.0\] nm"):
        ac.extraterrestrial_irradiance(bad)


@pytest.mark.parametrize("bad", [np.nan, -1.0, 0.0, np.inf])
def test_non_finite_or_non_positive_wavelength(bad):
    with pytest.raises(ValueError, match="wavelength"):
        ac.extraterrestrial_irradiance(bad)


@pytest.mark.parametrize("bad", [0.0, -1.0, np.nan, np.inf])
def test_bad_distance(bad):
    with pytest.raises(ValueError, match="distance_au"):
        ac.extraterrestrial_irradiance(550.0, distance_au=bad)


def test_sun_angular_radius():
    # IAU 2015 nominal solar radius 695 700 km; 1 au = 149 597 870.7 km → 959.2″
    arcsec = np.degrees(ac.SUN_ANGULAR_RADIUS) * 3600
    assert arcsec == pytest.approx(959.2, abs=0.1)

"""Tests for atmoscatter.sky.cie (CIE overcast and clear skies, seed 004)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import integrate

import atmoscatter as ac


def direction(theta, phi):
    return np.array([math.sin(theta) * math.sin(phi), math.sin(theta) * math.cos(phi), math.cos(theta)])


def clear_scalar(theta, gamma, ts, Yz):
    """Seed 004 'CIE Clear sky luminance model', transcribed with the math module."""
    num = (0.91 + 10 * math.exp(-3 * gamma) + 0.45 * math.cos(gamma) ** 2) * (
        1 - math.exp(-0.32 / math.cos(theta))
    )
    den = (0.91 + 10 * math.exp(-3 * ts) + 0.45 * math.cos(ts) ** 2) * (1 - math.exp(-0.32))
    return Yz * num / den


# ------------------------------------------------------------------------------- overcast
def test_overcast_zenith_horizon_ratio_is_three():
    """Moon & Spencer (1942): the overcast horizon is one third as bright as the zenith."""
    got = ac.cie_overcast_luminance([0.0, np.pi / 2, 2.0, np.pi], 3000.0)
    np.testing.assert_allclose(got, [3000.0, 1000.0, 1000.0, 1000.0], rtol=1e-15)
    theta = 1.1
    assert ac.cie_overcast_luminance(theta, 3000.0) == pytest.approx(3000 * (1 + 2 * math.cos(theta)) / 3)


def test_overcast_illuminance_relation_against_quadrature():
    Yz = 4321.0
    E, _ = integrate.quad(
        lambda t: ac.cie_overcast_luminance(t, Yz) * math.cos(t) * math.sin(t) * 2 * math.pi, 0, math.pi / 2
    )
    assert ac.cie_overcast_zenith_luminance_from_illuminance(E) == pytest.approx(Yz, rel=1e-12)


def test_overcast_sky_directions():
    v = np.array([[0, 0, 1.0], [1.0, 0, 0], [0, 0, -1.0], [0, 3.0, 3.0], [np.nan, 0, 1]])
    got = ac.cie_overcast_sky(v, 900.0)
    np.testing.assert_allclose(got[:4], [900.0, 300.0, 300.0, 300 * (1 + 2 * math.sqrt(0.5))], rtol=1e-14)
    assert np.isnan(got[4])
    assert ac.cie_overcast_sky(v[:4].astype(np.float32), 900.0).dtype == np.float32
    assert ac.cie_overcast_sky(v[:4].reshape(2, 2, 3), 900.0).shape == (2, 2)


# ---------------------------------------------------------------------------------- clear
@pytest.mark.parametrize("tsd", [0.0, 25.0, 60.0, 89.0, 90.0])
def test_clear_sky_matches_scalar_transcription(tsd):
    ts = math.radians(tsd)
    rng = np.random.default_rng(int(tsd))
    theta = rng.uniform(0, math.pi / 2 - 1e-6, 50)
    gamma = rng.uniform(0, math.pi, 50)
    got = ac.cie_clear_sky_luminance(theta, gamma, ts, 5000.0)
    ref = [clear_scalar(t, g, ts, 5000.0) for t, g in zip(theta, gamma, strict=True)]
    np.testing.assert_allclose(got, ref, rtol=1e-13)


def test_clear_sky_zenith_value_horizon_limit_and_night():
    ts = math.radians(40)
    sun = direction(ts, 1.0)
    assert ac.cie_clear_sky([0, 0, 1.0], sun, 6000.0) == pytest.approx(6000.0, rel=1e-14)
    # horizon: φ → 1 as cos θ → 0⁺; below the horizon the horizon value is used
    g = 1.3
    limit = 6000.0 * (0.91 + 10 * math.exp(-3 * g) + 0.45 * math.cos(g) ** 2) / (
        (0.91 + 10 * math.exp(-3 * ts) + 0.45 * math.cos(ts) ** 2) * (1 - math.exp(-0.32))
    )
    got = ac.cie_clear_sky_luminance([math.pi / 2, 2.0], g, ts, 6000.0)
    np.testing.assert_allclose(got, limit, rtol=1e-14)
    assert ac.cie_clear_sky_luminance(math.pi / 2 - 1e-5, g, ts, 6000.0) == pytest.approx(limit, rel=1e-12)
    # sun below the horizon: dark
    assert np.all(ac.cie_clear_sky(np.eye(3), direction(math.radians(95), 0.0), 6000.0) == 0.0)
    assert ac.cie_clear_sky_luminance(0.3, 0.2, math.radians(95), 6000.0) == 0.0


def test_clear_sky_symmetric_about_solar_vertical_and_matches_angle_api():
    sun = direction(math.radians(50), math.radians(200))
    n = np.cross([0, 0, 1.0], sun)
    n /= np.linalg.norm(n)
    v = np.random.default_rng(1).normal(size=(300, 3))
    v /= np.linalg.norm(v, axis=1, keepdims=True)
    m = v - 2 * (v @ n)[:, None] * n
    a = ac.cie_clear_sky(v, sun, 5000.0)
    np.testing.assert_allclose(a, ac.cie_clear_sky(m, sun, 5000.0), rtol=1e-12)
    theta = np.arccos(v[:, 2])
    gamma = np.arccos(np.clip(v @ sun, -1, 1))
    np.testing.assert_allclose(a, ac.cie_clear_sky_luminance(theta, gamma, math.radians(50), 5000.0), rtol=1e-9)
    # the brightest point of the upper sky is at the sun (circumsolar term)
    assert ac.cie_clear_sky(sun, sun, 5000.0) > a[v[:, 2] > 0].max()


def test_clear_sky_float32_nan_shapes():
    sun = direction(0.5, 0.0)
    v = np.array([[0, 0, 1.0], [np.nan, 0, 1], [0, 1, 0.2]])
    got = ac.cie_clear_sky(v, sun, 100.0)
    assert np.isnan(got[1]) and np.all(np.isfinite(got[[0, 2]]))
    g32 = ac.cie_clear_sky(v.astype(np.float32), sun, 100.0)
    assert g32.dtype == np.float32
    np.testing.assert_allclose(g32, got, rtol=1e-6)
    assert ac.cie_clear_sky(np.ones((2, 4, 3)), sun, 100.0).shape == (2, 4)


# ------------------------------------------------------------------------ zenith luminance
def test_krochmann_zenith_luminance():
    """Krochmann (1963): 123 + 8600 sin h cd m⁻²."""
    got = ac.cie_zenith_luminance(np.radians([90.0, 60.0, 0.0, 100.0]), method="krochmann")
    np.testing.assert_allclose(got, [123.0, 123 + 8600 * 0.5, 8723.0, 0.0], rtol=1e-12, atol=1e-9)


def test_preetham_zenith_luminance_method():
    got = ac.cie_zenith_luminance(math.radians(30), method="preetham", turbidity=3.0)
    chi = (4 / 9 - 3 / 120) * (math.pi - 2 * math.radians(30))
    ref = ((4.0453 * 3 - 4.9710) * math.tan(chi) - 0.2155 * 3 + 2.4192) * 1000
    assert got == pytest.approx(ref, rel=1e-14)


def test_bad_input():
    with pytest.raises(ValueError, match="zenith_luminance"):
        ac.cie_overcast_luminance(0.1, -5.0)
    with pytest.raises(ValueError, match="zenith_luminance"):
        ac.cie_clear_sky([0, 0, 1.0], [0, 0, 1.0], np.nan)
    with pytest.raises(ValueError, match="method"):
        ac.cie_zenith_luminance(0.3, method="karayel")
    with pytest.raises(ValueError, match="turbidity"):
        ac.cie_zenith_luminance(0.3, method="preetham")
    with pytest.raises(ValueError, match="sun_zenith"):
        ac.cie_zenith_luminance(-0.3)
    with pytest.raises(ValueError, match="sun_zenith"):
        ac.cie_clear_sky_luminance(0.1, 0.1, 4.0, 100.0)
    with pytest.raises(ValueError, match="horizontal_illuminance"):
        ac.cie_overcast_zenith_luminance_from_illuminance(-1.0)
    with pytest.raises(ValueError, match="view_directions"):
        ac.cie_overcast_sky([1.0, 2.0], 100.0)
    with pytest.raises(ValueError, match="sun_direction"):
        ac.cie_clear_sky([0, 0, 1.0], [0.0, 0.0, 0.0], 100.0)


def test_clear_sky_agrees_with_cie_general_sky_type_12():
    """CIE S 011/E:2003 (ISO 15469:2004) standard general sky, type 12 ("CIE standard clear
    sky, low luminance turbidity"): gradation a = -1, b = -0.32, indicatrix c = 10, d = -3,
    e = 0.45, with f(χ) = 1 + c[e^{dχ} - e^{dπ/2}] + e cos²χ. Its constant
    1 - 10 e^{-3π/2} = 0.91010 is the 0.91 of the 1973 formula, so the two agree to ~2e-4."""

    def general_sky(theta, chi, ts, a=-1.0, b=-0.32, c=10.0, d=-3.0, e=0.45):
        def phi(z):
            return 1 + a * math.exp(b / math.cos(z))

        def f(x):
            return 1 + c * (math.exp(d * x) - math.exp(d * math.pi / 2)) + e * math.cos(x) ** 2

        return phi(theta) * f(chi) / (phi(0.0) * f(ts))

    rng = np.random.default_rng(4)
    for tsd in (10.0, 45.0, 75.0):
        ts = math.radians(tsd)
        theta = rng.uniform(0, math.pi / 2 - 1e-3, 30)
        chi = rng.uniform(0, math.pi, 30)
        got = ac.cie_clear_sky_luminance(theta, chi, ts, 1.0)
        ref = [general_sky(t, c, ts) for t, c in zip(theta, chi, strict=True)]
        np.testing.assert_allclose(got, ref, rtol=3e-4)

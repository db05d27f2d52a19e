"""Tests for atmoscatter.sky.aerial (Hoffman & Preetham, seed 000; seed 004)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy import integrate

import atmoscatter as ac

SUN = np.array([0.0, 0.6, 0.8])  # sun zenith acos(0.8) ≈ 36.87°


def f_rayleigh(mu):
    return 3.0 / (16.0 * math.pi) * (1.0 + mu * mu)  # seed 000


def f_hg(mu, g):
    return (1 - g * g) / (4 * math.pi * (1 + g * g - 2 * g * mu) ** 1.5)  # errata 000.1


def iqbal(theta):
    """Seed 000 Eq. 5 relative optical length, θ in degrees inside (written independently)."""
    d = math.degrees(theta)
    return 1.0 / (math.cos(theta) + 0.15 * (93.885 - d) ** -1.253)


# ------------------------------------------------------------------------------ numerics
def test_one_minus_exp_ratio_small_and_large_ends():
    x = np.array([0.0, 1e-300, 1e-12, 1e-8, 1e-4])
    series = 1 - x / 2 + x**2 / 6 - x**3 / 24  # Taylor series, exact to rounding here
    np.testing.assert_allclose(ac.one_minus_exp_ratio(x), series, rtol=2e-16)
    big = np.array([50.0, 700.0, 1e4, 1e300])
    np.testing.assert_allclose(ac.one_minus_exp_ratio(big), 1.0 / big, rtol=1e-15)  # e^{-x} < 2e-22
    mid = np.array([0.1, 1.0, 5.0])
    ref = [(1 - math.exp(-v)) / v for v in mid]  # no cancellation at these x
    np.testing.assert_allclose(ac.one_minus_exp_ratio(mid), ref, rtol=1e-15)
    assert ac.one_minus_exp_ratio(np.inf) == 0.0
    assert np.isnan(ac.one_minus_exp_ratio(np.nan))
    assert ac.one_minus_exp_ratio(np.float32(1e-12)).dtype == np.float32
    with pytest.raises(ValueError, match="x must be >= 0"):
        ac.one_minus_exp_ratio(-1.0)


@pytest.mark.parametrize("beta,s", [(1e-5, 3e3), (2e-2, 1e2), (1e-4, 1e-8), (3e-3, 1e7)])
def test_path_integral_against_quadrature(beta, s):
    ref, _ = integrate.quad(lambda t: math.exp(-beta * t), 0, s, epsabs=0, epsrel=1e-13, limit=200)
    assert ac.path_integral(beta, s) == pytest.approx(ref, rel=1e-11)


def test_path_integral_limits():
    np.testing.assert_array_equal(ac.path_integral([0.0, 0.0, 2.0], [5.0, np.inf, 0.0]), [5.0, np.inf, 0.0])
    assert ac.path_integral(4.0, np.inf) == 0.25
    assert ac.path_integral(1e-300, 7.0) == pytest.approx(7.0, rel=1e-15)
    # beta*s spanning 1e-12 .. 1e4 with no warning (RuntimeWarning is an error here)
    beta = np.logspace(-12, 4, 33)
    got = ac.path_integral(beta, 1.0)
    np.testing.assert_allclose(got, -np.expm1(-beta) / beta, rtol=1e-15)


# --------------------------------------------------------------------------- coefficients
def test_rayleigh_values_of_seed_000():
    """Errata 000.4: 6.95e-6, 1.18e-5, 2.44e-5 m⁻¹ at 650, 570, 475 nm."""
    got = ac.hoffman_preetham_air_scattering()
    np.testing.assert_allclose(got, [6.95e-6, 1.18e-5, 2.44e-5], rtol=5e-3)


def test_haze_presets_follow_table_1_and_are_labelled():
    table = {  # errata 000.3
        "light_haze": (2e-5, 3e-5, 4e-5),
        "heavy_haze": (8e-5, 1e-4, 1.2e-4),
        "light_fog": (9e-4, 1e-3, 1.1e-3),
        "heavy_fog": (1e-2, 1e-2, 1e-2),
    }
    assert set(ac.HAZE_PRESETS) == set(table)
    gs = []
    for name, sc in table.items():
        p = ac.HAZE_PRESETS[name]
        np.testing.assert_array_equal(p.scattering, sc)
        assert 0 < p.g < 1 and "INTERPRETATION" in p.note and f"g = {p.g:.2f}" in p.note
        gs.append(p.g)
    assert gs == sorted(gs)  # |g| grows with beta (seed 000 text)
    with pytest.raises(ValueError, match="g must be in"):
        ac.HazePreset("bad", (1e-5, 1e-5, 1e-5), 1.0)
    with pytest.raises(ValueError, match="scattering"):
        ac.HazePreset("bad", (-1e-5, 1e-5, 1e-5), 0.5)


# ------------------------------------------------------------------------ extinction, sun
def test_extinction_factor():
    ba = np.array([1e-5, 2e-5, 3e-5])
    bh = np.array([4e-5, 5e-5, 6e-5])
    F = ac.hoffman_preetham_extinction([0.0, 1000.0, np.inf], [0.0, 300.0, np.inf], ba, bh)
    assert F.shape == (3, 3)
    np.testing.assert_array_equal(F[0], 1.0)
    np.testing.assert_allclose(F[1], [math.exp(-(a * 1000 + h * 300)) for a, h in zip(ba, bh, strict=True)], rtol=1e-15)
    np.testing.assert_array_equal(F[2], 0.0)
    # a transparent constituent over an infinite path does not give 0*inf = NaN
    np.testing.assert_allclose(ac.hoffman_preetham_extinction(np.inf, 10.0, 0.0, 1e-3), [math.exp(-1e-3 * 10.0)], rtol=1e-15)
    with pytest.raises(ValueError, match="s_air"):
        ac.hoffman_preetham_extinction(-1.0, 0.0, ba, bh)


@pytest.mark.parametrize("tsd", [0.0, 45.0, 80.0, 89.9, 90.0])
def test_sunlight_after_iqbal_extinction(tsd):
    ts = math.radians(tsd)
    ba = ac.hoffman_preetham_air_scattering()
    bh = ac.HAZE_PRESETS["heavy_haze"].extinction
    E0 = np.array([1.0, 2.0, 3.0])
    got = ac.hoffman_preetham_sunlight(ts, ba, bh, sun_irradiance=E0)
    m = iqbal(ts)
    ref = E0 * np.exp(-(ba * 8400.0 * m + bh * 1250.0 * m))
    np.testing.assert_allclose(got, ref, rtol=1e-13)


def test_sunlight_below_horizon_and_default_sun():
    ba = ac.hoffman_preetham_air_scattering()
    got = ac.hoffman_preetham_sunlight(np.radians([95.0, 180.0]), ba, np.zeros(3))
    np.testing.assert_array_equal(got, 0.0)
    E0 = ac.solar_illuminance_rgb()
    # Y of the default E_sun⁰ ≈ luminous solar constant 133.8 klx (Darula et al. 2005)
    Y = ac.linear_rgb_to_XYZ(E0)[1]
    assert Y == pytest.approx(133.8e3, rel=0.01)


# --------------------------------------------------------------------------- in-scattering
def inscatter_quadrature(s_air, s_haze, mu, E, bsa, bea, bsh, beh, g):
    """L_in from the seed 000 differential equation, integrated numerically (per channel).

    L_in = ∫₀^{s_max} E [β_scAir f_R ρ_air(t) + β_scHaze f_HG ρ_haze(t)] e^{-τ(t)} dt, with
    ρ = 1 inside a constituent's optical length and 0 beyond (the two shells), τ(t) the
    optical depth from the eye to t.
    """

    def tau(t):
        return bea * min(t, s_air) + beh * min(t, s_haze)

    def integrand(t):
        src = bsa * f_rayleigh(mu) * (t < s_air) + bsh * f_hg(mu, g) * (t < s_haze)
        return E * src * math.exp(-tau(t))

    pts = sorted({s_air, s_haze})
    total = 0.0
    lo = 0.0
    for hi in pts:
        val, _ = integrate.quad(integrand, lo, hi, epsabs=0, epsrel=1e-12, limit=200)
        total += val
        lo = hi
    return total


@pytest.mark.parametrize(
    "s_air,s_haze",
    [(3000.0, 3000.0), (8400.0, 1250.0), (30000.0, 4464.0), (500.0, 2000.0), (1e5, 1e3)],
)
def test_inscattering_two_shell_matches_the_differential_equation(s_air, s_haze):
    bsa = ac.hoffman_preetham_air_scattering()
    haze = ac.HAZE_PRESETS["light_fog"]
    bsh = np.asarray(haze.scattering)
    beh = bsh + np.array([1e-5, 2e-5, 3e-5])  # some absorption too
    E = np.array([1.0e5, 0.9e5, 0.8e5])
    for mu in (-0.9, 0.0, 0.5, 0.999):
        got = ac.hoffman_preetham_inscattering(s_air, s_haze, mu, E, bsa, bsa, bsh, beh, haze.g)
        ref = [
            inscatter_quadrature(s_air, s_haze, mu, E[c], bsa[c], bsa[c], bsh[c], beh[c], haze.g)
            for c in range(3)
        ]
        np.testing.assert_allclose(got, ref, rtol=1e-10)


def test_inscattering_equal_lengths_is_eq4():
    bsa = np.array([1e-5, 2e-5, 4e-5])
    bsh = np.array([3e-5, 3e-5, 3e-5])
    beh = bsh * 1.1
    g, mu, s, E = 0.7, 0.3, 2500.0, np.array([1.0, 1.0, 1.0])
    got = ac.hoffman_preetham_inscattering(s, s, mu, E, bsa, bsa, bsh, beh, g)
    bex = bsa + beh
    ref = E * (bsa * f_rayleigh(mu) + bsh * f_hg(mu, g)) / bex * (1 - np.exp(-bex * s))  # Eq. 4
    np.testing.assert_allclose(got, ref, rtol=1e-13)


def test_inscattering_stability_ends():
    bsa = np.array([1e-5, 2e-5, 4e-5])
    E = np.ones(3)
    mu = 0.2
    # beta_ex -> 0: the limit beta_sc(theta) * s, not 0/0
    got0 = ac.hoffman_preetham_inscattering(1000.0, 1000.0, mu, E, bsa, 0.0, 0.0, 0.0, 0.5)
    np.testing.assert_allclose(got0, bsa * f_rayleigh(mu) * 1000.0, rtol=1e-15)
    # beta_ex * s = 1e-12 and 1e4
    s_small = 1e-12 / bsa
    got_small = ac.hoffman_preetham_inscattering(s_small, s_small, mu, E, bsa, bsa, 0.0, 0.0, 0.5)
    np.testing.assert_allclose(np.diagonal(got_small), bsa * f_rayleigh(mu) * s_small * (1 - 5e-13), rtol=1e-15)
    s_big = 1e4 / bsa
    got_big = ac.hoffman_preetham_inscattering(s_big, s_big, mu, E, bsa, bsa, 0.0, 0.0, 0.5)
    np.testing.assert_allclose(np.diagonal(got_big), f_rayleigh(mu), rtol=1e-15)  # beta_sc/beta_ex = 1
    inf = ac.hoffman_preetham_inscattering(np.inf, np.inf, mu, E, bsa, bsa, 0.0, 0.0, 0.5)
    np.testing.assert_allclose(inf, f_rayleigh(mu), rtol=1e-15)
    zero = ac.hoffman_preetham_inscattering(0.0, 0.0, mu, E, bsa, bsa, bsa, bsa, 0.5)
    np.testing.assert_array_equal(zero, 0.0)


# ---------------------------------------------------------------------------- two-shell sky
def sky_scalar(v, sun, haze, E0):
    """Seed 000 sky: mesh at the air optical length, s_haze = s_air * 1.25/8.4, errata 000.6."""
    bsa = ac.hoffman_preetham_air_scattering()
    bsh = np.asarray(haze.scattering)
    beh = bsh + np.asarray(haze.absorption)
    ts = math.acos(sun[2])
    m_sun = iqbal(ts)
    E = E0 * np.exp(-(bsa * 8400 * m_sun + beh * 1250 * m_sun))
    theta_v = math.acos(min(max(v[2], 0.0), 1.0))
    s_air = 8400.0 * iqbal(theta_v)
    s_haze = s_air * 1250.0 / 8400.0
    mu = float(np.dot(v, sun))
    sc_air = bsa * f_rayleigh(mu)
    sc_haze = bsh * f_hg(mu, haze.g)
    bt = bsa + beh
    inner = (sc_air + sc_haze) / bt * (1 - np.exp(-bt * s_haze))
    outer = sc_air / bsa * (1 - np.exp(-bsa * (s_air - s_haze))) * np.exp(-bt * s_haze)
    return E * (inner + outer)


def test_two_shell_sky_matches_errata_000_6():
    haze = ac.HAZE_PRESETS["heavy_haze"]
    E0 = np.array([1.2e5, 1.3e5, 1.4e5])
    rng = np.random.default_rng(3)
    v = rng.normal(size=(40, 3))
    v[:, 2] = np.abs(v[:, 2])
    v /= np.linalg.norm(v, axis=1, keepdims=True)
    got = ac.hoffman_preetham_sky(v, SUN, haze="heavy_haze", sun_irradiance=E0)
    ref = np.array([sky_scalar(row, SUN, haze, E0) for row in v])
    np.testing.assert_allclose(got, ref, rtol=1e-12)


def test_two_shell_sky_edges():
    v = np.array([[0, 0, 1.0], [1, 0, 0.0], [1, 0, -0.5], [np.nan, 0, 1], [0, 0, 0.0]])
    got = ac.hoffman_preetham_sky(v, SUN)
    assert np.all(np.isfinite(got[:3])) and np.all(got[:3] > 0)
    assert np.all(np.isnan(got[3:]))
    # below the horizon: the horizon optical length, with the view's own scattering angle;
    # compare with a horizon direction that has the same angle to the sun
    below = np.array([math.cos(0.3), 0.0, -math.sin(0.3)])
    y = below @ SUN / SUN[1]
    horizon = np.array([math.sqrt(1 - y * y), y, 0.0])
    np.testing.assert_allclose(ac.hoffman_preetham_sky(below, SUN), ac.hoffman_preetham_sky(horizon, SUN), rtol=1e-14)
    # sun below the horizon: black sky
    np.testing.assert_array_equal(ac.hoffman_preetham_sky(v[:3], [0.0, 1.0, -0.1]), 0.0)
    # symmetric about the solar vertical
    a = ac.hoffman_preetham_sky([0.5, 0.5, math.sqrt(0.5)], SUN)
    b = ac.hoffman_preetham_sky([-0.5, 0.5, math.sqrt(0.5)], SUN)
    np.testing.assert_allclose(a, b, rtol=1e-14)
    assert ac.hoffman_preetham_sky(v[:3].astype(np.float32), SUN).dtype == np.float32
    assert ac.hoffman_preetham_sky(np.ones((2, 5, 3)), SUN, haze=None).shape == (2, 5, 3)
    with pytest.raises(ValueError, match="haze"):
        ac.hoffman_preetham_sky(v[:3], SUN, haze="smog")


# ------------------------------------------------------------------------ aerial perspective
def test_aerial_perspective_distance_zero_is_exact():
    rng = np.random.default_rng(0)
    L0 = rng.uniform(0, 5000, size=(4, 5, 3))
    d = np.zeros((4, 5))
    np.testing.assert_array_equal(ac.aerial_perspective(L0, d, [0.3, 0.9, 0.1], SUN), L0)
    L32 = L0.astype(np.float32)
    got = ac.aerial_perspective(L32, d, [0.3, 0.9, 0.1], SUN)
    assert got.dtype == np.float32
    np.testing.assert_array_equal(got, L32)


def test_aerial_perspective_is_Fex_L0_plus_Lin():
    rng = np.random.default_rng(1)
    L0 = rng.uniform(0, 5000, size=(6, 3))
    d = np.array([1.0, 10.0, 1e3, 1e4, 1e5, np.inf])
    view = rng.normal(size=(6, 3))
    view /= np.linalg.norm(view, axis=1, keepdims=True)
    haze = ac.HAZE_PRESETS["heavy_haze"]
    got = ac.aerial_perspective(L0, d, view, SUN, haze="heavy_haze")
    bsa = ac.hoffman_preetham_air_scattering()
    bsh = np.asarray(haze.scattering)
    bex = bsa + bsh
    E = ac.solar_illuminance_rgb() * np.exp(-(bsa * 8400 + bsh * 1250) * iqbal(math.acos(0.8)))
    for i in range(6):
        mu = float(view[i] @ SUN)
        bth = bsa * f_rayleigh(mu) + bsh * f_hg(mu, haze.g)
        F = np.exp(-bex * d[i])
        Lin = E * bth / bex * (1 - F)  # Eq. 4 (no cancellation at these optical depths)
        np.testing.assert_allclose(got[i], F * L0[i] + Lin, rtol=1e-10)
    # far away the object disappears into the "airlight" E β_sc(θ)/β_ex
    assert np.all(np.isfinite(got[-1]))


def test_aerial_perspective_options_and_bad_input():
    L0 = np.full((2, 3), 100.0)
    d = np.array([100.0, 2000.0])
    base = ac.aerial_perspective(L0, d, [1.0, 0, 0], SUN, haze=None, sun_extinction=False, sun_irradiance=[1.0, 1.0, 1.0])
    bsa = ac.hoffman_preetham_air_scattering()
    mu = 0.0
    ref = np.exp(-bsa * d[:, None]) * 100.0 + bsa * f_rayleigh(mu) / bsa * (1 - np.exp(-bsa * d[:, None]))
    np.testing.assert_allclose(base, ref, rtol=1e-13)
    g_hi = ac.aerial_perspective(L0, d, SUN, SUN, g=0.9)
    g_lo = ac.aerial_perspective(L0, d, SUN, SUN, g=0.1)
    assert np.all(g_hi > g_lo)  # looking toward the sun: forward scattering brightens
    assert np.all(np.isnan(ac.aerial_perspective(L0, d, [0.0, 0.0, 0.0], SUN)))
    with pytest.raises(TypeError, match="unknown option"):
        ac.aerial_perspective(L0, d, SUN, SUN, turbidity=3.0)
    with pytest.raises(ValueError, match="distance"):
        ac.aerial_perspective(L0, -d, SUN, SUN)
    with pytest.raises(ValueError, match="L0"):
        ac.aerial_perspective(np.ones((2, 4)), d, SUN, SUN)
    with pytest.raises(ValueError, match="haze"):
        ac.aerial_perspective(L0, d, SUN, SUN, haze="smog")
    with pytest.raises(ValueError, match="sun_direction"):
        ac.aerial_perspective(L0, d, SUN, [0.0, 0.0])
    with pytest.raises(ValueError, match="g must be in"):
        ac.aerial_perspective(L0, d, SUN, SUN, g=1.5)


def test_aerial_perspective_depth_buffer_shapes():
    H, W = 8, 12
    L0 = np.ones((H, W, 3))
    depth = np.linspace(0, 5e4, H * W).reshape(H, W)
    out = ac.aerial_perspective(L0, depth, [0.0, 1.0, 0.05], SUN)
    assert out.shape == (H, W, 3)
    # per-pixel view directions too
    views = np.broadcast_to([0.0, 1.0, 0.05], (H, W, 3))
    np.testing.assert_allclose(ac.aerial_perspective(L0, depth, views, SUN), out, rtol=1e-15)
    # distant objects converge to the airlight: monotone approach for a dark object
    dark = ac.aerial_perspective(np.zeros((H, W, 3)), depth, [0.0, 1.0, 0.05], SUN)
    assert np.all(np.diff(dark.reshape(-1, 3), axis=0) >= 0)


def test_chunked_evaluation_matches_small_calls():
    from atmoscatter.sky import aerial

    n = aerial._CHUNK * 2 + 3
    rng = np.random.default_rng(7)
    d = rng.uniform(0, 2e4, n)
    L0 = rng.uniform(0, 1e3, (n, 3))
    whole = ac.aerial_perspective(L0, d, [0.2, 0.9, 0.1], SUN)
    idx = [0, 5, aerial._CHUNK - 1, aerial._CHUNK, n - 1]
    parts = ac.aerial_perspective(L0[idx], d[idx], [0.2, 0.9, 0.1], SUN)
    np.testing.assert_allclose(whole[idx], parts, rtol=1e-15)
    v = rng.normal(size=(n, 3))
    sky = ac.hoffman_preetham_sky(v, SUN)
    np.testing.assert_allclose(sky[idx], ac.hoffman_preetham_sky(v[idx], SUN), rtol=1e-15)


def test_scalar_shapes():
    out = ac.aerial_perspective([10.0, 20.0, 30.0], 500.0, [0.0, 1.0, 0.0], SUN)
    assert out.shape == (3,)
    ref = ac.aerial_perspective(np.array([[10.0, 20.0, 30.0]]), np.array([500.0]), [0.0, 1.0, 0.0], SUN)
    np.testing.assert_allclose(out, ref[0], rtol=1e-15)
    assert ac.hoffman_preetham_sky([0.0, 0.0, 1.0], SUN).shape == (3,)
    assert np.ndim(ac.one_minus_exp_ratio(0.5)) == 0


def test_path_integral_bad_input():
    with pytest.raises(ValueError, match="beta"):
        ac.path_integral(-1.0, 1.0)
    with pytest.raises(ValueError, match="beta"):
        ac.path_integral(np.inf, 1.0)
    with pytest.raises(ValueError, match="s must be"):
        ac.path_integral(1.0, -1.0)


# ------------------------------------------------------ exact limits (issue 10, part 8)
# The physics of Eq. 1/3/4 fixes every 0·∞ and ∞/∞ case: no extinction keeps the object's
# radiance (F_ex = e^0 = 1), no scatterer adds no light (∫ 0 dt = 0 however long the path),
# and over an infinite path with β_ex > 0 the in-scattered light is the airlight
# E β_sc(θ)/β_ex, which is finite however small β_ex is.  Reference values below are those
# closed forms, evaluated directly.
VIEW = np.array([0.0, 1.0, 0.0])  # horizontal, μ = view·sun = 0.6
MU_VIEW = 0.6


def test_aerial_perspective_transparent_medium_keeps_L0_at_infinite_distance():
    L0 = np.array([[1.0, 2.0, 3.0], [0.0, 5e3, 7.0]])
    for d in (np.inf, 1e300, 0.0):
        got = ac.aerial_perspective(L0, d, VIEW, SUN, haze=None, air_scattering=[0.0, 0.0, 0.0])
        # F_ex = e^{-0·s} = 1 exactly and L_in = 0 exactly: the copy is exact by construction
        np.testing.assert_array_equal(got, L0)
    got32 = ac.aerial_perspective(L0.astype(np.float32), np.float32(np.inf), VIEW, SUN, haze=None,
                                  air_scattering=[0.0, 0.0, 0.0])  # fmt: skip
    assert got32.dtype == np.float32
    np.testing.assert_array_equal(got32, L0.astype(np.float32))  # exact, as above


def test_aerial_perspective_per_channel_limits_at_infinite_distance():
    # channel 0: transparent (L0 kept); 1: ordinary air (airlight E f_R, since β_sc = β_ex);
    # 2: subnormal β (1e-310: 1/β overflows, the ratio β_sc/β_ex = 1 does not)
    E = np.array([1.0e5, 2.0e5, 3.0e5])
    L0 = np.array([10.0, 20.0, 30.0])
    got = ac.aerial_perspective(L0, np.inf, VIEW, SUN, haze=None, sun_extinction=False,
                                sun_irradiance=E, air_scattering=[0.0, 1e-5, 1e-310])  # fmt: skip
    airlight = E * f_rayleigh(MU_VIEW)
    np.testing.assert_allclose(got, [L0[0], airlight[1], airlight[2]], rtol=1e-15)


def test_aerial_perspective_infinite_distance_is_the_limit_of_large_distances():
    # continuity at s = inf: with β s = 800, e^{-β s} < 1e-347 underflows, so the finite
    # path already equals the limit to rounding (a few ulps from the different formulas)
    for beta in (1e-5, 1e-300):
        kw = {"haze": None, "sun_extinction": False, "sun_irradiance": [1.0, 2.0, 3.0],
              "air_scattering": [beta] * 3}  # fmt: skip
        far = ac.aerial_perspective([5.0, 5.0, 5.0], 800.0 / beta, VIEW, SUN, **kw)
        inf = ac.aerial_perspective([5.0, 5.0, 5.0], np.inf, VIEW, SUN, **kw)
        np.testing.assert_allclose(inf, far, rtol=4e-16)
        assert np.all(np.isfinite(inf))


def test_inscattering_zero_coefficients_over_infinite_lengths_is_zero():
    z = np.zeros(3)
    E = np.ones(3)
    for sa, sh in ((np.inf, np.inf), (np.inf, 0.0), (0.0, np.inf), (np.inf, 1e3), (1e3, np.inf)):
        got = ac.hoffman_preetham_inscattering(sa, sh, 0.2, E, z, z, z, z, 0.5)
        np.testing.assert_array_equal(got, 0.0)  # ∫ 0 dt: exactly 0
    # no sunlight: 0 even for a scatterer without extinction over an infinite path (inf·0)
    b = np.array([1e-5, 2e-5, 4e-5])
    got = ac.hoffman_preetham_inscattering(np.inf, np.inf, 0.2, z, b, z, z, z, 0.5)
    np.testing.assert_array_equal(got, 0.0)
    # ... while with sunlight that limit is E β_sc f s → inf (not NaN)
    got = ac.hoffman_preetham_inscattering(np.inf, np.inf, 0.2, E, b, z, z, z, 0.5)
    assert np.all(np.isposinf(got))


@pytest.mark.parametrize("zero", ["air", "haze"])
def test_inscattering_absent_constituent_with_infinite_length(zero):
    # a constituent with zero coefficients adds neither light nor extinction, whatever its
    # optical length: the result is Eq. 4 of the other constituent over its own length
    b = np.array([1e-5, 2e-5, 4e-5])
    bex = b * 1.3
    z = np.zeros(3)
    E = np.array([1.0, 2.0, 3.0])
    mu, g, s = 0.3, 0.7, 1500.0
    if zero == "air":
        got = ac.hoffman_preetham_inscattering(np.inf, s, mu, E, z, z, b, bex, g)
        ref = E * b * f_hg(mu, g) / bex * -np.expm1(-bex * s)
    else:
        got = ac.hoffman_preetham_inscattering(s, np.inf, mu, E, b, bex, z, z, g)
        ref = E * b * f_rayleigh(mu) / bex * -np.expm1(-bex * s)
    np.testing.assert_allclose(got, ref, rtol=1e-14)


def test_inscattering_tiny_extinction_over_infinite_lengths_is_the_airlight():
    # β_sc/β_ex f(θ) for β down to subnormal values (1/β overflows below 5.6e-309)
    mu, E = 0.2, np.ones(3)
    for scale in (1.0, 1e-300, 1e-305, 1e-315):  # β from 4e-5 down to 1e-320 [m⁻¹]
        b = np.array([1e-5, 2e-5, 4e-5]) * scale
        assert np.all(b > 0)
        got = ac.hoffman_preetham_inscattering(np.inf, np.inf, mu, E, b, b, 0.0, 0.0, 0.5)
        # β_sc = β_ex: the ratio is exactly 1 even for subnormal β, so f_R to rounding
        np.testing.assert_allclose(got, f_rayleigh(mu), rtol=1e-15)
    # outer shell of air (tiny β, infinite) seen through 100 m of haze
    b = np.array([1e-5, 2e-5, 4e-5]) * 1e-305
    bh = np.array([1e-3, 1e-3, 1e-3])
    got = ac.hoffman_preetham_inscattering(np.inf, 100.0, mu, E, b, b, bh, bh, 0.5)
    inner = bh * f_hg(mu, 0.5) / bh * -np.expm1(-bh * 100.0) + b * f_rayleigh(mu) * 100.0
    ref = inner + f_rayleigh(mu) * np.exp(-bh * 100.0)
    np.testing.assert_allclose(got, ref, rtol=1e-14)


def test_inscattering_float32_limits():
    # float32 in, float32 out, computed in float64: a float32-subnormal β (1e-39) over an
    # infinite path gives the airlight instead of 1/β = inf in float32
    b = np.array([1e-5, 2e-5, 4e-5])
    args = dict(s_air=np.inf, s_haze=np.inf, cos_theta=0.2, sun_irradiance=np.ones(3))
    for scale in (1.0, 1e-34):
        b32 = (b * scale).astype(np.float32)
        got = ac.hoffman_preetham_inscattering(
            *[np.float32(args[k]) for k in ("s_air", "s_haze", "cos_theta")],
            np.float32(args["sun_irradiance"]), b32, b32, np.float32(0.0), np.float32(0.0), 0.5,
        )
        assert got.dtype == np.float32
        # the float32 cosine 0.2 and one final rounding to float32: a few float32 ulps
        np.testing.assert_allclose(got, f_rayleigh(float(np.float32(0.2))), rtol=3e-7)
    z = np.zeros(3, dtype=np.float32)
    got = ac.hoffman_preetham_inscattering(np.float32(np.inf), np.float32(np.inf), np.float32(0.2),
                                           np.ones(3, np.float32), z, z, z, z, 0.5)  # fmt: skip
    assert got.dtype == np.float32
    np.testing.assert_array_equal(got, 0.0)


@settings(max_examples=80, deadline=None)
@given(
    beta=st.one_of(st.just(0.0), st.floats(min_value=1e-320, max_value=1e-1)),
    s=st.one_of(st.just(np.inf), st.floats(min_value=0.0, max_value=1e308)),
    L0=st.floats(min_value=0.0, max_value=1e6),
)
def test_property_aerial_perspective_is_a_convex_mix_of_L0_and_airlight(beta, s, L0):
    # For air only (β_sc = β_ex = β) Eq. 1 + Eq. 4 read L = F L0 + (1 − F) A with
    # F = e^{−β s} ∈ [0, 1] and the airlight A = E f_R(θ): L lies between L0 and A (a few
    # ulps of slack for the rounding of F, 1 − F and the sum), never NaN, for every β ≥ 0
    # (subnormal included) and every s ∈ [0, inf]; with β = 0 or s = 0 it is L0 exactly.
    E = 1.0e5
    got = ac.aerial_perspective([L0] * 3, s, VIEW, SUN, haze=None, sun_extinction=False,
                                sun_irradiance=[E] * 3, air_scattering=[beta] * 3)  # fmt: skip
    A = E * f_rayleigh(MU_VIEW)
    lo, hi = min(L0, A), max(L0, A)
    assert np.all(np.isfinite(got))
    assert np.all(got >= lo * (1 - 1e-14)) and np.all(got <= hi * (1 + 1e-14))
    if beta == 0.0 or s == 0.0:
        np.testing.assert_array_equal(got, L0)  # F = 1, L_in = 0 exactly: exact by construction
    if beta > 0 and np.isinf(s):
        np.testing.assert_allclose(got, A, rtol=1e-14)  # F = 0, β_sc/β_ex = 1 exactly

@pytest.mark.parametrize("T", [1.0, 2.0, 3.0, 6.0])
def test_turbidity_haze_is_the_extinction_ratio(T):
    # T = (τ_m + τ_h)/τ_m at 550 nm (Preetham 1999; errata 004.3) with the model's zenith
    # optical lengths 8400 m / 1250 m (seed 000): evaluate the haze at 550 nm itself
    # (wavelength triple containing 550) and check against the air of the same model.
    h = ac.turbidity_haze(T, (650.0, 550.0, 475.0))
    tau_m = float(ac.hoffman_preetham_air_scattering(550.0, air="standard")) * 8400.0
    tau_h = h.extinction[1] * 1250.0
    assert (tau_m + tau_h) / tau_m == pytest.approx(T, rel=1e-12)
    np.testing.assert_allclose(np.asarray(h.scattering), 0.9 * h.extinction, rtol=1e-12)
    assert h.g == 0.8
    # real air: Bodhaine et al. (1999) sea-level coefficient 1.1488e-5 m⁻¹ at 550 nm
    assert tau_m == pytest.approx(1.1488e-5 * 8400.0, rel=1e-3)
    with pytest.raises(ValueError, match="wavelengths"):
        ac.turbidity_haze(T, (550.0, 650.0))
    with pytest.raises(ValueError, match="air"):
        ac.turbidity_haze(T, air="vacuum")

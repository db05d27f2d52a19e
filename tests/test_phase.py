"""Tests for atmoscatter.phase: normalisation, mean cosine, limits, clamping, bad input."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.integrate import quad

import atmoscatter as ac

G_EXTREMES = [-0.999, -0.99, -0.9, -0.5, 0.0, 0.3, 0.8, 0.9, 0.99, 0.999]


def sphere_integral(f, moment: int = 0) -> float:
    """2π ∫_{-1}^{1} f(μ) μ^moment dμ by adaptive quadrature (scipy.integrate.quad).

    Independent reference: the two halves are integrated in u = log(1 − μ) (forward) and
    v = log(1 + μ) (backward), which spreads the forward/backward peak of width
    ~(1 − |g|)² in μ (g = ±0.999: ~5e-7) over many units of u, so quad resolves it.
    """

    def fwd(u):
        mu = -np.expm1(u)  # 1 − e^u
        return float(f(mu)) * mu**moment * np.exp(u)

    def bwd(v):
        mu = np.expm1(v)  # e^v − 1
        return float(f(mu)) * mu**moment * np.exp(v)

    a = quad(fwd, -80.0, 0.0, epsabs=0.0, epsrel=1e-12, limit=500)[0]
    b = quad(bwd, -80.0, 0.0, epsabs=0.0, epsrel=1e-12, limit=500)[0]
    return 2.0 * np.pi * (a + b)


# ---------------------------------------------------------------------------------------
# normalisation and moments (reference: adaptive quadrature)
# ---------------------------------------------------------------------------------------


def test_rayleigh_normalised():
    assert sphere_integral(ac.rayleigh_phase) == pytest.approx(1.0, abs=1e-10)
    assert sphere_integral(ac.rayleigh_phase, 1) == pytest.approx(0.0, abs=1e-12)


def test_isotropic_normalised():
    assert sphere_integral(ac.isotropic_phase) == pytest.approx(1.0, abs=1e-12)


def test_rayleigh_values():
    # 3/(16π)(1 + μ²): seed 000 / seed 004
    mu = np.array([-1.0, -0.5, 0.0, 0.5, 1.0])
    np.testing.assert_allclose(ac.rayleigh_phase(mu), 3 / (16 * np.pi) * (1 + mu**2), rtol=1e-15)


@pytest.mark.parametrize("g", G_EXTREMES)
def test_henyey_greenstein_normalised_and_mean_cosine(g):
    f = lambda mu: ac.henyey_greenstein_phase(mu, g)  # noqa: E731
    # issue 2: normalised to 1e-6 including g = ±0.999 (we get ~1e-13)
    assert sphere_integral(f) == pytest.approx(1.0, abs=1e-6)
    # Henyey & Greenstein (1941): the mean cosine equals g
    assert sphere_integral(f, 1) == pytest.approx(g, abs=1e-6)


@pytest.mark.parametrize("g", G_EXTREMES)
def test_cornette_shanks_normalised_and_mean_cosine(g):
    f = lambda mu: ac.cornette_shanks_phase(mu, g)  # noqa: E731
    assert sphere_integral(f) == pytest.approx(1.0, abs=1e-6)
    # Cornette & Shanks (1992): <μ> = 3g(4 + g²)/(5(2 + g²)) — written out here, compared
    # with quadrature and with the class property
    closed = 3 * g * (4 + g * g) / (5 * (2 + g * g))
    assert sphere_integral(f, 1) == pytest.approx(closed, abs=1e-6)
    assert ac.CornetteShanksPhase(g).asymmetry == pytest.approx(closed, abs=1e-15)


def test_henyey_greenstein_closed_form():
    # (1 − g²)/(4π(1 + g² − 2gμ)^{3/2}), errata 000.1 — evaluated naively in float64 where
    # the naive form is accurate (moderate g)
    mu = np.linspace(-1, 1, 41)
    for g in (-0.7, 0.2, 0.76):
        ref = (1 - g * g) / (4 * np.pi * (1 + g * g - 2 * g * mu) ** 1.5)
        np.testing.assert_allclose(ac.henyey_greenstein_phase(mu, g), ref, rtol=1e-13)


def test_henyey_greenstein_forward_peak_accuracy_near_g_one():
    # At μ = 1 the exact value is (1 + g)/(4π(1 − g)²).  For g = 0.999999 the naive
    # denominator 1 + g² − 2g loses ~12 digits; the stable form must not.
    g = 0.999999
    exact = (1 + g) / (4 * np.pi * (1 - g) ** 2)
    assert float(ac.henyey_greenstein_phase(1.0, g)) == pytest.approx(exact, rel=1e-9)
    exact_b = (1 - g) / (4 * np.pi * (1 + g) ** 2)
    assert float(ac.henyey_greenstein_phase(-1.0, -g)) == pytest.approx((1 + g) / (4 * np.pi * (1 - g) ** 2), rel=1e-9)
    assert float(ac.henyey_greenstein_phase(-1.0, g)) == pytest.approx(exact_b, rel=1e-9)


def test_cornette_shanks_tends_to_rayleigh():
    mu = np.linspace(-1, 1, 21)
    np.testing.assert_allclose(ac.cornette_shanks_phase(mu, 0.0), ac.rayleigh_phase(mu), rtol=1e-15)
    # first order in g: difference O(g)
    d = np.max(np.abs(ac.cornette_shanks_phase(mu, 1e-4) - ac.rayleigh_phase(mu)))
    assert 0 < d < 1e-4


def test_hg_isotropic_at_g_zero():
    mu = np.linspace(-1, 1, 7)
    np.testing.assert_allclose(ac.henyey_greenstein_phase(mu, 0.0), 1 / (4 * np.pi), rtol=1e-15)


def test_forward_scattering_sign_convention():
    # g > 0: more light toward the sun direction (μ = 1), errata 000.2
    assert ac.henyey_greenstein_phase(1.0, 0.8) > ac.henyey_greenstein_phase(-1.0, 0.8)
    assert ac.cornette_shanks_phase(1.0, 0.8) > ac.cornette_shanks_phase(-1.0, 0.8)
    assert ac.henyey_greenstein_phase(1.0, -0.8) < ac.henyey_greenstein_phase(-1.0, -0.8)


# ---------------------------------------------------------------------------------------
# clamping, NaN, shapes, dtype
# ---------------------------------------------------------------------------------------


PHASES = [
    ("rayleigh", lambda mu: ac.rayleigh_phase(mu)),
    ("isotropic", lambda mu: ac.isotropic_phase(mu)),
    ("hg", lambda mu: ac.henyey_greenstein_phase(mu, 0.999)),
    ("hg-", lambda mu: ac.henyey_greenstein_phase(mu, -0.999)),
    ("cs", lambda mu: ac.cornette_shanks_phase(mu, 0.999)),
]


@pytest.mark.parametrize(("name", "f"), PHASES)
def test_cosine_rounding_outside_range_is_clamped(name, f):
    for mu, edge in ((1.0 + 1e-12, 1.0), (-1.0 - 1e-12, -1.0), (np.nextafter(1.0, 2.0), 1.0)):
        v = f(mu)
        assert np.isfinite(v)
        assert float(v) == float(f(edge))
    v32 = f(np.float32(1.0) + np.finfo(np.float32).eps)
    assert np.isfinite(v32)


@pytest.mark.parametrize(("name", "f"), PHASES)
def test_cosine_far_outside_range_is_value_error(name, f):
    with pytest.raises(ValueError, match="cos_theta"):
        f(1.1)


@pytest.mark.parametrize(("name", "f"), PHASES)
def test_nan_propagates_elementwise(name, f):
    out = f(np.array([0.3, np.nan, -0.2]))
    assert np.isnan(out[1])
    assert np.all(np.isfinite(out[[0, 2]]))


@pytest.mark.parametrize(("name", "f"), PHASES)
def test_shapes_and_float32(name, f):
    mu = np.linspace(-1, 1, 24).reshape(2, 3, 4)
    assert f(mu).shape == (2, 3, 4)
    assert np.ndim(f(0.5)) == 0
    out32 = f(mu.astype(np.float32))
    assert out32.dtype == np.float32
    np.testing.assert_allclose(out32, f(mu), rtol=1e-4)


def test_g_broadcasts_against_cosines():
    mu = np.linspace(-1, 1, 5)
    g = np.array([[0.0], [0.5], [0.9]])
    for fn in (ac.henyey_greenstein_phase, ac.cornette_shanks_phase):
        out = fn(mu, g)
        assert out.shape == (3, 5)
        np.testing.assert_allclose(out[1], fn(mu, 0.5), rtol=1e-15)


# ---------------------------------------------------------------------------------------
# bad input
# ---------------------------------------------------------------------------------------


@pytest.mark.parametrize("g", [1.0, -1.0, 1.5, -3.0, np.nan, np.inf])
def test_bad_g(g):
    with pytest.raises(ValueError, match="g"):
        ac.henyey_greenstein_phase(0.5, g)
    with pytest.raises(ValueError, match="g"):
        ac.cornette_shanks_phase(0.5, g)
    with pytest.raises(ValueError, match="g"):
        ac.HenyeyGreensteinPhase(g)
    with pytest.raises(ValueError, match="g"):
        ac.CornetteShanksPhase(g)


def test_bad_g_message_names_value_and_range():
    with pytest.raises(ValueError, match=r"g must be in \(-1.0, 1.0\).*1.0"):
        ac.henyey_greenstein_phase(0.0, 1.0)


def test_non_numeric_cosine_is_type_error():
    with pytest.raises(TypeError, match="cos_theta"):
        ac.rayleigh_phase("up")


# ---------------------------------------------------------------------------------------
# parameter objects
# ---------------------------------------------------------------------------------------


def test_phase_objects_are_frozen_callables():
    mu = np.linspace(-1, 1, 9)
    hg = ac.HenyeyGreensteinPhase(0.7)
    cs = ac.CornetteShanksPhase(0.7)
    np.testing.assert_array_equal(hg(mu), ac.henyey_greenstein_phase(mu, 0.7))
    np.testing.assert_array_equal(cs(mu), ac.cornette_shanks_phase(mu, 0.7))
    np.testing.assert_array_equal(ac.RayleighPhase()(mu), ac.rayleigh_phase(mu))
    np.testing.assert_array_equal(ac.IsotropicPhase()(mu), ac.isotropic_phase(mu))
    assert hg.asymmetry == 0.7
    assert ac.RayleighPhase().asymmetry == 0.0
    assert ac.IsotropicPhase().asymmetry == 0.0
    assert ac.HenyeyGreensteinPhase().g == 0.8  # Bruneton (2017) default
    with pytest.raises(dataclasses.FrozenInstanceError):
        hg.g = 0.1  # type: ignore[misc]
    assert hash(ac.HenyeyGreensteinPhase(0.7)) == hash(hg)
    assert isinstance(ac.HenyeyGreensteinPhase(np.float32(0.5)).g, float)


# ---------------------------------------------------------------------------------------
# property-based tests (hypothesis)
# ---------------------------------------------------------------------------------------

g_values = st.floats(min_value=-0.999, max_value=0.999, allow_nan=False)


@settings(max_examples=40, deadline=None)
@given(g=g_values)
def test_property_normalisation(g):
    for fn in (ac.henyey_greenstein_phase, ac.cornette_shanks_phase):
        assert sphere_integral(lambda mu, fn=fn: fn(mu, g)) == pytest.approx(1.0, abs=1e-6)


@settings(max_examples=100, deadline=None)
@given(
    g=g_values,
    mu=st.lists(st.floats(min_value=-1.0 - 1e-9, max_value=1.0 + 1e-9, allow_nan=False), min_size=1, max_size=20),
)
def test_property_positive_finite(g, mu):
    mu = np.asarray(mu)
    for fn in (ac.henyey_greenstein_phase, ac.cornette_shanks_phase):
        v = fn(mu, g)
        assert np.all(np.isfinite(v))
        assert np.all(v > 0)
        v32 = fn(mu.astype(np.float32), np.float32(g))
        assert np.all(np.isfinite(v32))
        assert np.all(v32 > 0)


@settings(max_examples=60, deadline=None)
@given(g=st.floats(min_value=0.0, max_value=0.999, allow_nan=False))
def test_property_hg_monotone_for_forward_g(g):
    # for g ≥ 0 the HG function increases with μ (peak toward the sun)
    mu = np.linspace(-1, 1, 201)
    v = ac.henyey_greenstein_phase(mu, g)
    assert np.all(np.diff(v) >= 0)

"""Tests for atmoscatter.sky.perez (Perez et al. 1993 distribution function)."""

from __future__ import annotations

import math

import numpy as np
import pytest

import atmoscatter as ac

# Preetham et al. (1999) Appendix A.2 luminance coefficients at T = 2.5 (errata 003.3):
# A = 0.1787 T - 1.4630, B = -0.3554 T + 0.4275, C = -0.0227 T + 5.3251,
# D = 0.1206 T - 2.5771, E = -0.0670 T + 0.3703.
T = 2.5
COEF = (
    0.1787 * T - 1.4630,
    -0.3554 * T + 0.4275,
    -0.0227 * T + 5.3251,
    0.1206 * T - 2.5771,
    -0.0670 * T + 0.3703,
)


def perez_scalar(theta, gamma, A, B, C, D, E):
    """Seed 003 §5 / seed 004, transcribed with the math module (independent evaluation)."""
    return (1 + A * math.exp(B / math.cos(theta))) * (
        1 + C * math.exp(D * gamma) + E * math.cos(gamma) ** 2
    )


@pytest.mark.parametrize(
    "theta,gamma",
    [(0.0, 0.0), (0.3, 0.1), (1.0, 2.0), (1.5, math.pi), (1.5707, 0.7), (0.0, 1.2)],
)
def test_matches_scalar_transcription(theta, gamma):
    got = ac.perez(theta, gamma, *COEF)
    assert got == pytest.approx(perez_scalar(theta, gamma, *COEF), rel=1e-14)


def test_horizon_and_below_take_the_horizon_limit():
    A, B, C, D, E = COEF
    gamma = 0.8
    limit = 1.0 * (1 + C * math.exp(D * gamma) + E * math.cos(gamma) ** 2)  # e^{B/0+} = 0
    got = ac.perez(np.array([np.pi / 2, 1.8, np.pi, 10.0]), gamma, *COEF)
    np.testing.assert_allclose(got, limit, rtol=1e-15)
    # continuity: approaching the horizon from above converges to the limit
    near = ac.perez(np.pi / 2 - 1e-4, gamma, *COEF)
    assert near == pytest.approx(limit, rel=1e-12)


def test_B_zero_gives_exp_zero_limit_and_B_positive_raises():
    A, _, C, D, E = COEF
    got = ac.perez([0.0, np.pi / 2, 2.0], 0.5, A, 0.0, C, D, E)
    expect = (1 + A) * (1 + C * math.exp(D * 0.5) + E * math.cos(0.5) ** 2)
    np.testing.assert_allclose(got, expect, rtol=1e-15)
    with pytest.raises(ValueError, match="B must be <= 0"):
        ac.perez(0.3, 0.5, A, 0.1, C, D, E)


def test_tiny_cosines_and_huge_B_do_not_warn():
    # RuntimeWarning is an error in this test suite: no overflow/divide warnings allowed.
    theta = np.arccos(np.array([1e-300, 5e-324, 1e-30, 0.0]))
    got = ac.perez(theta, 0.2, COEF[0], -1e6, *COEF[2:])
    assert np.all(np.isfinite(got))
    np.testing.assert_allclose(got, 1 + COEF[2] * math.exp(COEF[3] * 0.2) + COEF[4] * math.cos(0.2) ** 2)


def test_nan_propagates_elementwise():
    got = ac.perez(np.array([0.2, np.nan, 0.4]), np.array([0.1, 0.1, np.nan]), *COEF)
    assert np.isfinite(got[0]) and np.isnan(got[1]) and np.isnan(got[2])


def test_shapes_broadcast_and_float32():
    theta = np.linspace(0, 1.5, 4)[:, None]
    gamma = np.linspace(0, 3, 5)[None, :]
    got = ac.perez(theta, gamma, *COEF)
    assert got.shape == (4, 5)
    assert np.ndim(ac.perez(0.1, 0.2, *COEF)) == 0
    c32 = [np.float32(c) for c in COEF]
    got32 = ac.perez(theta.astype(np.float32), gamma.astype(np.float32), *c32)
    assert got32.dtype == np.float32
    np.testing.assert_allclose(got32, got, rtol=2e-6)
    # coefficient arrays broadcast too (one coefficient set per row)
    A = np.array([COEF[0], COEF[0] * 0.5])[:, None]
    assert ac.perez(0.5, gamma, A, *COEF[1:]).shape == (2, 5)


def test_bad_input_type():
    with pytest.raises(TypeError, match="theta"):
        ac.perez("north", 0.1, *COEF)

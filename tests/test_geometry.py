"""Tests for atmoscatter.geometry: ray–sphere roots against 50-digit decimal arithmetic."""

from __future__ import annotations

from decimal import Decimal, localcontext

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import atmoscatter as ac

R = 6.36e6  # Bruneton (2017) planet radius [m]
RT = 6.42e6  # Bruneton (2017) top of atmosphere [m]


def exact_roots(r, mu, radius):
    """Roots of t² + 2rμt + r² − R² = 0 in 50-digit decimal arithmetic.

    The float inputs are converted exactly (Decimal(float) is exact), so this is the true
    answer for the given floating-point inputs.  Returns None if the line misses the sphere.
    """
    with localcontext() as ctx:
        ctx.prec = 50
        r, mu, radius = Decimal(float(r)), Decimal(float(mu)), Decimal(float(radius))
        b = r * mu
        disc = b * b - (r * r - radius * radius)
        if disc < 0:
            return None
        s = disc.sqrt()
        # root pair without cancellation (so an exact zero root comes out as 0, not 1e-44)
        c = (r - radius) * (r + radius)
        q = -(b + s) if b >= 0 else -(b - s)
        if q == 0:
            return (-b - s, -b + s), disc
        t1, t2 = q, c / q
        return (min(t1, t2), max(t1, t2)), disc


def rel_err(x, exact):
    with localcontext() as ctx:
        ctx.prec = 50
        if exact == 0:
            return abs(float(x))
        return float(abs(Decimal(float(x)) - exact) / abs(exact))


ORIGINS = [R, R + 1.0, R + 12e3, RT, RT + 100e3]
COSINES = [1.0, 0.7, 0.2, 0.01, 1e-4, 0.0, -1e-4, -0.01, -0.05, -0.1, -0.2, -0.5, -1.0]


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
@pytest.mark.parametrize("radius", [R, RT])
def test_roots_against_exact_decimal(dtype, radius):
    eps = np.finfo(dtype).eps
    checked = 0
    for r in ORIGINS:
        for mu in COSINES:
            r_, mu_, rad_ = dtype(r), dtype(mu), dtype(radius)
            t_near, t_far = ac.ray_sphere_intersections(r_, mu_, rad_)
            assert t_near.dtype == dtype
            ref = exact_roots(r_, mu_, rad_)
            if ref is None:
                assert np.isnan(t_near) and np.isnan(t_far)
                continue
            (e_near, e_far), disc = ref
            scale = max(abs(e_near), abs(e_far))
            # away from a double root (grazing, treated below) each root is accurate to a
            # few ulp of itself — including the small root near an origin on the sphere
            if disc > Decimal(1e-3) * scale * scale:
                assert rel_err(t_near, e_near) <= 4 * eps, (r, mu)
                assert rel_err(t_far, e_far) <= 4 * eps, (r, mu)
            else:
                # grazing: a few ulp of the larger root (the double root is ill-conditioned)
                assert float(abs(Decimal(float(t_near)) - e_near)) <= 8 * eps * float(scale) + 1e-300
                assert float(abs(Decimal(float(t_far)) - e_far)) <= 8 * eps * float(scale) + 1e-300
            checked += 1
    assert checked > 30


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
def test_grazing_rays_to_the_ground(dtype):
    # rays from 12 km just steeper / shallower than the ground tangent
    r = dtype(R + 12e3)
    mu_t = -np.sqrt(1.0 - (R / float(r)) ** 2)
    eps = np.finfo(dtype).eps
    for d in (-1e-3, -1e-5, 1e-5, 1e-3):
        mu = dtype(mu_t + d)
        ref = exact_roots(r, mu, dtype(R))
        hits = bool(ac.ray_hits_ground(r, mu, dtype(R)))
        assert hits == (ref is not None)
        t_g = ac.distance_to_ground(r, mu, dtype(R))
        if ref is None:
            assert np.isinf(t_g)
        else:
            (e_near, _), _ = ref
            assert rel_err(t_g, e_near) <= 1e3 * eps  # near a double root: allow ~sqrt scaling
            assert t_g > 0


def test_naive_formula_would_fail_in_float32():
    # Observer 1 m above a 6360 km planet looking 5.7° below the horizon: the ground is
    # ~10 m away.  The textbook formula t = −rμ − sqrt(r²μ² − (r² − R²)) subtracts squares of
    # order 4e13 (float32 spacing there: 4e6 m²) and is off by ~1 %; the stable one is not.
    r, mu, rad = np.float32(R + 1.0), np.float32(-0.1), np.float32(R)
    (e_near, _), _ = exact_roots(r, mu, rad)
    b = r * mu
    naive = -b - np.sqrt(b * b - (r * r - rad * rad))
    assert rel_err(naive, e_near) > 1e-3
    stable = ac.distance_to_ground(r, mu, rad)
    assert stable.dtype == np.float32
    assert rel_err(stable, e_near) < 2e-7
    # same for the distance to the top of the atmosphere straight up from the ground
    r, mu, top = np.float32(R), np.float32(0.5), np.float32(RT)
    (_, e_far), _ = exact_roots(r, mu, top)
    b = r * mu
    naive = -b + np.sqrt(b * b - (r * r - top * top))
    assert rel_err(naive, e_far) > 1e-6
    assert rel_err(ac.distance_to_top(r, mu, top), e_far) < 2e-7


def test_origin_on_sphere_gives_exact_zero_root():
    # on the sphere looking down: roots 0 and −2rμ = 0.6 R (the chord)
    t_near, t_far = ac.ray_sphere_intersections(R, -0.3, R)
    assert t_near == 0.0
    assert t_far == pytest.approx(0.6 * R, rel=1e-15)
    # looking up: the other root is behind the origin
    t_near, t_far = ac.ray_sphere_intersections(R, 0.3, R)
    assert t_far == 0.0
    assert t_near == pytest.approx(-0.6 * R, rel=1e-15)
    assert float(ac.distance_to_ground(R, -0.3, R)) == 0.0


def test_miss_is_nan_and_vertical_rays():
    t_near, t_far = ac.ray_sphere_intersections(RT + 1e5, 0.0, RT)
    assert np.isnan(t_near) and np.isnan(t_far)
    t_near, t_far = ac.ray_sphere_intersections(R, 1.0, RT)
    assert t_far == pytest.approx(RT - R, rel=1e-15)
    assert t_near == pytest.approx(-(RT + R), rel=1e-15)


# ---------------------------------------------------------------------------------------
# semantics of the distance helpers
# ---------------------------------------------------------------------------------------


def test_distance_to_top_semantics():
    # inside: the positive root
    assert float(ac.distance_to_top(R, 1.0, RT)) == pytest.approx(RT - R, rel=1e-15)
    assert float(ac.distance_to_top(R + 1e4, -1.0, RT)) == pytest.approx(RT + R + 1e4, rel=1e-15)
    # on the top sphere looking up: 0; looking down: the chord 2·RT·|μ|
    assert float(ac.distance_to_top(RT, 1.0, RT)) == 0.0
    assert float(ac.distance_to_top(RT, -0.5, RT)) == pytest.approx(RT, rel=1e-14)
    # from space: entering → far intersection; missing or pointing away → 0
    r = RT + 1e5
    assert float(ac.distance_to_top(r, -1.0, RT)) == pytest.approx(1e5 + 2 * RT, rel=1e-15)
    assert float(ac.distance_to_top(r, 1.0, RT)) == 0.0
    assert float(ac.distance_to_top(r, 0.0, RT)) == 0.0
    assert np.all(np.isfinite(ac.distance_to_top(r, np.linspace(-1, 1, 101), RT)))


def test_distance_to_entry_semantics():
    assert float(ac.distance_to_entry(R + 10.0, 0.3, RT)) == 0.0  # inside
    r = RT + 1e5
    assert float(ac.distance_to_entry(r, -1.0, RT)) == pytest.approx(1e5, rel=1e-12)
    assert float(ac.distance_to_entry(r, 0.0, RT)) == 0.0  # misses
    assert float(ac.distance_to_entry(r, 1.0, RT)) == 0.0  # pointing away


def test_distance_to_ground_and_hits():
    assert float(ac.distance_to_ground(R + 1000.0, -1.0, R)) == pytest.approx(1000.0, rel=1e-15)
    assert np.isinf(ac.distance_to_ground(R + 1000.0, 0.0, R))
    assert np.isinf(ac.distance_to_ground(R + 1000.0, 1.0, R))
    # from the ground: the horizontal (horizon) ray does not hit (documented); any
    # downward ray does
    assert not bool(ac.ray_hits_ground(R, 0.0, R))
    assert np.isinf(ac.distance_to_ground(R, 0.0, R))
    assert bool(ac.ray_hits_ground(5.0, 0.0, 5.0)) is False  # any size: horizon ray
    assert not bool(ac.ray_hits_ground(R, 1e-9, R))
    assert bool(ac.ray_hits_ground(R, -1e-9, R))
    # from space: a downward ray can miss the planet
    assert not bool(ac.ray_hits_ground(RT, -0.1, R))
    assert bool(ac.ray_hits_ground(RT, -0.5, R))
    # chord geometry: from altitude h looking down at μ, exact near root
    h, mu = 12e3, -0.2
    r = R + h
    expected = -r * mu - np.sqrt((r * mu) ** 2 - (r - R) * (r + R))
    assert float(ac.distance_to_ground(r, mu, R)) == pytest.approx(expected, rel=1e-12)


def test_impact_parameter():
    assert float(ac.impact_parameter(R, 0.0)) == R
    assert float(ac.impact_parameter(R, 1.0)) == 0.0
    assert float(ac.impact_parameter(R, 0.6)) == pytest.approx(0.8 * R, rel=1e-15)
    # accuracy for near-vertical rays: sqrt((1−μ)(1+μ)) vs the exact value
    mu = 1.0 - 1e-12
    assert float(ac.impact_parameter(1.0, mu)) == pytest.approx(np.sqrt(2e-12 - 1e-24), rel=1e-4)


def test_altitude_along_ray_against_decimal():
    with localcontext() as ctx:
        ctx.prec = 50
        for r, mu, t in [(R, 0.0, 1e5), (R + 12e3, -0.3, 2e4), (R, 1.0, 6e4), (RT, -0.99, 1.2e5)]:
            h, mu_t = ac.altitude_along_ray(r, mu, t, R)
            rd, md, td = Decimal(r), Decimal(mu), Decimal(t)
            rt = (rd * rd + 2 * rd * md * td + td * td).sqrt()
            assert float(h) == pytest.approx(float(rt - Decimal(R)), rel=1e-9, abs=1e-6)
            assert float(mu_t) == pytest.approx(float((rd * md + td) / rt), abs=1e-15)
    # returning to the origin's altitude at t = −2rμ
    h, mu_t = ac.altitude_along_ray(R + 5e3, 0.4, -2 * (R + 5e3) * 0.4, R)
    assert float(h) == pytest.approx(5e3, abs=1e-6)
    assert float(mu_t) == pytest.approx(-0.4, abs=1e-12)


def test_broadcasting_shapes_and_nan():
    r = np.full((4, 1), R + 100.0)
    mu = np.linspace(-1, 1, 5)
    tn, tf = ac.ray_sphere_intersections(r, mu, RT)
    assert tn.shape == tf.shape == (4, 5)
    assert ac.distance_to_top(r, mu, RT).shape == (4, 5)
    assert ac.distance_to_ground(r, mu, R).shape == (4, 5)
    assert ac.distance_to_entry(r, mu, RT).shape == (4, 5)
    assert ac.ray_hits_ground(r, mu, R).shape == (4, 5)
    h, m = ac.altitude_along_ray(r, mu, np.array([[0.0], [1.0], [10.0], [100.0]]), R)
    assert h.shape == m.shape == (4, 5)
    # NaN in → NaN out for that element only (no warnings: pytest treats them as errors)
    tn, tf = ac.ray_sphere_intersections(np.array([R, R]), np.array([np.nan, 0.5]), RT)
    assert np.isnan(tf[0]) and np.isfinite(tf[1])
    h, _ = ac.altitude_along_ray(R, np.array([np.nan, 0.5]), 10.0, R)
    assert np.isnan(h[0]) and np.isfinite(h[1])


def test_cosine_rounding_is_clamped():
    tn, tf = ac.ray_sphere_intersections(R, 1.0 + 1e-12, RT)
    assert float(tf) == pytest.approx(RT - R, rel=1e-15)
    h, m = ac.altitude_along_ray(R, -1.0 - 1e-12, 100.0, R)
    assert np.isfinite(h) and np.isfinite(m)


@settings(max_examples=200, deadline=None)
@given(
    h=st.floats(min_value=0.0, max_value=2e5),
    mu=st.floats(min_value=-1.0, max_value=1.0),
)
def test_property_exit_point_lies_on_the_top_sphere(h, mu):
    # stability: walking distance_to_top along the ray lands on the top sphere (inside
    # observers), to float64 rounding of the radius
    r = R + h
    t = ac.distance_to_top(r, mu, RT)
    assert np.isfinite(t) and t >= 0
    if r <= RT:
        hh, _ = ac.altitude_along_ray(r, mu, t, R)
        assert float(hh) == pytest.approx(RT - R, abs=1e-6)
    tg = ac.distance_to_ground(r, mu, R)
    if np.isfinite(tg):
        hg, _ = ac.altitude_along_ray(r, mu, tg, R)
        assert abs(float(hg)) < 1e-4

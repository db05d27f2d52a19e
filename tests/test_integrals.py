"""Tests for atmoscatter.integrals: sky irradiance/illuminance and real spherical harmonics.

Reference values are analytic (uniform sky: πL; CIE overcast sky, CIE S 011/E:2003:
E_h = 7πL_z/9; clamped-cosine SH factors of Ramamoorthi & Hanrahan 2001) or independent
computations inside the tests (scipy.special.sph_harm_y, scipy.integrate.dblquad/quad).
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy import integrate, special

import atmoscatter as ac
from atmoscatter.integrals import (
    clamped_cosine_sh_coefficients,
    diffuse_irradiance,
    direct_irradiance,
    direct_normal_irradiance,
    latlong_quadrature,
    real_sph_harm,
    sh_count,
    sh_evaluate,
    sh_index,
    sh_irradiance,
    sh_project,
    sphere_quadrature,
)


def _dir(theta, phi):
    """Unit vector from zenith angle θ and mathematical azimuth φ (from +x toward +y)."""
    return np.stack(
        [np.sin(theta) * np.cos(phi), np.sin(theta) * np.sin(phi), np.cos(theta)], axis=-1
    )


def _real_from_scipy(l, m, theta, phi, *, condon_shortley=False):  # noqa: E741
    """Independent real SH from scipy's complex sph_harm_y (which has the CS phase)."""
    z = special.sph_harm_y(l, abs(m), theta, phi)
    s = 1.0 if condon_shortley else (-1.0) ** m
    if m == 0:
        return z.real
    if m > 0:
        return np.sqrt(2.0) * s * z.real
    return np.sqrt(2.0) * s * z.imag


# --------------------------------------------------------------------------------------
# quadrature
# --------------------------------------------------------------------------------------
class TestQuadrature:
    @pytest.mark.parametrize("domain,total", [("sphere", 4 * np.pi), ("upper", 2 * np.pi),
                                              ("lower", 2 * np.pi)])
    def test_weights_sum_to_solid_angle(self, domain, total):
        d, w = sphere_quadrature(7, 9, domain=domain)
        assert d.shape == (w.size, 3)
        assert w.sum() == pytest.approx(total, rel=1e-14)
        np.testing.assert_allclose(np.linalg.norm(d, axis=-1), 1.0, rtol=1e-15)
        if domain == "upper":
            assert np.all(d[:, 2] > 0)
        if domain == "lower":
            assert np.all(d[:, 2] < 0)

    def test_latlong_solid_angles_and_layout(self):
        d, om = latlong_quadrature(16, 8)
        assert d.shape == (8, 16, 3) and om.shape == (8, 16)
        assert om.sum() == pytest.approx(4 * np.pi, rel=1e-14)
        # row 0 near the zenith, last row near the nadir; OpenEXR lat-long columns:
        # geographic azimuth 2π(c + ½)/W − π (south at the edges, north in the centre)
        assert d[0, 0, 2] > 0.98 and d[-1, 0, 2] < -0.98
        mid = latlong_quadrature(4, 2)[0]
        np.testing.assert_allclose(np.arctan2(mid[0, :, 0], mid[0, :, 1]),
                                   [-3 * np.pi / 4, -np.pi / 4, np.pi / 4, 3 * np.pi / 4])
        # elevation of row r: π/2 − π(r + ½)/H
        np.testing.assert_allclose(np.arcsin(d[:, 0, 2]), np.pi / 2 - np.pi * (np.arange(8) + 0.5) / 8)

    def test_bad_resolution(self):
        with pytest.raises(ValueError, match="n_theta"):
            sphere_quadrature(0)
        with pytest.raises(TypeError, match="n_phi"):
            sphere_quadrature(4, 2.5)
        with pytest.raises(ValueError, match="domain"):
            sphere_quadrature(4, domain="north")


# --------------------------------------------------------------------------------------
# irradiance / illuminance
# --------------------------------------------------------------------------------------
class TestDiffuseIrradiance:
    @pytest.mark.parametrize("L", [1.0, 5000.0])
    def test_uniform_sky_gives_pi_L(self, L):
        e = diffuse_irradiance(lambda d: np.full(len(d), L))
        assert e == pytest.approx(np.pi * L, rel=1e-13)

    def test_cie_overcast_ratio_exact(self):
        # CIE overcast: L(θ) = L_z (1 + 2 cos θ)/3  ⇒  E_h = 7π L_z / 9 (analytic)
        Lz = 3000.0
        e = diffuse_irradiance(lambda d: Lz * (1 + 2 * d[:, 2]) / 3, n_theta=4)
        assert e == pytest.approx(7 * np.pi * Lz / 9, rel=1e-14)

    def test_channels_on_last_axis(self):
        e = diffuse_irradiance(lambda d: np.stack([np.ones(len(d)), 2 + 0 * d[:, 2],
                                                   (1 + 2 * d[:, 2]) / 3], axis=-1))
        np.testing.assert_allclose(e, [np.pi, 2 * np.pi, 7 * np.pi / 9], rtol=1e-13)

    def test_ground_is_not_a_source_unless_asked(self):
        def sky(d):  # bright ground, dark sky
            return np.where(d[:, 2] < 0, 1.0, 0.0)

        assert diffuse_irradiance(sky) == 0.0
        up = diffuse_irradiance(lambda d: np.ones(len(d)), normal=(0, 0, -1), domain="sphere")
        assert up == pytest.approx(np.pi, rel=1e-13)

    def test_vertical_plane_uniform_sky(self):
        # a vertical plane sees half of the sky dome: E = πL/2 (by symmetry); the rule is
        # cut at the horizon, so only the documented ~1e-3 accuracy is claimed
        e = diffuse_irradiance(lambda d: np.ones(len(d)), normal=(1.0, 0.0, 0.0))
        assert e == pytest.approx(np.pi / 2, rel=1e-3)
        # whole sphere, tilted normal: exact
        e = diffuse_irradiance(lambda d: 1 + d @ np.array([0.3, -0.2, 0.5]),
                               normal=(1.0, 2.0, 2.0), domain="sphere")
        n = np.array([1.0, 2.0, 2.0]) / 3.0
        # ∫ (1 + a·ω) max(n·ω,0) dΩ = π + (2π/3) a·n
        assert e == pytest.approx(np.pi + 2 * np.pi / 3 * (n @ [0.3, -0.2, 0.5]), rel=1e-13)

    def test_sampled_values_on_latlong_map(self):
        d, om = latlong_quadrature(64, 256)
        L = 1000 * (1 + 2 * d[..., 2]) / 3
        e = diffuse_irradiance(L, directions=d, weights=om)
        # midpoint rule in θ: second-order accurate
        assert e == pytest.approx(7 * np.pi * 1000 / 9, rel=1e-4)
        rgb = np.stack([L, 2 * L], axis=-1).astype(np.float32)
        e2 = diffuse_irradiance(rgb, directions=d, weights=om)
        assert e2.shape == (2,) and e2.dtype == np.float64
        np.testing.assert_allclose(e2, [e, 2 * e], rtol=1e-6)

    def test_nan_propagates(self):
        d, w = sphere_quadrature(4)
        v = np.ones(len(d))
        v[np.argmax(d[:, 2])] = np.nan
        assert np.isnan(diffuse_irradiance(v, directions=d, weights=w))

    def test_bad_input(self):
        d, w = sphere_quadrature(4)
        with pytest.raises(ValueError, match="directions"):
            diffuse_irradiance(np.ones(len(d)))
        with pytest.raises(ValueError, match="weights"):
            diffuse_irradiance(np.ones(len(d)), directions=d, weights=w[:-1])
        with pytest.raises(ValueError, match="sky values"):
            diffuse_irradiance(np.ones(len(d) + 1), directions=d, weights=w)
        with pytest.raises(ValueError, match="domain"):
            diffuse_irradiance(lambda x: np.ones(len(x)), domain="lower")
        with pytest.raises(ValueError, match="normal"):
            diffuse_irradiance(lambda x: np.ones(len(x)), normal=(0, 0, 0))
        with pytest.raises(ValueError, match="sky\\(directions\\)"):
            diffuse_irradiance(lambda x: np.ones(3))
        with pytest.raises(ValueError, match="callable"):
            diffuse_irradiance(lambda x: np.ones(len(x)), directions=d, weights=w)


class TestDirect:
    def test_cosine_and_horizon(self):
        s = np.array([[0, 0, 1], [0, np.sqrt(0.5), np.sqrt(0.5)], [0, 1, -1e-3]])
        e = direct_irradiance(1000.0, s)
        np.testing.assert_allclose(e, [1000.0, 1000 * np.sqrt(0.5), 0.0], rtol=1e-14)
        # a plane facing the low sun still gets nothing once the sun has set
        assert direct_irradiance(1000.0, [0, 1, -0.01], normal=(0, 1, 0)) == 0.0
        assert direct_irradiance(1000.0, [0, 1, 0.2], normal=(0, 1, 0)) == pytest.approx(
            1000 / np.sqrt(1.04), rel=1e-14)

    def test_channels(self):
        e = direct_irradiance([1.0, 2.0, 3.0], [0, 0.6, 0.8])
        np.testing.assert_allclose(e, [0.8, 1.6, 2.4], rtol=1e-14)
        e = direct_irradiance(np.ones((2, 3)), [[0, 0, 1], [0, 0.6, 0.8]])
        np.testing.assert_allclose(e, [[1, 1, 1], [0.8, 0.8, 0.8]], rtol=1e-14)

    def test_direct_normal_beer_lambert_against_quad(self):
        # one absorbing-and-scattering constituent with an exponential profile; the optical
        # length is computed here independently by adaptive quadrature along the slant ray
        R, top, H, beta = 6.36e6, 6.42e6, 8000.0, 1.2e-5
        atm = ac.Atmosphere(
            planet_radius=R, top_radius=top, wavelengths=(550.0,),
            constituents=(ac.Constituent("air", (beta,), (0.0,), ac.ExponentialProfile(H),
                                         ac.RayleighPhase()),),
        )
        mu = 0.3
        s = np.array([0.0, np.sqrt(1 - mu**2), mu])
        t_top = -R * mu + np.sqrt((R * mu) ** 2 + top**2 - R**2)

        def rho(t):
            h = np.sqrt(R**2 + t**2 + 2 * R * t * mu) - R
            return np.exp(-h / H)

        ell, _ = integrate.quad(rho, 0.0, t_top, epsabs=0, epsrel=1e-12, limit=200)
        e0 = ac.extraterrestrial_irradiance(550.0)
        got = direct_normal_irradiance(atm, s)
        assert got.shape == (1,)
        assert got[0] == pytest.approx(e0 * np.exp(-beta * ell), rel=1e-9)
        # below the horizon the planet blocks the sun
        assert direct_normal_irradiance(atm, [0, 0.99, -0.1])[0] == 0.0
        # vectorised over sun directions
        assert direct_normal_irradiance(atm, np.stack([s, s])).shape == (2, 1)


# --------------------------------------------------------------------------------------
# spherical harmonics
# --------------------------------------------------------------------------------------
class TestBasis:
    def test_counts_and_indices(self):
        assert sh_count(4) == 25 and sh_count(0) == 1
        assert sh_index(0, 0) == 0 and sh_index(1, -1) == 1 and sh_index(4, 4) == 24
        with pytest.raises(ValueError, match="sh_index"):
            sh_index(2, 3)
        with pytest.raises(ValueError, match="order"):
            sh_count(-1)

    @pytest.mark.parametrize("cs", [False, True])
    def test_against_scipy_complex_harmonics(self, cs):
        rng = np.random.default_rng(1)
        th, ph = np.arccos(rng.uniform(-1, 1, 200)), rng.uniform(-np.pi, np.pi, 200)
        th[:2] = [0.0, np.pi]  # poles
        Y = real_sph_harm(12, _dir(th, ph), condon_shortley=cs)
        for l in range(13):  # noqa: E741
            for m in range(-l, l + 1):
                np.testing.assert_allclose(Y[:, sh_index(l, m)],
                                           _real_from_scipy(l, m, th, ph, condon_shortley=cs),
                                           rtol=0, atol=1e-12)

    def test_cartesian_forms_and_cs_sign(self):
        d = np.array([[0.48, 0.6, 0.64]])
        c = np.sqrt(3 / (4 * np.pi))
        np.testing.assert_allclose(real_sph_harm(1, d)[0],
                                   [0.5 / np.sqrt(np.pi), c * 0.6, c * 0.64, c * 0.48])
        np.testing.assert_allclose(real_sph_harm(1, d, condon_shortley=True)[0],
                                   [0.5 / np.sqrt(np.pi), -c * 0.6, c * 0.64, -c * 0.48])

    def test_orthonormal_under_quadrature(self):
        d, w = sphere_quadrature(9, 17)
        Y = real_sph_harm(8, d)
        np.testing.assert_allclose((Y * w[:, None]).T @ Y, np.eye(81), atol=1e-13)

    def test_shapes_and_bad_input(self):
        assert real_sph_harm(2, np.zeros((4, 5, 3)) + [0, 0, 1]).shape == (4, 5, 9)
        assert real_sph_harm(0, [0, 0, 1]).shape == (1,)
        with pytest.raises(ValueError, match="directions"):
            real_sph_harm(2, np.ones((4, 2)))
        with pytest.raises(ValueError, match="order"):
            real_sph_harm(41, [0, 0, 1])
        with pytest.raises(TypeError, match="order"):
            real_sph_harm(2.0, [0, 0, 1])


class TestProjection:
    def test_constant(self):
        c = sh_project(lambda d: np.full(len(d), 7.0), order=4)
        expect = np.zeros(25)
        expect[0] = 7.0 * 4 * np.pi / (2 * np.sqrt(np.pi))  # 7 · 4π · Y_00
        np.testing.assert_allclose(c, expect, rtol=0, atol=1e-10)

    def test_cos_theta(self):
        c = sh_project(lambda d: d[:, 2], order=4)
        expect = np.zeros(25)
        expect[sh_index(1, 0)] = np.sqrt(4 * np.pi / 3)  # cos θ = √(4π/3) Y_10
        np.testing.assert_allclose(c, expect, rtol=0, atol=1e-10)

    @pytest.mark.parametrize("lm", [(0, 0), (1, -1), (2, 1), (3, -3), (4, 2), (4, -4), (6, 5)])
    def test_single_harmonic_recovered(self, lm):
        l, m = lm  # noqa: E741
        i = sh_index(l, m)
        c = sh_project(lambda d: real_sph_harm(l, d)[:, i], order=6, n_theta=8)
        expect = np.zeros(49)
        expect[i] = 1.0
        np.testing.assert_allclose(c, expect, rtol=0, atol=1e-10)

    def test_roundtrip_band_limited_with_channels(self):
        rng = np.random.default_rng(7)
        coef = rng.normal(size=(25, 3))

        def sky(d):
            return sh_evaluate(coef, d)

        got = sh_project(sky, order=4, n_theta=5)
        np.testing.assert_allclose(got, coef, rtol=0, atol=1e-12)
        probe = _dir(rng.uniform(0, np.pi, 50), rng.uniform(0, 2 * np.pi, 50))
        np.testing.assert_allclose(sh_evaluate(got, probe), sky(probe), atol=1e-12)

    def test_smooth_sky_against_dense_numerical_integration(self):
        # a smooth, non-band-limited "sky": gradient + circumsolar lobe, zero below horizon;
        # reference coefficients by adaptive 2-D quadrature (scipy.integrate.dblquad)
        s = np.array([0.3, -0.5, np.sqrt(1 - 0.34)])

        def sky(d):
            return (1 + 2 * d[..., 2]) / 3 + 0.5 * np.exp(4 * (d @ s - 1))

        c = sh_project(sky, order=4, domain="upper")
        for l, m in [(0, 0), (1, 0), (1, 1), (2, -2), (3, 1), (4, 0), (4, -3)]:  # noqa: E741
            i = sh_index(l, m)

            def f(phi, theta, i=i, l=l):  # noqa: E741
                d = _dir(np.array([theta]), np.array([phi]))
                return float(sky(d)[0] * real_sph_harm(l, d)[0, i] * np.sin(theta))

            ref, _ = integrate.dblquad(f, 0, np.pi / 2, 0, 2 * np.pi, epsabs=1e-12,
                                       epsrel=1e-11)
            assert c[i] == pytest.approx(ref, abs=1e-9)

    def test_sampled_values_projection_matches_callable(self):
        d, w = sphere_quadrature(10)

        def sky(x):
            return 1 + x[..., 0] * x[..., 2]

        np.testing.assert_allclose(sh_project(sky(d), 4, directions=d, weights=w),
                                   sh_project(sky, 4), atol=1e-12)
        # "upper" on sampled values drops the lower hemisphere
        up = sh_project(np.ones(len(d)), 0, directions=d, weights=w, domain="upper")
        assert up[0] == pytest.approx(2 * np.pi / (2 * np.sqrt(np.pi)), rel=1e-13)

    def test_bad_input(self):
        with pytest.raises(ValueError, match="coefficients"):
            sh_evaluate(np.ones(24), [0, 0, 1])
        with pytest.raises(ValueError, match="domain"):
            sh_project(lambda d: np.ones(len(d)), domain="lower")
        with pytest.raises(ValueError, match="directions"):
            sh_project(np.ones(10), 2)


class TestSHIrradiance:
    def test_clamped_cosine_factors(self):
        # Ramamoorthi & Hanrahan 2001: π, 2π/3, π/4, 0, −π/24; and an independent quad:
        # Â_l = 2π ∫_0^1 μ P_l(μ) dμ
        a = clamped_cosine_sh_coefficients(8)
        np.testing.assert_allclose(a[:5], [np.pi, 2 * np.pi / 3, np.pi / 4, 0, -np.pi / 24],
                                   atol=1e-15)
        for deg in range(9):
            ref = 2 * np.pi * integrate.quad(lambda x, k=deg: x * special.eval_legendre(k, x),
                                             0, 1, epsabs=1e-14)[0]
            assert a[deg] == pytest.approx(ref, abs=1e-12)

    def test_exact_for_band_limited_radiance(self):
        rng = np.random.default_rng(3)
        coef = rng.normal(size=25)
        coef[0] = 10.0
        for n in ([0, 0, 1], [0.6, 0, 0.8], [0, -1, 0], [0.2, 0.3, -0.9]):
            ref = diffuse_irradiance(lambda d: sh_evaluate(coef, d), normal=n, domain="sphere",
                                     n_theta=8)
            assert sh_irradiance(coef, n) == pytest.approx(ref, rel=1e-12)

    def test_overcast_sky_truncation_converges(self):
        # (1 + 2 cos θ)/3 above the horizon, 0 below is not band-limited (horizon step):
        # the SH irradiance converges to the exact 7π/9 as the order grows
        def sky(d):
            return (1 + 2 * d[:, 2]) / 3

        errs = [abs(float(sh_irradiance(sh_project(sky, o, domain="upper"), [0, 0, 1]))
                    / (7 * np.pi / 9) - 1) for o in (2, 4, 8)]
        assert errs[0] < 1e-2 and errs[1] < 2e-3 and errs[2] < 5e-4
        assert errs[0] > errs[1] > errs[2]


def test_rendered_sky_image_is_accepted():
    # a rendered lat-long map (pixel solid angles, midpoint rule) against the Gauss–Legendre
    # integral of the same model as a callable
    pytest.importorskip("atmoscatter.render")
    sun = np.array([0.0, -np.cos(np.radians(50)), np.sin(np.radians(50))])
    img = ac.render(ac.Scene(model="preetham", turbidity=3.0, sun_elevation_deg=50.0,
                             sun_azimuth_deg=180.0, projection="latlong", width=256,
                             height=128))
    exact = diffuse_irradiance(lambda d: ac.preetham_sky(d, sun, 3.0)[..., 1], n_theta=96)
    assert diffuse_irradiance(img) == pytest.approx(exact, rel=1e-3)  # measured 7e-5
    c_img = sh_project(img, 2, domain="upper")
    c_ref = sh_project(lambda d: ac.preetham_sky(d, sun, 3.0)[..., 1], 2, domain="upper",
                       n_theta=96)
    np.testing.assert_allclose(c_img, c_ref, rtol=0, atol=1e-2 * abs(c_ref[0]))
    with pytest.raises(ValueError, match="SkyImage"):
        diffuse_irradiance(img, directions=np.zeros((1, 3)), weights=np.ones(1))

"""The 15 CIE standard general skies (atmoscatter.sky.cie_standard).

Reference values
----------------
* Table 1 of ISO 15469:2004 / CIE S 011/E:2003 (as reproduced in Darula & Kittler 2002,
  "CIE general sky standard defining luminance distributions", Proc. eSim 2002), typed here a
  second time, independently of the package data file.
* Closed forms of the standard's formulas: type 5 is the sky of uniform luminance
  (``L/L_z = 1``, ``D_v/L_z = π``); types 1 and 3 are rotationally symmetric
  (``D_v/L_z = 2π ∫ φ(Z)/φ(0) cos Z sin Z dZ``, computed here with scipy's adaptive ``quad``).
* Type 12 is the CIE (1973) clear sky: :func:`atmoscatter.cie_clear_sky_luminance`, which
  uses the constant 0.91 where the standard's formula has 1 − 10 e^{−3π/2} = 0.91017.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import atmoscatter as ac
from atmoscatter.sky import _hemisphere
from atmoscatter.sky import cie_standard as cs

# ISO 15469:2004 / CIE S 011/E:2003 Table 1: type -> (a, b, c, d, e)
CIE_S011_TABLE1 = {
    1: (4.0, -0.70, 0, -1.0, 0.00), 2: (4.0, -0.70, 2, -1.5, 0.15),
    3: (1.1, -0.80, 0, -1.0, 0.00), 4: (1.1, -0.80, 2, -1.5, 0.15),
    5: (0.0, -1.00, 0, -1.0, 0.00), 6: (0.0, -1.00, 2, -1.5, 0.15),
    7: (0.0, -1.00, 5, -2.5, 0.30), 8: (0.0, -1.00, 10, -3.0, 0.45),
    9: (-1.0, -0.55, 2, -1.5, 0.15), 10: (-1.0, -0.55, 5, -2.5, 0.30),
    11: (-1.0, -0.55, 10, -3.0, 0.45), 12: (-1.0, -0.32, 10, -3.0, 0.45),
    13: (-1.0, -0.32, 16, -3.0, 0.30), 14: (-1.0, -0.15, 16, -3.0, 0.30),
    15: (-1.0, -0.15, 24, -2.8, 0.15),
}
GRADATION_GROUPS = {"I": (1, 2), "II": (3, 4), "III": (5, 6, 7, 8), "IV": (9, 10, 11),
                    "V": (12, 13), "VI": (14, 15)}

SUN_ZENITHS = np.radians([0.0, 20.0, 45.0, 70.0, 89.0, 90.0])


class TestTable:
    def test_parameters_equal_cie_s011_table1(self):
        for t, ref in CIE_S011_TABLE1.items():
            assert cs.cie_standard_sky_parameters(t) == pytest.approx(ref, abs=0)

    def test_groups(self):
        for group, types in GRADATION_GROUPS.items():
            for t in types:
                assert cs.CIE_STANDARD_SKY_TYPES[t]["gradation_group"] == group
        assert len(cs.CIE_STANDARD_SKY_TYPES) == 15
        assert "uniform" in cs.CIE_STANDARD_SKY_TYPES[5]["description"]

    def test_array_of_types(self):
        a, b, c, d, e = cs.cie_standard_sky_parameters(np.array([[1, 15], [12, 5]]))
        assert a.shape == (2, 2) and c[0, 1] == 24 and b[1, 0] == -0.32

    @pytest.mark.parametrize("bad", [0, 16, 2.5, -1, np.nan])
    def test_bad_type(self, bad):
        with pytest.raises(ValueError, match=r"cie_type must be an integer in \[1, 15\]"):
            cs.cie_standard_sky_parameters(bad)

    def test_type_not_a_number(self):
        with pytest.raises(TypeError, match="cie_type"):
            cs.cie_standard_sky_parameters("12")


class TestRelativeLuminance:
    @pytest.mark.parametrize("t", range(1, 16))
    def test_zenith_is_one(self, t):
        # at the zenith Z = 0 and γ = Z_s: the formula gives exactly f(Z_s)φ(0)/(f(Z_s)φ(0))
        r = cs.cie_standard_relative_luminance(0.0, SUN_ZENITHS, SUN_ZENITHS, t)
        np.testing.assert_allclose(r, 1.0, rtol=1e-14)

    def test_uniform_sky_type5(self):
        z = np.linspace(0, np.pi / 2, 7)[:, None]
        g = np.linspace(0, np.pi, 5)[None, :]
        np.testing.assert_allclose(cs.cie_standard_relative_luminance(z, g, 0.7, 5), 1.0,
                                   rtol=1e-15)
        assert cs.cie_standard_diffuse_ratio(0.7, 5) == pytest.approx(math.pi, rel=1e-12)

    def test_formula_by_hand(self):
        # type 7 (a=0, b=-1, c=5, d=-2.5, e=0.3), Z = 50°, γ = 30°, Z_s = 40°
        Z, g, zs = np.radians([50.0, 30.0, 40.0])

        def f(x):
            return 1 + 5 * (math.exp(-2.5 * x) - math.exp(-2.5 * math.pi / 2)) + 0.3 * math.cos(x) ** 2

        expected = f(g) * 1.0 / (f(zs) * 1.0)
        assert cs.cie_standard_relative_luminance(Z, g, zs, 7) == pytest.approx(expected, rel=1e-14)
        # type 13 (a=-1, b=-0.32, c=16, d=-3, e=0.3)
        phi = (1 - math.exp(-0.32 / math.cos(Z))) / (1 - math.exp(-0.32))

        def f13(x):
            return 1 + 16 * (math.exp(-3 * x) - math.exp(-3 * math.pi / 2)) + 0.3 * math.cos(x) ** 2

        assert cs.cie_standard_relative_luminance(Z, g, zs, 13) == pytest.approx(
            f13(g) * phi / f13(zs), rel=1e-14)

    def test_type1_horizon_ratio(self):
        # φ(90°)/φ(0) = 1/(1 + 4 e^{-0.7}) for type 1, independent of the sun (c = e = 0)
        r = cs.cie_standard_relative_luminance(np.pi / 2, np.linspace(0, 3, 4), 0.3, 1)
        np.testing.assert_allclose(r, 1 / (1 + 4 * math.exp(-0.7)), rtol=1e-14)

    def test_type12_is_the_cie_clear_sky(self):
        # same formulas; cie_clear_sky uses 0.91 for 1 - 10 exp(-3π/2) = 0.910167; the ratio
        # f(γ)/f(Z_s) then differs by at most 2 * 1.7e-4 / min f (min f > 0.9): < 4e-4
        z = np.radians(np.linspace(0, 89.9, 40))[:, None, None]
        g = np.radians(np.linspace(0, 180, 37))[None, :, None]
        zs = SUN_ZENITHS[None, None, :5]
        ours = cs.cie_standard_relative_luminance(z, g, zs, 12)
        clear = ac.cie_clear_sky_luminance(z, g, zs, 1.0)
        np.testing.assert_allclose(ours, clear, rtol=4e-4)
        assert np.max(np.abs(ours / clear - 1)) > 1e-5  # they are not the same constant

    def test_moon_spencer_overcast_is_not_type1(self):
        # the traditional overcast sky (1 + 2 cos Z)/3 stays separate: it differs from type 1
        z = np.radians(np.linspace(0, 90, 91))
        t1 = cs.cie_standard_relative_luminance(z, 0.5, 0.5, 1)
        ms = ac.cie_overcast_luminance(z, 1.0)
        assert np.max(np.abs(t1 / ms - 1)) > 0.05
        assert {"cie_overcast", "cie_standard"} <= set(ac.MODELS)

    def test_below_horizon_views_take_horizon_value(self):
        r = cs.cie_standard_relative_luminance(np.radians([90.0, 100.0, 180.0]), 1.0, 0.5, 12)
        np.testing.assert_allclose(r, r[0], rtol=0)
        near = cs.cie_standard_relative_luminance(np.radians(89.999), 1.0, 0.5, 12)
        assert near == pytest.approx(r[0], rel=1e-4)

    def test_sun_below_horizon_is_dark(self):
        assert cs.cie_standard_relative_luminance(0.3, 1.0, np.radians(95), 12) == 0.0

    def test_broadcast_and_scalar(self):
        out = cs.cie_standard_relative_luminance(np.zeros((3, 1)), np.ones((1, 4)), 0.5,
                                                 np.array([1, 5, 12, 15]))
        assert out.shape == (3, 4)
        assert isinstance(cs.cie_standard_relative_luminance(0.1, 0.2, 0.3, 9), float)

    def test_bad_sun(self):
        with pytest.raises(ValueError, match=r"sun_zenith must be in \[0, pi\] rad"):
            cs.cie_standard_relative_luminance(0.1, 0.2, -0.1, 9)


class TestDiffuseRatio:
    @pytest.mark.parametrize("t", [1, 3])
    def test_rotationally_symmetric_types_against_quad(self, t):
        from scipy.integrate import quad

        a, b, *_ = CIE_S011_TABLE1[t]
        phi0 = 1 + a * math.exp(b)
        ref, _ = quad(lambda z: (1 + a * math.exp(b / math.cos(z))) / phi0 * math.cos(z)
                      * math.sin(z), 0, math.pi / 2, epsabs=0, epsrel=1e-13)
        ref *= 2 * math.pi
        np.testing.assert_allclose(cs.cie_standard_diffuse_ratio(SUN_ZENITHS[:5], t), ref,
                                   rtol=1e-10)

    @pytest.mark.parametrize("t", range(1, 16))
    def test_converged(self, t):
        # the default rule against one with 4x the nodes in each direction (whose own error,
        # from the 2x-refinement sequence, is < 1e-11)
        zs = np.radians([0.0, 10.0, 35.0, 60.0, 80.0, 88.0, 90.0])
        params = cs.cie_standard_sky_parameters(np.full(zs.shape, t))
        fine = _hemisphere.horizontal_integral(cs._relative, zs, params, n_mu=192, n_phi=384)
        np.testing.assert_allclose(cs.cie_standard_diffuse_ratio(zs, t), fine, rtol=1e-8)

    def test_against_independent_sphere_quadrature(self):
        # atmoscatter.diffuse_irradiance: Gauss in cos θ x uniform φ, not split at the sun
        # (kink at the sun): agreement to its own accuracy, 1e-4
        for t, elev in ((2, 30.0), (12, 45.0), (15, 15.0)):
            zs = math.radians(90 - elev)
            sun = np.array([math.sin(zs), 0.0, math.cos(zs)])
            e = ac.diffuse_irradiance(lambda v, t=t, sun=sun: cs.cie_standard_sky(
                v, sun, t, zenith_luminance=1.0), n_theta=256)
            assert e == pytest.approx(cs.cie_standard_diffuse_ratio(zs, t), rel=1e-4)

    def test_sun_below_horizon_raises(self):
        with pytest.raises(ValueError, match="sun above the horizon"):
            cs.cie_standard_diffuse_ratio(np.radians(91), 3)


class TestAbsolute:
    def test_zenith_luminance_scaling(self):
        lum = cs.cie_standard_luminance(0.0, 0.6, 0.6, 11, zenith_luminance=5000.0)
        assert lum == pytest.approx(5000.0, rel=1e-14)

    def test_illuminance_scaling_round_trip(self):
        zs = np.radians(50)
        lz = cs.cie_standard_luminance(0.0, zs, zs, 8, diffuse_horizontal_illuminance=20000.0)
        assert lz * cs.cie_standard_diffuse_ratio(zs, 8) == pytest.approx(20000.0, rel=1e-13)

    def test_exactly_one_scaling(self):
        with pytest.raises(ValueError, match="exactly one of zenith_luminance"):
            cs.cie_standard_luminance(0.0, 0.5, 0.5, 8)
        with pytest.raises(ValueError, match="exactly one of zenith_luminance"):
            cs.cie_standard_luminance(0.0, 0.5, 0.5, 8, zenith_luminance=1,
                                      diffuse_horizontal_illuminance=1)

    def test_negative_scaling(self):
        with pytest.raises(ValueError, match=r"diffuse_horizontal_illuminance must be in \[0, inf\) lx"):
            cs.cie_standard_luminance(0.0, 0.5, 0.5, 8, diffuse_horizontal_illuminance=-1)

    def test_sky_directions(self):
        sun = np.array([0.0, -math.sin(0.7), math.cos(0.7)])
        v = np.array([[0, 0, 1], [1, 0, 0.2], [0, -1, 0.5], [0, 0, -1], [np.nan, 0, 1]], float)
        out = cs.cie_standard_sky(v, sun, 14, zenith_luminance=1000.0)
        vh = v[:4] / np.linalg.norm(v[:4], axis=1)[:, None]
        g = np.arccos(np.clip(vh @ sun, -1, 1))
        ref = cs.cie_standard_luminance(np.arccos(vh[:, 2]), g, 0.7, 14, zenith_luminance=1000.0)
        np.testing.assert_allclose(out[:4], ref, rtol=1e-12)
        assert np.isnan(out[4])
        assert cs.cie_standard_sky(v[:2].astype(np.float32), sun, 14,
                                   zenith_luminance=1.0).dtype == np.float32
        night = cs.cie_standard_sky(v[:2], np.array([0, 1.0, -0.1]), 14,
                                    diffuse_horizontal_illuminance=100.0)
        np.testing.assert_array_equal(night, 0.0)

    def test_sun_at_horizon_finite(self):
        sun = np.array([0.0, 1.0, 0.0])
        v = np.array([[0, 0, 1.0], [0, 1.0, 1e-9], [0, -1.0, 0.0]])
        out = cs.cie_standard_sky(v, sun, 15, diffuse_horizontal_illuminance=1000.0)
        assert np.all(np.isfinite(out)) and np.all(out > 0)

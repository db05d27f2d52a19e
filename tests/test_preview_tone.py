"""The hue-preserving ``luminance`` tone curve of :mod:`atmoscatter.preview`.

What is checked, and against what:

* chromaticity: the output's channel ratios equal the input's (so its CIE xy, a linear
  function of the channels up to normalisation, is the input's), also for a saturated colour
  brighter than white — where the per-channel ``exponential`` curve is shown to shift it;
* monotonicity in luminance at fixed chromaticity (displayed luminance and every channel);
* the achromatic case reduces to seed 002's curve ``1 − e^{−exposure·Y}``, computed here;
* a fixed exposure keeps a darker sky darker (the automatic exposure does not);
* input errors.

Tolerances: the curve is a handful of float64 operations per pixel, so the ratio and
identity checks use ``rtol = 1e-12`` (about 10⁴ ulp, well above the rounding of
``expm1``, one division and one product); the 8-bit checks compare whole code values.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import atmoscatter as ac
from atmoscatter.colour import _luminance_coefficients, linear_rgb_to_XYZ
from atmoscatter.preview import preview_array, tone_map

COEFF = _luminance_coefficients("sRGB")  # Y of unit R, G, B (the sRGB matrix's Y row)
#: saturated sunset colours in linear sRGB (relative): orange-red, deep red, blue
COLOURS = np.array([[1.0, 0.30, 0.05], [1.0, 0.05, 0.02], [0.05, 0.15, 1.0]])


def chromaticity(rgb):
    xyz = linear_rgb_to_XYZ(np.asarray(rgb, dtype=float))
    return xyz[..., :2] / xyz.sum(axis=-1, keepdims=True)


def with_luminance(colour, Y):
    """``colour`` scaled to luminance ``Y`` [cd m⁻²] (a column of Y values → rows)."""
    c = np.asarray(colour, dtype=float)
    return np.asarray(Y, dtype=float)[..., None] * (c / (c @ COEFF))


class TestHue:
    @pytest.mark.parametrize("k", range(len(COLOURS)))
    def test_chromaticity_kept_above_white(self, k):
        exposure = 1e-3  # [m² cd⁻¹]
        Y = np.array([10.0, 500.0, 2000.0, 2.0e4, 1.0e6])  # exposure·Y from 0.01 to 1000
        rgb = with_luminance(COLOURS[k], Y)
        out = tone_map(rgb, exposure, "luminance")
        assert np.all(out <= 1.0) and np.all(out >= 0.0)
        # channel ratios = the input's → the same CIE xy chromaticity
        np.testing.assert_allclose(out / out.max(axis=-1, keepdims=True),
                                   rgb / rgb.max(axis=-1, keepdims=True), rtol=1e-12)
        np.testing.assert_allclose(chromaticity(out), chromaticity(rgb), rtol=1e-12)
        # above white (exposure·Y ≥ 2) the brightest channel is at full scale, not clipped:
        # the other channels keep their ratio to it instead of climbing to 1
        bright = exposure * Y >= 2.0
        np.testing.assert_allclose(out[bright].max(axis=-1), 1.0, rtol=1e-12)
        assert np.all(out[bright].min(axis=-1) < 0.2)

    def test_per_channel_curve_shifts_the_same_colour(self):
        # the check above can fail: the per-channel exponential curve moves a bright
        # orange-red toward yellow/white (its xy moves by far more than the tolerance)
        rgb = with_luminance(COLOURS[0], np.array([2.0e4]))
        shifted = chromaticity(tone_map(rgb, 1e-3, "exponential"))
        kept = chromaticity(tone_map(rgb, 1e-3, "luminance"))
        assert np.abs(shifted - chromaticity(rgb)).max() > 0.05
        assert np.abs(kept - chromaticity(rgb)).max() < 1e-12

    def test_grey_is_the_exponential_curve(self):
        # achromatic input (Y, Y, Y): no channel exceeds the luminance, so the output is
        # seed 002's 1 − e^{−exposure·Y} on every channel
        # (luminance passed: the sRGB coefficients sum to 1 only to ~2e-6, the rounding
        # of the published matrix, so (Y, Y, Y) computed from them is 2e-6 off Y)
        Y = np.array([0.0, 1e-3, 0.5, 10.0, 3000.0])
        out = tone_map(np.repeat(Y[:, None], 3, axis=1), 0.01, "luminance", luminance=Y)
        expected = np.array([1.0 - math.exp(-0.01 * v) for v in Y])
        np.testing.assert_allclose(out, np.repeat(expected[:, None], 3, axis=1), rtol=1e-12,
                                   atol=1e-300)

    def test_dark_colour_follows_the_curve_in_luminance(self):
        # while no channel reaches 1 the displayed luminance is exactly 1 − e^{−exposure·Y}
        Y = np.array([1.0, 50.0, 200.0])
        rgb = with_luminance(COLOURS[0], Y)
        out = tone_map(rgb, 1e-3, "luminance")
        assert out.max() < 1.0
        np.testing.assert_allclose(out @ COEFF, -np.expm1(-1e-3 * Y), rtol=1e-12)

    def test_given_luminance_equals_computed(self):
        rgb = with_luminance(COLOURS[1], np.array([[30.0, 3.0e3], [3.0e5, 7.0]]))
        np.testing.assert_allclose(
            tone_map(rgb, 2e-3, "luminance", luminance=rgb @ COEFF),
            tone_map(rgb, 2e-3, "luminance"), rtol=1e-12)

    def test_black_nan_and_negative(self):
        out = tone_map(np.array([[0.0, 0.0, 0.0], [np.nan, 1.0, 1.0], [-1.0, 0.0, 0.0]]),
                       1.0, "luminance")
        assert np.all(np.isfinite(out))
        np.testing.assert_array_equal(out[0], 0.0)
        np.testing.assert_array_equal(out[2], 0.0)


class TestMonotonic:
    @pytest.mark.parametrize("k", range(len(COLOURS)))
    def test_non_decreasing_in_luminance(self, k):
        Y = np.geomspace(1e-3, 1e7, 2001)
        out = tone_map(with_luminance(COLOURS[k], Y), 1e-3, "luminance")
        # above white the exact output is constant (c / max c); computed as one division
        # and one product per value it may wobble by a few ulp of 1, never more
        ulp = 4 * np.finfo(float).eps
        assert np.all(np.diff(out, axis=0) >= -ulp)  # every channel
        shown = out @ COEFF
        assert np.all(np.diff(shown) >= -ulp)
        below = out.max(axis=-1)[1:] < 1.0 - 1e-9  # no channel at full scale yet
        assert below.sum() > 100 and np.all(np.diff(shown)[below] > 0.0)  # strictly
        assert shown[-1] > shown[0]

    def test_8bit_preview_non_decreasing(self):
        Y = np.geomspace(1e-2, 1e6, 512)
        rgb = with_luminance(COLOURS[0], Y)[None]  # one row of an image
        px = preview_array(rgb, exposure=1e-3, tone="luminance").astype(int)
        assert np.all(np.diff(px[0], axis=0) >= 0)
        assert px[0, 0].max() == 0 and px[0, -1].max() == 255


class TestFixedExposure:
    def test_darker_sky_is_darker(self):
        # a real rendered sky (Preetham, cheap) and the same sky 8× (3 stops) darker, as one
        # frame of a twilight series is to the one before it
        img = ac.render(ac.Scene(model="preetham", sun_elevation_deg=30.0, projection="fisheye",
                                 width=24, height=24, sun_disc=False))
        rgb, lum, mask = img.rgb, img.luminance, img.alpha
        e = 1.0 / float(np.median(lum[mask > 0]))
        bright = preview_array(rgb, exposure=e, tone="luminance", luminance=lum)
        dark = preview_array(rgb / 8.0, exposure=e, tone="luminance", luminance=lum / 8.0)
        sky = mask > 0
        assert np.all(dark[sky].astype(int).sum(-1) < bright[sky].astype(int).sum(-1))
        # the automatic exposure (one per image) shows both the same: why the gallery
        # fixes one exposure per series
        auto_b = preview_array(rgb, tone="luminance", luminance=lum, mask=mask)
        auto_d = preview_array(rgb / 8.0, tone="luminance", luminance=lum / 8.0, mask=mask)
        assert np.abs(auto_b.astype(int) - auto_d.astype(int)).max() <= 1

    def test_scene_and_write_preview_accept_the_tone(self, tmp_path):
        from atmoscatter.preview import write_preview

        img = ac.render(ac.Scene(model="preetham", sun_elevation_deg=5.0, projection="latlong",
                                 width=16, height=8, tone="luminance", exposure=1e-3))
        path = write_preview(img, tmp_path / "sky.png")
        assert (tmp_path / "sky.png").stat().st_size > 0 and path.endswith("sky.png")


class TestErrors:
    def test_needs_rgb(self):
        with pytest.raises(ValueError, match=r"tone='luminance' needs RGB values"):
            tone_map(np.ones((4, 4)), 1.0, "luminance")

    def test_luminance_shape(self):
        with pytest.raises(ValueError, match=r"luminance must have shape \(4,\)"):
            tone_map(np.ones((4, 3)), 1.0, "luminance", luminance=np.ones(3))

    def test_unknown_tone_lists_luminance(self):
        with pytest.raises(ValueError, match="luminance"):
            tone_map(np.ones(3), 1.0, "filmic")

    def test_scene_rejects_unknown_tone(self):
        with pytest.raises(ValueError, match="tone"):
            ac.Scene(tone="filmic")

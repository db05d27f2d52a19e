"""SkyImage's planar storage behind its channel-last interface (atmoscatter.render.image)."""

from __future__ import annotations

import numpy as np
import pytest

import atmoscatter as ac
from atmoscatter.colour import XYZ_to_linear_rgb
from atmoscatter.exr import read_exr, write_exr


@pytest.fixture(scope="module")
def img():
    # 512 x 256 = 131 072 pixels: more than one band of the banded luminance (65 536)
    return ac.render(ac.Scene(width=512, height=256, sun_elevation_deg=20.0, alpha=True))


def test_layers_are_views_of_contiguous_planes(img):
    p = img.planes("rgb")
    assert p.shape == (3, 256, 512) and p.dtype == np.float32 and p.flags.c_contiguous
    assert img.rgb.shape == (256, 512, 3) and np.shares_memory(img.rgb, p)
    np.testing.assert_array_equal(img.rgb[..., 1], p[1])
    assert img.planes("xyz") is None and img.planes("spectral") is None
    with pytest.raises(ValueError, match="layer='alpha'"):
        img.planes("alpha")


def test_writing_through_the_view_changes_the_image():
    im = ac.render(ac.Scene(width=16, height=8))
    im.rgb[0, 0] = (1.0, 2.0, 3.0)
    np.testing.assert_array_equal(im.planes("rgb")[:, 0, 0], [1.0, 2.0, 3.0])


def test_alpha_is_float32_zero_or_one(img):
    a = img.alpha
    assert a.dtype == np.float32 and a.shape == img.shape
    assert set(np.unique(a)) == {0.0, 1.0}
    assert img.alpha is a  # converted once, then kept (writes into it persist)
    sky = img.directions[..., 2] >= img.plan.horizon_z
    np.testing.assert_array_equal(a > 0, sky)


def test_luminance_in_bands_matches_the_whole_map_formula(img):
    # the pre-planar formula: inverse of the forward matrix on the whole (h, w, 3) map
    m = np.linalg.inv(XYZ_to_linear_rgb(np.eye(3), img.scene.colourspace))
    ref = (np.ascontiguousarray(img.rgb).astype(np.float64) @ m[:, 1]).astype(np.float32)
    lum = img.luminance
    assert lum.dtype == np.float32 and lum.shape == img.shape
    # same float64 products per pixel, rounded to float32: equal to float32 rounding
    np.testing.assert_allclose(lum, ref, rtol=2e-7, atol=0.0)


def test_a_channel_last_array_is_stored_planar(img):
    rgb = np.ascontiguousarray(img.rgb)  # interleaved copy
    other = ac.SkyImage(img.scene, img.plan, img.directions_set, rgb=rgb, alpha=img.alpha)
    assert other.planes("rgb").flags.c_contiguous and not np.shares_memory(other.rgb, rgb)
    np.testing.assert_array_equal(other.rgb, img.rgb)
    # a view of another image's planes is kept as it is (no copy)
    same = ac.SkyImage(img.scene, img.plan, img.directions_set, rgb=img.rgb)
    assert np.shares_memory(same.planes("rgb"), img.planes("rgb"))
    other.rgb = None
    assert other.rgb is None and other.planes("rgb") is None
    assert "SkyImage(" in repr(img) and "rgb" in repr(img)


@pytest.mark.parametrize("precision", ["float", "half"])
def test_exr_channels_are_the_planes(img, tmp_path, precision):
    path = write_exr(tmp_path / "p.exr", img, precision=precision)
    back = read_exr(path)
    dtype = np.float32 if precision == "float" else np.float16
    for c, plane in zip("RGB", img.planes("rgb"), strict=True):
        assert back.channels[c].dtype == dtype
        expect = plane if precision == "float" else np.minimum(plane, 65504.0).astype(np.float16)
        np.testing.assert_array_equal(back.channels[c], expect)
    np.testing.assert_array_equal(back.channels["A"], img.alpha.astype(dtype))

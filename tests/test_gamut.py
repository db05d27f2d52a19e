"""Out-of-gamut policy of the RGB output (issue 11, deliverable 6).

Physical skies at low sun have colours outside sRGB: their XYZ is non-negative but their RGB
has a negative channel (``hoffman_preetham`` at sun 0–3°: the whole blue channel; the
``single_scattering`` horizon at sun −13…+3°).  The default ``gamut="map"`` moves those
colours into the gamut along the line toward the achromatic colour of the same luminance;
``"clip"`` clips; ``"none"`` keeps the raw values.  XYZ and spectral layers stay exact.

Tolerances: float32 has a unit roundoff u = 2⁻²⁴ ≈ 6e-8.  A luminance computed from float32
RGB carries at most u·Σ|l_k c_k| of rounding per rounding step (l = luminance coefficients);
the render rounds the raw RGB (once), the mapped RGB (once) and the XYZ layer (once), so
``|Y(rgb) − Y_xyz| ≤ 3u(Σ|l_k c_raw,k| + Y)``; the tests allow 4× that.  Chromaticities of
float32 colours are good to ~1e-6 (relative), and the mapped pixels lie ≥ 0.01 from the
white point in xy, so their direction from it is good to ~1e-4 rad.
"""

import warnings

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

import atmoscatter as ac
from atmoscatter.colour import GAMUT_POLICIES, _luminance_coefficients

U32 = 2.0**-24  # float32 unit roundoff
LUM = _luminance_coefficients("sRGB")


def xy(XYZ):
    XYZ = np.asarray(XYZ, dtype=np.float64)
    return XYZ[..., :2] / XYZ.sum(axis=-1, keepdims=True)


def expected_desaturation(raw):
    """1 − s of the map policy, from the definition: the achromatic level a = Y/Σl and the
    lowest channel m, s = a/(a − m) (0 for Y ≤ 0); raw (k, 3) out-of-gamut rows, float64."""
    raw = np.asarray(raw, dtype=np.float64)
    a = raw @ LUM / LUM.sum()
    m = raw.min(axis=-1)
    s = np.where(a > 0, a / np.where(a > 0, a - m, 1.0), 0.0)
    return 1.0 - s


# chromaticity of RGB (1, 1, 1) through the renderer's matrices: D65 (0.3127, 0.3290) to the
# 4-decimal rounding of the published sRGB matrix
WHITE = xy(ac.linear_rgb_to_XYZ([1.0, 1.0, 1.0]))


# ----------------------------------------------------------------------------
# the function
# ----------------------------------------------------------------------------
class TestRgbIntoGamut:
    def test_in_gamut_colours_unchanged(self):
        rgb = np.array([[1.0, 0.5, 0.25], [0.0, 0.0, 0.0], [3.0, 3.0, 3.0], [0.0, 1.0, 0.0]])
        for policy in GAMUT_POLICIES:
            # untouched rows: identical up to nothing (rtol of one float64 ulp for form)
            np.testing.assert_allclose(ac.rgb_into_gamut(rgb, policy=policy), rgb,
                                       rtol=1e-16, atol=0)

    def test_map_keeps_luminance_and_hue_and_lands_on_the_boundary(self):
        rng = np.random.default_rng(11)
        # colours with non-negative XYZ (as the models give) whose sRGB is out of gamut
        raw = ac.XYZ_to_linear_rgb(rng.uniform(0.0, 1.0, size=(4000, 3)))
        raw = raw[(raw.min(axis=-1) < 0) & (raw @ LUM > 1e-3)]
        assert len(raw) > 1000
        out = ac.rgb_into_gamut(raw)
        assert out.min() >= 0.0
        # float64 arithmetic: rounding ~ a few eps of Σ|l_k c_k|
        tol = 1e-14 * (np.abs(raw) @ np.abs(LUM))
        np.testing.assert_array_less(np.abs(out @ LUM - raw @ LUM), tol + 1e-300)
        np.testing.assert_allclose(out.min(axis=-1), 0.0, atol=1e-14)  # lowest channel → 0
        # hue: the output chromaticity is on the ray from the white point through the raw one
        d_raw = xy(ac.linear_rgb_to_XYZ(raw)) - WHITE
        d_out = xy(ac.linear_rgb_to_XYZ(out)) - WHITE
        cross = d_raw[:, 0] * d_out[:, 1] - d_raw[:, 1] * d_out[:, 0]
        norm = np.linalg.norm(d_raw, axis=-1) * np.linalg.norm(d_out, axis=-1)
        np.testing.assert_array_less(np.abs(cross) / norm, 1e-9)
        assert np.all(np.sum(d_raw * d_out, axis=-1) > 0)  # same side: not the opposite hue
        # lower purity: closer to the white point
        assert np.all(np.linalg.norm(d_out, axis=-1) <= np.linalg.norm(d_raw, axis=-1) * (1 + 1e-9))
        # the point is a + s (c − a) with the documented s
        s = 1.0 - expected_desaturation(raw)
        a = (raw @ LUM / LUM.sum())[:, None]
        np.testing.assert_allclose(out, a + s[:, None] * (raw - a), rtol=1e-12, atol=1e-14)

    def test_non_positive_luminance_becomes_black(self):
        out = ac.rgb_into_gamut([[-1.0, 0.1, 0.1], [0.5, -0.5, 0.5]])
        np.testing.assert_allclose(out[0], 0.0, atol=0)
        assert out.min() >= 0.0

    def test_clip_and_none(self):
        raw = np.array([[1.0, 0.5, -0.1], [-2.0, 1.0, 1.0], [0.2, 0.3, 0.4]])
        np.testing.assert_allclose(ac.rgb_into_gamut(raw, policy="clip"), np.maximum(raw, 0.0),
                                   rtol=1e-16, atol=0)
        np.testing.assert_allclose(ac.rgb_into_gamut(raw, policy="none"), raw, rtol=1e-16, atol=0)

    def test_shape_dtype_nan_and_other_colourspaces(self):
        raw = np.array([[[1.0, 0.5, -0.1], [np.nan, 0.0, 1.0]]] * 2, dtype=np.float32)
        out = ac.rgb_into_gamut(raw)
        assert out.shape == raw.shape and out.dtype == np.float32
        assert np.isnan(out[..., 1, 0]).all()  # NaN rows are left alone
        assert out[..., 0, :].min() >= 0.0
        # ACES2065-1 has a negative luminance coefficient (its blue primary has y < 0): Y kept
        lum = _luminance_coefficients("ACES2065-1")
        assert lum.min() < 0
        c = np.array([[0.2, 0.3, -0.4], [1.0, -0.1, 0.5]])
        o = ac.rgb_into_gamut(c, "ACES2065-1")
        assert o.min() >= 0.0
        np.testing.assert_allclose(o @ lum, c @ lum, rtol=1e-13)
        assert np.nanmin(raw) < 0  # input not modified

    def test_bad_input(self):
        with pytest.raises(ValueError, match=r"policy='wide' is not valid; choose one of"):
            ac.rgb_into_gamut([1.0, 0.0, 0.0], policy="wide")
        with pytest.raises(ValueError, match=r"rgb must have shape \(\.\.\., 3\)"):
            ac.rgb_into_gamut([1.0, 0.0])
        with pytest.raises(ValueError, match="colourspace"):
            ac.rgb_into_gamut([1.0, 0.0, 0.0], "not a colourspace")

    @given(st.lists(st.floats(-1e4, 1e4, allow_nan=False), min_size=3, max_size=3))
    def test_property_non_negative_and_luminance(self, c):
        c = np.array(c)
        out = ac.rgb_into_gamut(c)
        assert out.min() >= 0.0
        Y = c @ LUM
        if c.min() >= 0:
            np.testing.assert_allclose(out, c, rtol=1e-16, atol=0)
        elif Y > 0:
            assert abs(out @ LUM - Y) <= 1e-13 * (np.abs(c) @ LUM) + 1e-300
        else:
            np.testing.assert_allclose(out, 0.0, atol=0)


# ----------------------------------------------------------------------------
# renders: the low-sun cases of issue 11
# ----------------------------------------------------------------------------
LOW_SUN = [("hoffman_preetham", 1.0), ("hoffman_preetham", 3.0), ("hoffman_preetham", -3.0),
           ("single_scattering", 1.0), ("single_scattering", -3.0),
           ("single_scattering", 15.0)]
_CACHE = {}


def low_sun(model, el, gamut, **kw):
    key = (model, el, gamut, tuple(sorted(kw.items())))
    if key not in _CACHE:
        s = ac.Scene(model=model, sun_elevation_deg=el, width=64, height=32, output="xyz",
                     gamut=gamut, **kw)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", ac.GamutWarning)
            _CACHE[key] = ac.render(s, batch_size=300)  # 7 batches, some in gamut
    return _CACHE[key]


def luminance_tolerance(raw, Y):
    return 4.0 * 3.0 * U32 * (np.abs(raw.astype(np.float64)) @ np.abs(LUM) + Y)


@pytest.mark.parametrize("model,el", LOW_SUN)
class TestLowSunRenders:
    def test_none_reproduces_the_raw_values(self, model, el):
        img = low_sun(model, el, "none")
        xyz = img.xyz.astype(np.float64)
        # the old path: float32(XYZ64 @ M); the XYZ layer is float32(XYZ64) → 2 roundings
        m = np.abs(ac.XYZ_to_linear_rgb(np.eye(3)))
        tol = 4.0 * U32 * (np.abs(xyz) @ m)
        np.testing.assert_array_less(np.abs(img.rgb - ac.XYZ_to_linear_rgb(xyz)), tol + 1e-30)

    def test_map_is_non_negative_and_keeps_luminance(self, model, el):
        raw = low_sun(model, el, "none").rgb
        img = low_sun(model, el, "map")
        assert img.rgb.min() >= 0.0
        Y_xyz = img.xyz[..., 1].astype(np.float64)
        Y_rgb = ac.linear_rgb_to_XYZ(img.rgb.astype(np.float64))[..., 1]
        np.testing.assert_array_less(np.abs(Y_rgb - Y_xyz), luminance_tolerance(raw, Y_xyz) + 1e-30)
        np.testing.assert_allclose(img.luminance, Y_rgb, rtol=1e-6)  # SkyImage.luminance

    def test_map_keeps_hue(self, model, el):
        raw = low_sun(model, el, "none").rgb
        img = low_sun(model, el, "map")
        out = raw.min(axis=-1) < 0
        if not out.any():
            pytest.skip(f"{model} at {el}° has no out-of-gamut pixel")
        d_raw = xy(img.xyz[out]) - WHITE
        d_out = xy(ac.linear_rgb_to_XYZ(img.rgb[out].astype(np.float64))) - WHITE
        assert np.linalg.norm(d_raw, axis=-1).min() > 0.01  # far from white: directions defined
        cross = d_raw[:, 0] * d_out[:, 1] - d_raw[:, 1] * d_out[:, 0]
        norm = np.linalg.norm(d_raw, axis=-1) * np.linalg.norm(d_out, axis=-1)
        np.testing.assert_array_less(np.abs(cross) / norm, 1e-4)
        assert np.all(np.sum(d_raw * d_out, axis=-1) > 0)

    def test_in_gamut_pixels_and_other_layers_unchanged(self, model, el):
        raw = low_sun(model, el, "none")
        for policy in ("map", "clip"):
            img = low_sun(model, el, policy)
            ok = raw.rgb.min(axis=-1) >= 0
            # the policy never touches them: equal up to nothing (one float32 ulp for form)
            np.testing.assert_allclose(img.rgb[ok], raw.rgb[ok], rtol=U32, atol=0)
            np.testing.assert_allclose(img.xyz, raw.xyz, rtol=U32, atol=0)  # XYZ exact

    def test_clip(self, model, el):
        raw = low_sun(model, el, "none").rgb
        np.testing.assert_allclose(low_sun(model, el, "clip").rgb, np.maximum(raw, 0.0),
                                   rtol=U32, atol=0)

    def test_header_counts(self, model, el):
        raw = low_sun(model, el, "none").rgb.reshape(-1, 3)
        bad = raw.min(axis=-1) < 0
        n_bad = int(bad.sum())
        for policy in GAMUT_POLICIES:
            md = low_sun(model, el, policy).metadata
            assert md["atmoscatter:gamut"].startswith(policy + ":")
            assert int(md["atmoscatter:gamut_out_of_gamut_pixels"]) == n_bad
            assert float(md["atmoscatter:gamut_out_of_gamut_fraction"]) == pytest.approx(
                n_bad / raw.shape[0], rel=1e-5)  # written with 6 significant digits
            changed = 0 if policy == "none" else n_bad
            assert int(md["atmoscatter:gamut_mapped_pixels"]) == changed
            low = float(raw.min()) if n_bad else 0.0
            assert float(md["atmoscatter:gamut_min_raw_value"]) == pytest.approx(low, rel=1e-5)
            if policy == "map":
                d = expected_desaturation(raw[bad]).max() if n_bad else 0.0
                assert float(md["atmoscatter:gamut_max_desaturation"]) == pytest.approx(
                    d, rel=1e-5, abs=1e-6)
            else:
                assert "atmoscatter:gamut_max_desaturation" not in md


def test_the_issue_cases_do_have_out_of_gamut_pixels():
    """The low-sun cases above exercise the policy (otherwise the tests would prove nothing)."""
    for model, el in [("hoffman_preetham", 1.0), ("hoffman_preetham", 3.0),
                      ("single_scattering", 1.0), ("single_scattering", -3.0)]:
        assert low_sun(model, el, "none").rgb.min() < 0, (model, el)


def test_sun_disc_pixel_is_mapped_after_the_disc_is_added():
    """A sun smaller than a pixel puts its energy into the nearest pixel after the batches:
    the policy must see that final value.  At sun 3.5° the single-scattering sky is in the
    sRGB gamut everywhere but the transmitted (reddened) sun is not."""
    sky = low_sun("single_scattering", 3.5, "none")
    raw = low_sun("single_scattering", 3.5, "none", sun_disc=True)
    img = low_sun("single_scattering", 3.5, "map", sun_disc=True)
    assert sky.rgb.min() >= 0
    i = np.unravel_index(np.argmax(img.xyz[..., 1]), img.shape)
    assert img.xyz[i][1] > 10 * sky.xyz[i][1]  # the sun's pixel
    assert raw.rgb[i].min() < 0 and img.rgb.min() >= 0.0
    assert img.metadata["atmoscatter:gamut_mapped_pixels"] == "1"
    Y = ac.linear_rgb_to_XYZ(img.rgb[i].astype(np.float64))[1]
    assert abs(Y - img.xyz[i][1]) <= luminance_tolerance(raw.rgb[i], img.xyz[i][1])


def test_warning_when_many_pixels_change_and_not_otherwise():
    s = ac.Scene(model="hoffman_preetham", sun_elevation_deg=1.0, width=64, height=32)
    with pytest.warns(ac.GamutWarning, match=r"1024 of 2048 RGB pixels \(50.0 %\).*sRGB gamut"):
        ac.render(s)
    with warnings.catch_warnings():
        warnings.simplefilter("error", ac.GamutWarning)
        ac.render(s.replace_from_strings(["gamut=none"]))  # raw on request: no warning
        ac.render(s.replace_from_strings(["sun_elevation_deg=40"]))  # in gamut
        # a wide gamut holds these colours
        img = ac.render(s.replace_from_strings(["colourspace=ACES2065-1"]))
    assert img.metadata["atmoscatter:gamut_out_of_gamut_pixels"] == "0"


def test_scene_option():
    assert ac.Scene().gamut == "map"
    assert ac.Scene().replace_from_strings(["gamut=clip"]).gamut == "clip"
    with pytest.raises(ValueError) as exc:
        ac.Scene(gamut="wide")
    msg = str(exc.value)
    assert "\n" not in msg and "gamut='wide'" in msg and "['clip', 'map', 'none']" in msg
    s = ac.Scene(gamut="none")
    assert ac.Scene.from_dict(s.to_strings()) == s


def test_luminance_output_has_no_gamut_attributes():
    img = ac.render(ac.Scene(model="hoffman_preetham", sun_elevation_deg=1.0, width=16,
                             height=8, output="luminance"))
    assert not any(k.startswith("atmoscatter:gamut") for k in img.metadata)


def test_exr_carries_the_policy(tmp_path):
    OpenEXR = pytest.importorskip("OpenEXR")  # noqa: N806, F841
    img = low_sun("hoffman_preetham", 1.0, "map")
    back = ac.read_exr(ac.write_exr(tmp_path / "low.exr", img))
    assert back.rgb.min() >= 0.0
    for k in ("atmoscatter:gamut", "atmoscatter:gamut_out_of_gamut_pixels",
              "atmoscatter:gamut_mapped_pixels", "atmoscatter:gamut_max_desaturation"):
        assert back.header[k] == img.metadata[k]
    assert back.scene().gamut == "map"


def test_batch_with_a_nan_pixel_is_still_mapped():
    """A NaN pixel must not hide the out-of-gamut pixels of its batch (``min()`` of a batch
    with a NaN is NaN); the NaN itself is left alone."""
    from atmoscatter.render import ModelAdapter, register_model, unregister_model

    def prepare(scene, plan):
        def evaluate(d):
            # saturated orange (sRGB blue < 0) everywhere, NaN near the zenith
            xyz = np.tile([0.5, 0.3, 0.01], (len(d), 1)) * 1000.0
            xyz[d[:, 2] > 0.95] = np.nan
            return {"XYZ": xyz}
        return evaluate

    register_model(ModelAdapter(name="gamut_nan", description="orange with NaN near the zenith",
                                prepare=prepare, error_estimate="exact"), replace=True)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", ac.GamutWarning)
            img = ac.render(ac.Scene(model="gamut_nan", sun_elevation_deg=30.0, width=16,
                                     height=8, symmetry="off"), workers=1)
    finally:
        unregister_model("gamut_nan")
    nan = np.isnan(img.rgb).any(axis=-1)
    assert nan.any() and not nan.all()
    assert np.nanmin(img.rgb) >= 0.0
    sky = img.alpha > 0  # below the horizon: the (black) ground fill, in gamut
    assert int(img.metadata["atmoscatter:gamut_mapped_pixels"]) == (sky & ~nan).sum() > 0

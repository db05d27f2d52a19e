"""Tests for atmoscatter.compare (reference-oracle comparison of sky maps).

The perturbation tests build a reference image, derive a deliberately perturbed "other
renderer" image from it with a known scale factor and a known local perturbation, and check
that the comparison recovers both.  Expected statistics are computed independently here
from the patch's solid-angle fraction (exact pixel solid angles Δφ (cos θ₁ − cos θ₂)).
"""

from __future__ import annotations

import json
from types import SimpleNamespace

import numpy as np
import pytest
from _png import read_png  # tests/_png.py

from atmoscatter.colour import linear_rgb_to_XYZ
from atmoscatter.compare import (
    SCALE_METHODS,
    compare_exr,
    compare_images,
    read_sky_map,
    weighted_quantile,
)
from atmoscatter.integrals import latlong_quadrature

W, H = 64, 32


def _xyz_to_rgb_exact(xyz, colourspace):
    """Inverse of linear_rgb_to_XYZ (colour-science's published sRGB matrices are rounded to
    4 decimals and are not exact inverses of each other: ~4e-5)."""
    m = linear_rgb_to_XYZ(np.eye(3), colourspace).T  # columns: XYZ of the primaries
    return np.linalg.solve(m, xyz.reshape(-1, 3).T).T.reshape(xyz.shape)


def _reference():
    """A smooth, coloured 'sky' (XYZ, cd m⁻²) on a 64×32 lat-long map, with solid angles."""
    d, om = latlong_quadrature(W, H)
    sun = np.array([0.0, 0.6, 0.8])
    y = 3000.0 * (1 + 2 * np.abs(d[..., 2])) / 3 + 2000.0 * np.exp(5 * (d @ sun - 1))
    x = 0.30 + 0.02 * d[..., 2]
    yy = 0.31 + 0.01 * d[..., 0]
    xyz = np.stack([x / yy * y, y, (1 - x - yy) / yy * y], axis=-1)
    return xyz, om, d


def _patch():
    """Rows 4–9, columns 10–29: a local region of the upper sky."""
    m = np.zeros((H, W), dtype=bool)
    m[4:10, 10:30] = True
    return m


class TestPerturbationRecovered:
    def test_scale_and_local_perturbation(self):
        ref, om, _ = _reference()
        patch = _patch()
        k, bump = 2.5, 0.3  # other renderer in units 2.5× too small, +30 % in the patch
        other = ref / k
        other[patch] *= 1 + bump
        r = compare_images(other, ref, other_space="XYZ", reference_space="XYZ", weights=om)
        assert r.scale == pytest.approx(k, rel=1e-12)
        # independent expectation: solid-angle fraction of the patch (exact pixel areas)
        edges = np.linspace(0, np.pi, H + 1)
        band = (np.cos(edges[:-1]) - np.cos(edges[1:])) * 2 * np.pi / W
        frac = (band[4:10].sum() * 20) / (4 * np.pi)
        assert 0.05 < frac < 0.5  # so that p95 sees the patch and the median does not
        s = r.scaled_luminance_relative_error
        assert s["median"] == pytest.approx(0.0, abs=1e-12)
        assert s["p95"] == pytest.approx(bump, rel=1e-12)
        assert s["max"] == pytest.approx(bump, rel=1e-12)
        assert s["mean"] == pytest.approx(bump * frac, rel=1e-12)
        # without rescaling: |1/k − 1| = 0.6 outside, |1.3/k − 1| = 0.48 inside
        u = r.luminance_relative_error
        assert u["median"] == pytest.approx(1 - 1 / k, rel=1e-12)
        assert u["max"] == pytest.approx(1 - 1 / k, rel=1e-12)
        assert u["mean"] == pytest.approx((1 - frac) * 0.6 + frac * 0.48, rel=1e-12)
        # the signed map localises the perturbation
        np.testing.assert_allclose(r.relative_error_map[patch], (1 + bump) / k - 1, rtol=1e-12)
        np.testing.assert_allclose(r.relative_error_map[~patch], 1 / k - 1, rtol=1e-12)
        # a pure brightness change is no colour difference after exposure normalisation:
        # ΔE00 is ~0 outside the patch, positive inside (lightness differs there)
        assert np.nanmax(r.delta_e_map[~patch]) < 1e-6
        assert np.all(r.delta_e_map[patch] > 1.0)
        assert r.pixels_compared == W * H and r.weighting == "solid_angle"

    def test_chromatic_perturbation_only_in_delta_e(self):
        ref, om, _ = _reference()
        patch = _patch()
        other = ref * 7.0
        other[patch, 2] *= 1.5  # bluer (Z only): luminance unchanged
        r = compare_images(other, ref, other_space="XYZ", reference_space="XYZ", weights=om)
        assert r.scale == pytest.approx(1 / 7.0, rel=1e-12)
        assert r.scaled_luminance_relative_error["max"] == pytest.approx(0.0, abs=1e-12)
        assert np.nanmax(r.delta_e_map[~patch]) < 1e-6
        assert np.nanmin(r.delta_e_map[patch]) > 1.0
        # ΔE does not depend on the overall units of the other image
        r2 = compare_images(other / 1000, ref, other_space="XYZ", reference_space="XYZ",
                            weights=om)
        np.testing.assert_allclose(r2.delta_e_map, r.delta_e_map, rtol=1e-9, atol=1e-9)

    def test_rgb_input_and_least_squares(self):
        ref, om, _ = _reference()
        rgb = _xyz_to_rgb_exact(ref, "sRGB").astype(np.float32)
        r = compare_images(rgb * 3, ref, other_space="sRGB", weights=om,
                           scale_method="least_squares")
        assert r.scale == pytest.approx(1 / 3, rel=1e-6)
        assert r.luminance_relative_error["median"] == pytest.approx(2.0, rel=1e-6)
        assert r.delta_e_2000["max"] < 1e-3
        assert set(SCALE_METHODS) == {"median_log", "least_squares"}

    def test_pixel_weighting_and_luminance_only(self):
        ref, _, _ = _reference()
        y = ref[..., 1]
        other = y * 1.1
        r = compare_images(other, y, other_space="luminance", reference_space="luminance")
        assert r.weighting == "pixel" and r.delta_e_2000 is None and r.delta_e_map is None
        assert r.luminance_relative_error["p95"] == pytest.approx(0.1, rel=1e-12)
        assert r.scale == pytest.approx(1 / 1.1, rel=1e-12)

    def test_exclusions(self):
        ref, om, d = _reference()
        other = ref.copy()
        other[0, 0] = np.nan  # not finite → excluded
        ref2 = ref.copy()
        ref2[1, 1] = 0.0  # reference not positive → excluded
        sky = d[..., 2] > 0
        r = compare_images(other, ref2, other_space="XYZ", reference_space="XYZ", weights=om,
                           mask=sky)
        assert r.pixels_compared == sky.sum() - 2
        assert np.isnan(r.relative_error_map[0, 0]) and np.isnan(r.relative_error_map[1, 1])
        assert np.all(np.isnan(r.relative_error_map[~sky]))
        assert r.luminance_relative_error["max"] == 0.0


class TestWeightedQuantile:
    def test_equal_weights_match_numpy_inverted_cdf(self):
        v = np.random.default_rng(0).normal(size=101)
        for q in (0.0, 0.1, 0.5, 0.95, 1.0):
            assert weighted_quantile(v, q) == np.quantile(v, q, method="inverted_cdf")

    def test_integer_weights_equal_repetition(self):
        rng = np.random.default_rng(1)
        v = rng.normal(size=40)
        w = rng.integers(1, 5, size=40)
        for q in (0.25, 0.5, 0.95):
            assert weighted_quantile(v, q, w) == np.quantile(np.repeat(v, w), q,
                                                             method="inverted_cdf")

    def test_bad(self):
        with pytest.raises(ValueError, match="q must"):
            weighted_quantile([1.0], 1.5)
        with pytest.raises(ValueError, match="weights"):
            weighted_quantile([1.0, 2.0], 0.5, [1.0])


class TestBadInput:
    def test_errors(self):
        ref, om, _ = _reference()
        with pytest.raises(ValueError, match="differ in shape"):
            compare_images(ref[:-1], ref, other_space="XYZ")
        with pytest.raises(ValueError, match="no pixel"):
            compare_images(ref, ref * 0, other_space="XYZ")
        with pytest.raises(ValueError, match="positive luminance"):
            compare_images(ref * 0, ref, other_space="XYZ")
        with pytest.raises(ValueError, match="colourspace"):
            compare_images(ref, ref, other_space="NoSuchRGB")
        with pytest.raises(ValueError, match="scale_method"):
            compare_images(ref, ref, other_space="XYZ", scale_method="mean")
        with pytest.raises(ValueError, match="weights"):
            compare_images(ref, ref, other_space="XYZ", weights=om[:-1])
        with pytest.raises(ValueError, match="mask"):
            compare_images(ref, ref, other_space="XYZ", mask=np.ones(3, bool))
        with pytest.raises(ValueError, match="3 channels"):
            compare_images(ref[..., :2], ref, other_space="sRGB")


def _png_pixels(path):
    """RGB pixels of a PNG the report wrote (decoded by tests/_png.py, any row filter)."""
    px = read_png(path)
    assert px.shape[-1] == 3
    return px


def test_write_summary_and_error_maps(tmp_path):
    ref, om, _ = _reference()
    patch = _patch()
    other = ref.copy()
    other[patch] *= 1.5
    r = compare_images(other, ref, other_space="XYZ", reference_space="XYZ", weights=om,
                       info={"other": "synthetic"})
    paths = r.write(tmp_path / "report")
    summary = json.loads((tmp_path / "report" / "summary.json").read_text())
    for k in ("median", "p95", "max"):
        assert k in summary["luminance_relative_error"]
    assert summary["scale"] == pytest.approx(1.0)
    assert summary["luminance_relative_error"]["max"] == pytest.approx(0.5)
    assert summary["other"] == "synthetic"
    px = _png_pixels(paths["error_map"])
    assert px.shape == (H, W, 3)
    # brighter patch → saturated red at +50 % of the ±100 % range; elsewhere white
    np.testing.assert_array_equal(px[patch][0], [255, 128, 128])
    np.testing.assert_array_equal(px[~patch][0], [255, 255, 255])
    assert _png_pixels(paths["delta_e_map"]).shape == (H, W, 3)


# --------------------------------------------------------------------------------------
# EXR files of "another renderer"
# --------------------------------------------------------------------------------------
def _write_exr(path, channels, envmap=None):
    import OpenEXR

    header = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}
    if envmap == "latlong":
        header["envmap"] = OpenEXR.ENVMAP_LATLONG
    elif envmap == "cube":
        header["envmap"] = OpenEXR.ENVMAP_CUBE
    chans = {k: np.ascontiguousarray(v, dtype=np.float32) for k, v in channels.items()}
    with OpenEXR.File(header, chans) as f:
        f.write(str(path))


class TestReadSkyMap:
    def test_rgb_latlong(self, tmp_path):
        rng = np.random.default_rng(2)
        rgb = rng.uniform(0.1, 2.0, size=(H, W, 3)).astype(np.float32)
        p = tmp_path / "a.exr"
        _write_exr(p, {"R": rgb[..., 0], "G": rgb[..., 1], "B": rgb[..., 2]}, "latlong")
        m = read_sky_map(p)
        assert m.layout == "latlong" and (m.width, m.height) == (W, H)
        np.testing.assert_allclose(m.xyz, linear_rgb_to_XYZ(rgb.astype(float), "sRGB"),
                                   rtol=1e-12)
        m2 = read_sky_map(p, colourspace="ACEScg")
        np.testing.assert_allclose(m2.xyz, linear_rgb_to_XYZ(rgb.astype(float), "ACEScg"),
                                   rtol=1e-12)

    def test_rotate_and_flip_semantics(self, tmp_path):
        # every column stores a periodic function of the geographic azimuth it shows in
        # our layout: f(a) = 2 + cos a + 0.5 sin a
        d, _ = latlong_quadrature(W, H)
        az = np.arctan2(d[..., 0], d[..., 1])

        def f(a):
            return 2.0 + np.cos(a) + 0.5 * np.sin(a)

        p = tmp_path / "az.exr"
        _write_exr(p, {"Y": f(az)}, None)  # no envmap: layout from the 2:1 aspect
        m = read_sky_map(p, rotate_deg=90.0)
        assert m.layout == "latlong" and m.xyz is None
        # our pixel at azimuth a shows what the file stored at a − 90°
        np.testing.assert_allclose(m.luminance, f(az - np.pi / 2), atol=1e-6)
        fl = read_sky_map(p, flip="horizontal")
        np.testing.assert_allclose(fl.luminance, f(-az), atol=1e-6)
        v = read_sky_map(p, flip="vertical")
        np.testing.assert_array_equal(v.luminance, f(az)[::-1].astype(np.float32))
        # fractional shift: a signal linear in azimuth (jump at the south edges) is shifted
        # exactly by linear interpolation away from the jump
        lin = tmp_path / "lin.exr"
        _write_exr(lin, {"Y": np.degrees(az) + 181.0}, None)
        half = read_sky_map(lin, rotate_deg=360.0 / W / 2)
        inner = slice(2, W - 2)
        np.testing.assert_allclose(half.luminance[:, inner],
                                   (np.degrees(az) - 180.0 / W + 181.0)[:, inner], atol=1e-3)

    def test_layout_detection(self, tmp_path):
        p = tmp_path / "cube.exr"
        _write_exr(p, {"Y": np.ones((48, 8))}, None)
        m = read_sky_map(p)
        assert m.layout == "cubemap" and (m.width, m.height) == (8, 8)
        p2 = tmp_path / "fish.exr"
        _write_exr(p2, {"Y": np.ones((16, 16))}, None)
        assert read_sky_map(p2).layout == "fisheye"
        p3 = tmp_path / "odd.exr"
        _write_exr(p3, {"Y": np.ones((10, 16))}, None)
        with pytest.raises(ValueError, match="cannot infer the layout"):
            read_sky_map(p3)
        with pytest.raises(ValueError, match="twice as wide"):
            read_sky_map(p3, layout="latlong")
        # the envmap attribute wins over the aspect ratio
        p4 = tmp_path / "cube_attr.exr"
        _write_exr(p4, {"Y": np.ones((8, 16))}, "cube")
        with pytest.raises(ValueError, match="six square faces"):
            read_sky_map(p4)

    def test_bad_files(self, tmp_path):
        with pytest.raises(ValueError, match="does not exist"):
            read_sky_map(tmp_path / "missing.exr")
        junk = tmp_path / "junk.exr"
        junk.write_bytes(b"this is not an EXR file")
        with pytest.raises(ValueError, match="not a readable OpenEXR"):
            read_sky_map(junk)
        depth = tmp_path / "depth.exr"
        _write_exr(depth, {"Z": np.ones((8, 16))}, "latlong")
        with pytest.raises(ValueError, match="none of the channels"):
            read_sky_map(depth)
        rgb = tmp_path / "rgb.exr"
        _write_exr(rgb, {c: np.ones((8, 16)) for c in "RGB"}, "latlong")
        with pytest.raises(ValueError, match="colourspace"):
            read_sky_map(rgb, colourspace="NotAColourspace")
        with pytest.raises(ValueError, match="layout"):
            read_sky_map(rgb, layout="mercator")


class _FakeLatLong:
    """Stand-in for the renderer's lat-long direction set (same documented layout)."""

    kind = "latlong"

    def __init__(self, w, h):
        self._d, self._om = latlong_quadrature(w, h)
        self.shape, self.size = (h, w), w * h

    def all_directions(self):
        return self._d

    def solid_angles(self, start, stop):
        return self._om.ravel()[start:stop]


def test_compare_exr_against_given_reference(tmp_path):
    ref, om, d = _reference()
    sun = np.array([0.0, 0.6, 0.8])
    reference = SimpleNamespace(
        luminance=ref[..., 1], xyz=ref, rgb=None, alpha=None, directions_set=_FakeLatLong(W, H),
        plan=SimpleNamespace(sun_direction=sun), scene=SimpleNamespace(colourspace="sRGB"),
    )
    rgb = _xyz_to_rgb_exact(ref, "sRGB") / 4.0
    # the other renderer's map runs its azimuth the other way and is turned by 90°:
    # undo both with flip + rotate
    stored = np.roll(rgb, -W // 4, axis=1)[:, ::-1]
    p = tmp_path / "other.exr"
    _write_exr(p, {"R": stored[..., 0], "G": stored[..., 1], "B": stored[..., 2]}, "latlong")
    r = compare_exr(p, reference=reference, flip="horizontal", rotate_deg=90.0)
    assert r.scale == pytest.approx(4.0, rel=1e-6)
    assert r.scaled_luminance_relative_error["max"] < 1e-6
    assert r.delta_e_2000["max"] < 1e-3
    # only the sky, minus a 1° cone around the sun
    assert r.pixels_compared == int(((d[..., 2] > 0) & (d @ sun < np.cos(np.radians(1)))).sum())
    assert r.info["layout"] == "latlong" and "frame" in r.info
    # without the flip the maps disagree badly
    bad = compare_exr(p, reference=reference)
    assert bad.scaled_luminance_relative_error["max"] > 0.1
    # mismatched size
    small = tmp_path / "small.exr"
    _write_exr(small, {"Y": np.ones((8, 16))}, "latlong")
    with pytest.raises(ValueError, match="must match pixel for pixel"):
        compare_exr(small, reference=reference)
    with pytest.raises(ValueError, match="sun_exclusion_deg"):
        compare_exr(p, reference=reference, sun_exclusion_deg=-1)


# --------------------------------------------------------------------------------------
# end to end: our renderer's files and the ``atmoscatter compare`` command
# --------------------------------------------------------------------------------------
SCENE_TOML = """model = "preetham"
turbidity = 3.0
sun_elevation_deg = 40.0
sun_azimuth_deg = 150.0
"""


def _scene_file(tmp_path):
    p = tmp_path / "scene.toml"
    p.write_text(SCENE_TOML)
    return p


@pytest.mark.parametrize("projection,width,height", [("latlong", 32, 16), ("cubemap", 8, 8),
                                                     ("fisheye", 16, 16)])
def test_compare_our_own_render_is_exact(tmp_path, projection, width, height):
    import atmoscatter as ac

    scene = ac.Scene(model="preetham", turbidity=3.0, sun_elevation_deg=40.0,
                     sun_azimuth_deg=150.0, projection=projection, width=width, height=height,
                     output="xyz")
    path = ac.write_exr(tmp_path / "ours.exr", ac.render(scene))
    r = compare_exr(path, scene)
    assert r.info["layout"] == projection
    assert r.pixels_compared > 0
    # float32 EXR round trip only
    assert r.luminance_relative_error["max"] < 1e-6
    assert r.scale == pytest.approx(1.0, abs=1e-6)
    assert r.delta_e_2000["max"] < 1e-3


def test_cli_compare_writes_summary_and_recovers_scale(tmp_path):
    import atmoscatter as ac
    from atmoscatter.cli import main

    scene = ac.Scene(model="preetham", turbidity=3.0, sun_elevation_deg=40.0,
                     sun_azimuth_deg=150.0, projection="latlong", width=32, height=16)
    rgb = np.asarray(ac.render(scene).rgb, dtype=np.float64) * 0.01
    rgb[3:5, 8:14] *= 1.25  # local perturbation in the sky
    other = tmp_path / "other.exr"
    # stored with north at the left edge instead of the centre: --rotate 180 undoes it
    stored = np.roll(rgb, 16, axis=1)
    _write_exr(other, {c: stored[..., i] for i, c in enumerate("RGB")}, "latlong")
    out = tmp_path / "report"
    status = main(["compare", str(other), "--scene", str(_scene_file(tmp_path)), "--rotate",
                   "180", "-o", str(out)])
    assert status == 0
    s = json.loads((out / "summary.json").read_text())
    assert s["scale"] == pytest.approx(100.0, rel=1e-5)
    # without rescaling every sky pixel is 99 % too dark (the patch 98.75 %)
    assert s["luminance_relative_error"]["median"] == pytest.approx(0.99, rel=1e-5)
    assert s["luminance_relative_error"]["max"] == pytest.approx(0.99, rel=1e-5)
    assert s["scaled_luminance_relative_error"]["max"] == pytest.approx(0.25, rel=1e-4)
    assert s["scaled_luminance_relative_error"]["median"] < 1e-5
    assert s["layout"] == "latlong" and s["scene"]["model"] == "preetham"
    assert (out / "error_map.png").exists() and (out / "delta_e_map.png").exists()


def test_cli_compare_uses_scene_in_header_and_reports_errors(tmp_path, capsys):
    import atmoscatter as ac
    from atmoscatter.cli import main

    scene = ac.Scene(model="preetham", sun_elevation_deg=30.0, sun_azimuth_deg=90.0,
                     projection="latlong", width=16, height=8)
    path = ac.write_exr(tmp_path / "ours.exr", ac.render(scene))
    assert main(["compare", str(path)]) == 0  # scene read back from the EXR header
    assert "best-fit scale" in capsys.readouterr().out
    # a file without a recorded scene and no --scene
    bare = tmp_path / "bare.exr"
    _write_exr(bare, {"Y": np.ones((8, 16))}, "latlong")
    assert main(["compare", str(bare)]) == 2
    err = capsys.readouterr().err
    assert "pass --scene" in err and err.count("\n") == 1
    # not an EXR
    junk = tmp_path / "junk.exr"
    junk.write_text("nope")
    assert main(["compare", str(junk), "--scene", str(_scene_file(tmp_path))]) == 2
    assert "not a readable OpenEXR file" in capsys.readouterr().err
    # wrong shape for the declared layout
    assert main(["compare", str(bare), "--scene", str(_scene_file(tmp_path)),
                 "--layout", "cubemap"]) == 2
    assert "six square faces" in capsys.readouterr().err


def test_compare_direction_set_file(tmp_path):
    # a dome mesh written by our renderer carries dir.X/Y/Z: compared at those directions
    import atmoscatter as ac

    scene = ac.Scene(model="preetham", turbidity=3.0, sun_elevation_deg=40.0,
                     sun_azimuth_deg=150.0, projection="dome", width=16, height=6)
    img = ac.render(scene)
    path = ac.write_exr(tmp_path / "dome.exr", img)
    m = read_sky_map(path)
    assert m.layout == "directions" and m.directions.shape == m.luminance.shape + (3,)
    r = compare_exr(path, scene)
    assert r.weighting == "pixel" and r.pixels_compared > 0
    assert r.luminance_relative_error["max"] < 1e-6
    # rotating the file's directions by 30° in azimuth (and mirroring) is undone exactly
    d = np.asarray(img.directions, dtype=float).reshape(1, -1, 3)
    a = np.radians(-30.0)
    stored = np.stack([-(d[..., 0] * np.cos(a) + d[..., 1] * np.sin(a)),
                       d[..., 1] * np.cos(a) - d[..., 0] * np.sin(a), d[..., 2]], -1)
    xyz = np.asarray(img.xyz if img.xyz is not None else
                     linear_rgb_to_XYZ(np.asarray(img.rgb, float), "sRGB"), float).reshape(1, -1, 3)
    other = tmp_path / "rotated.exr"
    _write_exr(other, {"XYZ.X": xyz[..., 0], "XYZ.Y": xyz[..., 1], "XYZ.Z": xyz[..., 2],
                       "dir.X": stored[..., 0], "dir.Y": stored[..., 1], "dir.Z": stored[..., 2]})
    np.testing.assert_allclose(read_sky_map(other, flip="horizontal", rotate_deg=30.0).directions,
                               d, atol=1e-6)
    r2 = compare_exr(other, scene, flip="horizontal", rotate_deg=30.0)
    assert r2.luminance_relative_error["max"] < 1e-5
    bad = compare_exr(other, scene)
    assert bad.luminance_relative_error["max"] > 0.05


@pytest.mark.parametrize("projection,width,height", [("cubemap", 8, 8), ("fisheye", 16, 16)])
@pytest.mark.parametrize("flip,rotate,azimuth", [("none", 40.0, 190.0),
                                                 ("horizontal", 0.0, 210.0),
                                                 ("horizontal", 25.0, 235.0)])
def test_rotate_and_flip_cube_maps_and_fisheyes(tmp_path, projection, width, height, flip,
                                                rotate, azimuth):
    # their map: sun at azimuth 150°.  Mirrored (a → −a) and turned by `rotate`, it shows the
    # sky of a sun at −150° + rotate: our reference for that scene must match it exactly
    import atmoscatter as ac

    def scene(az):
        return ac.Scene(model="preetham", turbidity=3.0, sun_elevation_deg=35.0,
                        sun_azimuth_deg=az, projection=projection, width=width, height=height)

    path = ac.write_exr(tmp_path / "theirs.exr", ac.render(scene(150.0)))
    r = compare_exr(path, scene(azimuth), flip=flip, rotate_deg=rotate)
    assert r.weighting == "solid_angle" and r.pixels_compared > 0
    assert r.luminance_relative_error["max"] < 1e-5
    assert r.delta_e_2000["max"] < 1e-3
    # and without the options they disagree
    assert compare_exr(path, scene(azimuth)).luminance_relative_error["max"] > 0.05
    if projection == "fisheye":
        with pytest.raises(ValueError, match="rotate_deg=180"):
            compare_exr(path, scene(azimuth), flip="vertical")


def test_spectral_file_is_integrated_to_xyz(tmp_path):
    # spectral layers S0.<λ>nm (Fichet et al. 2021 naming) → XYZ with the CIE CMFs
    from atmoscatter.colour import spectral_to_XYZ

    wl = np.arange(380.0, 781.0, 10.0)
    rng = np.random.default_rng(4)
    spec = rng.uniform(0.0, 0.01, size=(8, 16, wl.size))
    chans = {"S0." + f"{w:.6f}".replace(".", ",") + "nm": spec[..., i] for i, w in enumerate(wl)}
    p = tmp_path / "spectral.exr"
    _write_exr(p, chans, "latlong")
    m = read_sky_map(p)
    assert "spectral" in m.source and "41 bands" in m.source
    np.testing.assert_allclose(m.xyz, spectral_to_XYZ(spec.astype(np.float32).astype(float), wl),
                               rtol=1e-12)

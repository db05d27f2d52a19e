"""EXR round trips, header provenance, atomic writes, and PNG previews."""

import json
import os

import numpy as np
import OpenEXR
import pytest
from _png import read_png  # tests/_png.py

import atmoscatter as ac
from atmoscatter.exr import (
    atomic_write,
    is_complete_exr,
    read_exr,
    spectral_channel_name,
    write_exr,
)
from atmoscatter.preview import preview_array, srgb_encode, tone_map, write_png, write_preview
from atmoscatter.render import physical_adapter, register_model, unregister_model
from atmoscatter.scene import Scene

pytestmark = pytest.mark.usefixtures("toy_model")


def scene(**kw):
    base = dict(model="toy", sun_elevation_deg=35.0, sun_azimuth_deg=150.0, width=32, height=16)
    base.update(kw)
    return Scene(**base)


class TestRoundTrip:
    def test_float_rgb(self, tmp_path):
        img = ac.render(scene(turbidity=3.0, alpha=True))
        p = write_exr(tmp_path / "sky.exr", img)
        back = read_exr(p)
        np.testing.assert_array_equal(back.rgb, img.rgb)
        np.testing.assert_array_equal(back.alpha, img.alpha)
        assert back.rgb.dtype == np.float32

    def test_half(self, tmp_path):
        img = ac.render(scene(precision="half"))
        back = read_exr(write_exr(tmp_path / "h.exr", img))
        assert back.rgb.dtype == np.float16
        # half has an 11-bit significand: relative error <= 2^-11
        np.testing.assert_allclose(back.rgb.astype(np.float32), img.rgb, rtol=2**-11)

    def test_half_saturates_instead_of_inf(self, tmp_path):
        img = ac.render(scene())
        img.rgb[0, 0] = 1e9
        back = read_exr(write_exr(tmp_path / "h.exr", img, precision="half"))
        assert np.all(np.isfinite(back.rgb)) and back.rgb[0, 0, 0] == np.float16(65504)

    def test_xyz_and_luminance_layers(self, tmp_path):
        img = ac.render(scene(output="xyz"))
        back = read_exr(write_exr(tmp_path / "x.exr", img))
        np.testing.assert_array_equal(back.xyz, img.xyz)
        assert back.rgb is not None
        img = ac.render(scene(output="luminance"))
        back = read_exr(write_exr(tmp_path / "y.exr", img))
        np.testing.assert_array_equal(back.luminance, img.luminance)
        assert back.rgb is None and set(back.channels) == {"Y"}

    def test_spectral_layers(self, tmp_path, monkeypatch):
        def fake(atm, d, sun, **kw):
            wl = atm.wavelengths_array
            return np.broadcast_to(1e-2 * (550.0 / wl) ** 4, d.shape[:-1] + wl.shape).copy()

        previous = ac.MODELS.get("single_scattering")
        monkeypatch.setattr(ac, "single_scattering", fake, raising=False)
        register_model(physical_adapter("single_scattering"), replace=True)
        try:
            img = ac.render(scene(model="single_scattering", output="spectral",
                                  wavelength_step=50.0, width=8, height=4))
        finally:
            unregister_model("single_scattering")
            if previous is not None:
                register_model(previous)
        back = read_exr(write_exr(tmp_path / "s.exr", img))
        wl, spec = back.spectral
        np.testing.assert_array_equal(wl, img.wavelengths)
        np.testing.assert_array_equal(spec, img.spectral)
        assert spectral_channel_name(580.0) in back.channels
        assert spectral_channel_name(550.0) == "S0.550,000000nm"

    def test_dome_vertices(self, tmp_path):
        img = ac.render(scene(projection="dome", width=12, height=4))
        back = read_exr(write_exr(tmp_path / "d.exr", img))
        assert back.rgb.shape == (1, img.shape[0], 3)
        d = np.stack([back.channels[f"dir.{c}"][0] for c in "XYZ"], -1)
        np.testing.assert_allclose(d, img.directions, atol=1e-7)
        assert "envmap" not in back.header


class TestHeader:
    def test_provenance(self, tmp_path):
        s = scene(turbidity=4.5)
        back = read_exr(write_exr(tmp_path / "sky.exr", ac.render(s)))
        h = back.header
        assert h["atmoscatter:package"] == "atmoscatter"
        assert h["atmoscatter:version"] == ac.__version__
        assert h["atmoscatter:model"] == "toy"
        assert h["atmoscatter:error_estimate"] == "exact (toy)"
        # every scene field as a string attribute, turbidity included
        for k, v in s.to_strings().items():
            assert h[k] == v and isinstance(h[k], str)
        assert h["turbidity"] == "4.5"
        assert json.loads(h["atmoscatter:plan"])["model"] == "toy"
        assert back.scene() == s

    def test_envmap_and_chromaticities(self, tmp_path):
        import colour

        back = read_exr(write_exr(tmp_path / "l.exr", ac.render(scene())))
        assert back.header["envmap"] == OpenEXR.ENVMAP_LATLONG
        cs = colour.RGB_COLOURSPACES["sRGB"]
        expected = list(np.ravel(cs.primaries)) + list(cs.whitepoint)
        np.testing.assert_allclose(back.header["chromaticities"], expected, atol=1e-7)
        cube = read_exr(write_exr(tmp_path / "c.exr", ac.render(scene(projection="cubemap",
                                                                      width=8))))
        assert cube.header["envmap"] == OpenEXR.ENVMAP_CUBE
        assert cube.rgb.shape == (48, 8, 3)
        fish = read_exr(write_exr(tmp_path / "f.exr", ac.render(scene(projection="fisheye"))))
        assert "envmap" not in fish.header

    def test_other_colourspace(self, tmp_path):
        import colour

        back = read_exr(write_exr(tmp_path / "p3.exr", ac.render(scene(colourspace="ACEScg"))))
        cs = colour.RGB_COLOURSPACES["ACEScg"]
        np.testing.assert_allclose(back.header["chromaticities"][:2], cs.primaries[0], atol=1e-7)


class TestAtomic:
    def test_failed_write_keeps_old_file_and_leaves_no_temp(self, tmp_path, monkeypatch):
        target = tmp_path / "sky.exr"
        write_exr(target, ac.render(scene()))
        before = target.read_bytes()

        real_write = OpenEXR.File.write

        class Boom(Exception):
            pass

        def partial_write(self, path):
            real_write(self, path)
            with open(path, "r+b") as fh:  # leave a truncated temp file, then fail
                fh.truncate(100)
            raise Boom("disk full")

        monkeypatch.setattr(OpenEXR.File, "write", partial_write)
        with pytest.raises(Boom):
            write_exr(target, ac.render(scene(turbidity=7.0)))
        assert target.read_bytes() == before
        assert os.listdir(tmp_path) == ["sky.exr"]
        with pytest.raises(Boom):
            write_exr(tmp_path / "new.exr", ac.render(scene()))
        assert not (tmp_path / "new.exr").exists()
        assert os.listdir(tmp_path) == ["sky.exr"]

    def test_atomic_write_context(self, tmp_path):
        target = tmp_path / "a.txt"
        with atomic_write(target) as tmp:
            assert os.path.dirname(tmp) == str(tmp_path) and not target.exists()
            open(tmp, "w").write("ok")
        assert target.read_text() == "ok"

    def test_is_complete(self, tmp_path):
        p = write_exr(tmp_path / "ok.exr", ac.render(scene()))
        assert is_complete_exr(p)
        data = open(p, "rb").read()
        bad = tmp_path / "bad.exr"
        bad.write_bytes(data[: len(data) // 2])
        assert not is_complete_exr(bad)
        assert not is_complete_exr(tmp_path / "missing.exr")
        (tmp_path / "text.exr").write_text("hello")
        assert not is_complete_exr(tmp_path / "text.exr")
        with pytest.raises(ValueError, match="not a readable OpenEXR"):
            read_exr(bad)


class TestPreview:
    def test_tone_curves(self):
        L = np.array([0.0, 1.0, 10.0])
        np.testing.assert_allclose(tone_map(L, 0.1, "exponential"), 1 - np.exp(-0.1 * L))
        np.testing.assert_allclose(tone_map(L, 0.1, "reinhard"), 0.1 * L / (1 + 0.1 * L))
        np.testing.assert_allclose(tone_map(L, 0.5, "clip"), [0, 0.5, 1.0])
        with pytest.raises(ValueError, match="tone='gamma' is not valid"):
            tone_map(L, 1.0, "gamma")
        with pytest.raises(ValueError, match="exposure must be in"):
            tone_map(L, 0.0)
        assert np.all(np.isfinite(tone_map(np.array([np.nan, np.inf]), 1.0)))

    def test_srgb_encode(self):
        # IEC 61966-2-1: 0.0031308 -> 0.04045, 1 -> 1, 0.5 -> 0.7354
        np.testing.assert_allclose(srgb_encode(np.array([0.0031308, 1.0, 0.5])),
                                   [0.04045, 1.0, 0.735357], atol=2e-5)

    def test_png_round_trip(self, tmp_path):
        px = np.random.default_rng(0).integers(0, 256, size=(5, 7, 4), dtype=np.uint8)
        np.testing.assert_array_equal(read_png(write_png(tmp_path / "a.png", px)), px)
        np.testing.assert_array_equal(read_png(write_png(tmp_path / "b.png", px[..., :3])),
                                      px[..., :3])

    def test_preview_of_exr(self, tmp_path):
        img = ac.render(scene(alpha=True))
        exr = write_exr(tmp_path / "sky.exr", img)
        png = write_preview(exr, tmp_path / "sky.png", exposure=1e-4, alpha="mask")
        px = read_png(png)
        assert px.shape == (16, 32, 4)
        expected = np.round(srgb_encode(1 - np.exp(-1e-4 * img.rgb.astype(float))) * 255)
        np.testing.assert_array_equal(px[..., :3], expected.astype(np.uint8))
        np.testing.assert_array_equal(px[..., 3], (img.alpha * 255).astype(np.uint8))

    def test_seed002_alpha(self):
        rgb = np.zeros((2, 2, 3))
        rgb[0, 0] = 1000.0
        px = preview_array(rgb, exposure=1e-3, alpha="sky", transparency=0.5)
        t = 1 - np.exp(-1.0)
        assert px[0, 0, 3] == round(min(1.0, (3 * t) ** 0.5) * 255)
        assert px[1, 1, 3] == 0  # black sky: stars show through

    def test_auto_exposure_and_dome_error(self, tmp_path):
        img = ac.render(scene())
        px = preview_array(img.rgb, mask=img.alpha)
        assert 60 < np.median(px[:8, :, 1]) < 250
        with pytest.raises(ValueError, match="dome mesh has no image"):
            write_preview(ac.render(scene(projection="dome", width=8, height=3)),
                          tmp_path / "d.png")


def test_written_files_get_normal_permissions(tmp_path):
    import stat

    p = write_exr(tmp_path / "perm.exr", ac.render(scene()))
    mask = os.umask(0)
    os.umask(mask)
    assert stat.S_IMODE(os.stat(p).st_mode) == 0o666 & ~mask


def test_directory_as_output_is_a_clear_error(tmp_path):
    with pytest.raises(ValueError, match="is a directory"):
        write_exr(tmp_path, ac.render(scene()))

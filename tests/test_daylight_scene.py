"""Scene keys and model adapters of the daylighting skies (cie_standard, perez_all_weather).

The rendered values are checked against the array functions of the same models (the
adapters only map scene fields onto them and add the D65 chromaticity of the CIE skies).
"""

from __future__ import annotations

import numpy as np
import pytest

import atmoscatter as ac
from atmoscatter.batch import load_batch, run_batch


def _zenith_y(img):
    i = int(np.argmax(np.asarray(img.directions)[..., 2].ravel()))
    return float(np.asarray(img.luminance).ravel()[i]), np.asarray(img.directions).reshape(-1, 3)[i]


class TestScene:
    def test_set_strings(self):
        s = ac.Scene().replace_from_strings(["model=cie_standard", "cie_type=7",
                                             "diffuse_horizontal_illuminance=25000"])
        assert s.cie_type == 7 and s.diffuse_horizontal_illuminance == 25000.0
        p = ac.Scene().replace_from_strings(["model=perez_all_weather",
                                             "direct_normal_irradiance=600",
                                             "diffuse_horizontal_irradiance=120", "dew_point=8"])
        assert p.dew_point == 8.0

    def test_scene_file(self, tmp_path):
        f = tmp_path / "sky.toml"
        f.write_text('model = "cie_standard"\ncie_type = 12\nzenith_luminance = 8000\n'
                     'sun_elevation_deg = 35\nwidth = 32\nheight = 16\n')
        s = ac.load_scene(f)
        assert s.model == "cie_standard" and s.zenith_luminance == 8000.0

    @pytest.mark.parametrize("fields, match", [
        ({"model": "cie_standard", "zenith_luminance": 1.0}, "needs cie_type"),
        ({"model": "cie_standard", "cie_type": 16, "zenith_luminance": 1.0},
         r"cie_type must be in \[1, 15\], got 16"),
        ({"model": "cie_standard", "cie_type": 3}, "exactly one of zenith_luminance"),
        ({"model": "cie_standard", "cie_type": 3, "zenith_luminance": 1.0,
          "diffuse_horizontal_illuminance": 2.0}, "exactly one of zenith_luminance"),
        ({"model": "cie_standard", "cie_type": 3, "zenith_luminance": -1.0},
         r"zenith_luminance must be in \[0, inf\)"),
        ({"model": "perez_all_weather", "direct_normal_irradiance": 100.0},
         "needs diffuse_horizontal_irradiance"),
        ({"model": "perez_all_weather", "direct_normal_irradiance": -5.0,
          "diffuse_horizontal_irradiance": 100.0}, r"direct_normal_irradiance must be in \[0, inf\)"),
        ({"model": "perez_all_weather", "direct_normal_irradiance": 5.0,
          "diffuse_horizontal_irradiance": 100.0, "dew_point": 99.0},
         r"dew_point must be in \[-100, 60\] degC, got 99.0"),
        ({"model": "preetham", "cie_type": 3}, "cie_type=3 only applies to model='cie_standard'"),
        ({"model": "cie_standard", "cie_type": 3, "zenith_luminance": 1.0, "dew_point": 3.0},
         "dew_point=3.0 only applies to model='perez_all_weather'"),
        ({"model": "cie_standard", "cie_type": "x"}, "scene field cie_type must be an integer"),
    ])
    def test_bad_fields(self, fields, match):
        with pytest.raises(ValueError, match=match):
            ac.Scene.from_dict(fields)


class TestRender:
    def test_cie_standard_zenith_luminance(self):
        s = ac.Scene(model="cie_standard", cie_type=9, zenith_luminance=6000.0,
                     sun_elevation_deg=30.0, width=32, height=16, output="luminance")
        img = ac.render(s)
        y, d = _zenith_y(img)
        ref = ac.cie_standard_sky(d[None], s.sun_direction(), 9, zenith_luminance=6000.0)[0]
        assert y == pytest.approx(float(ref), rel=1e-5)  # float32 output
        assert np.all(np.asarray(img.luminance) >= 0)

    def test_cie_standard_colour_is_d65(self):
        s = ac.Scene(model="cie_standard", cie_type=4, diffuse_horizontal_illuminance=1e4,
                     sun_elevation_deg=30.0, width=16, height=8, output="xyz")
        xyz = np.asarray(ac.render(s).xyz).reshape(-1, 3)
        xyz = xyz[xyz[:, 1] > 0]
        x = xyz[:, 0] / xyz.sum(axis=1)
        np.testing.assert_allclose(x, ac.CIE_SKY_CHROMATICITY[0], rtol=1e-5)

    def test_perez_all_weather_matches_function(self):
        s = ac.Scene(model="perez_all_weather", direct_normal_irradiance=550.0,
                     diffuse_horizontal_irradiance=140.0, dew_point=10.0,
                     time="2024-03-20T11:00:00Z", width=32, height=16, output="luminance")
        img = ac.render(s)
        y, d = _zenith_y(img)
        from atmoscatter.render.daylight_adapters import _scene_extraterrestrial_irradiance

        i0 = _scene_extraterrestrial_irradiance(s)
        assert 1367 / 1.02**2 < i0 < 1367 / 0.98**2
        ref = ac.perez_all_weather_sky(d[None], s.sun_direction(), 550.0, 140.0, dew_point=10.0,
                                       extraterrestrial_normal_irradiance=i0)[0]
        assert y == pytest.approx(float(ref), rel=1e-5)

    def test_perez_night_with_diffuse_light_is_an_error(self):
        s = ac.Scene(model="perez_all_weather", direct_normal_irradiance=0.0,
                     diffuse_horizontal_irradiance=20.0, sun_elevation_deg=-5.0,
                     width=16, height=8)
        with pytest.raises(ValueError, match="below the horizon"):
            ac.render(s)

    def test_perez_night_black(self):
        s = ac.Scene(model="perez_all_weather", direct_normal_irradiance=0.0,
                     diffuse_horizontal_irradiance=0.0, sun_elevation_deg=-5.0,
                     width=16, height=8, output="luminance")
        assert np.all(np.asarray(ac.render(s).luminance) == 0)


class TestBatch:
    def test_batch_columns(self, tmp_path):
        p = tmp_path / "skies.csv"
        p.write_text(
            "name,model,cie_type,zenith_luminance,direct_normal_irradiance,"
            "diffuse_horizontal_irradiance,dew_point,sun_elevation_deg\n"
            "overcast,cie_standard,1,5000,,,,20\n"
            "hour_12,perez_all_weather,,,620,95,11,45\n"
            "bad,perez_all_weather,,,620,,,45\n")
        items = load_batch(p, overrides={"width": "16", "height": "8"})
        summary = run_batch(items, tmp_path / "out", progress=None)
        assert summary.count("done") == 2 and summary.count("failed") == 1
        assert (tmp_path / "out" / "overcast.exr").exists()
        assert (tmp_path / "out" / "hour_12.exr").exists()


def test_plan_says_turbidity_is_not_used_by_measured_input_skies():
    """The plan's notes do not call turbidity a fit parameter of the daylighting skies."""
    p = ac.plan(ac.Scene(model="cie_standard", cie_type=3, zenith_luminance=5000.0))
    assert any("turbidity is not used" in n for n in p.notes)
    assert not any("parameter of the fit" in n for n in p.notes)
    assert not p.haze

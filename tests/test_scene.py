"""Scene loading/validation and plan(): the decisions and their records."""

import datetime as dt
import json
import math

import numpy as np
import pytest

import atmoscatter as ac
from atmoscatter.render import ModelAdapter, Plan, plan, register_model, unregister_model
from atmoscatter.scene import Scene, load_scene, parse_time
from atmoscatter.sun import earth_sun_distance


def _toy_prepare(scene, plan):
    def evaluate(d):
        y = 1000.0 + 500.0 * d[:, 2]
        return {"Y": y} if plan.quantity == "Y" else {"XYZ": np.stack([y, y, y], -1)}

    return evaluate


@pytest.fixture(autouse=True)
def toy_models():
    register_model(ModelAdapter(name="toy", description="toy", prepare=_toy_prepare), replace=True)
    register_model(ModelAdapter(name="toy_haze", description="toy with a haze term",
                                prepare=_toy_prepare, separate_haze=True, ground_only=False,
                                spectral=True, cost_per_direction=1e-4,
                                wavelengths=lambda s: (680.0, 550.0, 440.0)), replace=True)
    yield
    unregister_model("toy")
    unregister_model("toy_haze")


def scene(**kw):
    kw.setdefault("model", "toy")
    if "time" not in kw and "sun_azimuth_deg" not in kw:
        kw.setdefault("sun_elevation_deg", 35.0)
        kw.setdefault("sun_azimuth_deg", 150.0)
    return Scene(**kw)


class TestScene:
    def test_defaults_are_a_real_place_and_time(self):
        s = Scene(model="toy")
        assert s.latitude == pytest.approx(51.4779) and s.time.startswith("2024-06-21")
        assert s.projection == "latlong" and s.sun_elevation_deg is None
        assert Scene.__dataclass_fields__["model"].default == "preetham"

    def test_frozen(self):
        with pytest.raises(AttributeError):
            scene().turbidity = 3.0  # type: ignore[misc]

    def test_strings_are_coerced(self):
        s = Scene.from_dict({"model": "toy", "turbidity": "3.5", "width": "256", "alpha": "true",
                             "sun_elevation_deg": "12", "exposure": ""})
        assert s.turbidity == 3.5 and s.width == 256 and s.alpha is True
        assert s.sun_elevation_deg == 12.0 and s.exposure is None

    def test_replace_from_strings(self):
        s = scene().replace_from_strings(["turbidity=4", "projection=fisheye", "sun_disc=yes"])
        assert (s.turbidity, s.projection, s.sun_disc) == (4.0, "fisheye", True)
        with pytest.raises(ValueError, match="key=value"):
            scene().replace_from_strings(["turbidity"])

    def test_unknown_field_lists_valid_fields(self):
        with pytest.raises(ValueError, match="unknown scene field 'turbidty'.*turbidity"):
            Scene.from_dict({"model": "toy", "turbidty": 3})

    @pytest.mark.parametrize("field,value,match", [
        ("turbidity", 0.5, r"turbidity must be in \[1, inf\)"),
        ("turbidity", float("nan"), "turbidity must be finite"),
        ("turbidity", "abc", "turbidity must be a number"),
        ("latitude", 91.0, r"latitude must be in \[-90, 90\]"),
        ("projection", "mercator", "projection='mercator' is not valid"),
        ("width", 0, r"width must be in \[1, 65536\]"),
        ("width", 2.5, "width must be an integer"),
        ("time", "yesterday", "ISO 8601"),
        ("model", "nope", "model='nope' is not valid; choose one of"),
        ("altitude", -1.0, r"altitude must be in \[0, inf\)"),
        ("ground_albedo", 1.5, r"ground_albedo must be in \[0, 1\]"),
        ("colourspace", "sRGBB", "colourspace='sRGBB' is not valid"),
        ("alpha", "maybe", "alpha must be true/false"),
        ("sun_elevation_deg", 95.0, r"sun_elevation_deg must be in \[-90, 90\]"),
        ("orders", 0, r"orders must be in \[1, 1000\]"),
        ("longitude", 400.0, r"longitude must be in \[-360, 360\]"),
    ])
    def test_bad_values_name_field_and_range(self, field, value, match):
        with pytest.raises(ValueError, match=match):
            Scene.from_dict({"model": "toy", field: value})

    def test_azimuth_needs_elevation(self):
        with pytest.raises(ValueError, match="sun_azimuth_deg was given without sun_elevation_deg"):
            Scene(model="toy", sun_azimuth_deg=100.0)

    def test_elevation_alone_defaults_azimuth_south(self):
        zen, azi, src = Scene(model="toy", sun_elevation_deg=30.0).sun_angles()
        assert zen == pytest.approx(math.radians(60.0)) and azi == pytest.approx(math.pi)
        assert "given" in src

    def test_sun_direction_frame(self):
        # azimuth 90 deg (east), elevation 0: +x
        d = scene(sun_elevation_deg=0.0, sun_azimuth_deg=90.0).sun_direction()
        np.testing.assert_allclose(d, [1.0, 0.0, 0.0], atol=1e-15)

    def test_no_time_no_sun_is_an_error(self):
        with pytest.raises(ValueError, match="needs either a time"):
            Scene(model="toy", time="")

    def test_to_strings_has_every_field(self):
        st = Scene(model="toy", turbidity=3.0).to_strings()
        assert set(st) == set(Scene.field_names())
        assert st["turbidity"] == "3.0" and st["sun_elevation_deg"] == ""
        assert all(isinstance(v, str) for v in st.values())
        # round trip through strings (as EXR headers and CSV cells carry them)
        assert Scene.from_dict(st) == Scene(model="toy", turbidity=3.0)
        s2 = scene(alpha=True, exposure=2e-4)
        assert Scene.from_dict(s2.to_strings()) == s2


class TestFiles:
    def test_toml(self, tmp_path):
        p = tmp_path / "s.toml"
        p.write_text('model = "toy"\nturbidity = 4.0\nwidth = 64\nheight = 32\nsun_disc = true\n')
        s = load_scene(p)
        assert (s.turbidity, s.width, s.sun_disc) == (4.0, 64, True)

    def test_toml_scene_table(self, tmp_path):
        p = tmp_path / "s.toml"
        p.write_text('[scene]\nmodel = "toy"\ntime = 2024-03-20T12:00:00Z\n')
        assert load_scene(p).time.startswith("2024-03-20T12:00:00")

    def test_json(self, tmp_path):
        p = tmp_path / "s.json"
        p.write_text(json.dumps({"model": "toy", "sun_elevation_deg": 10, "sun_azimuth_deg": 200}))
        assert load_scene(p).sun_azimuth_deg == 200.0

    def test_errors_name_the_file(self, tmp_path):
        p = tmp_path / "bad.toml"
        p.write_text('model = "toy"\nturbidity = -3\n')
        with pytest.raises(ValueError, match=r"bad.toml: turbidity"):
            load_scene(p)
        p.write_text("model = = \n")
        with pytest.raises(ValueError, match="not valid TOML"):
            load_scene(p)
        with pytest.raises(ValueError, match="does not exist"):
            load_scene(tmp_path / "missing.toml")
        (tmp_path / "x.yaml").write_text("")
        with pytest.raises(ValueError, match="expected a .toml or .json"):
            load_scene(tmp_path / "x.yaml")


class TestTime:
    def test_parse(self):
        utc = dt.timezone.utc
        assert parse_time("2024-06-21T09:00:00Z") == dt.datetime(2024, 6, 21, 9, tzinfo=utc)
        assert parse_time("2024-06-21T11:00:00+02:00") == dt.datetime(2024, 6, 21, 9, tzinfo=utc)
        # naive = UTC (documented)
        assert parse_time("2024-06-21T09:00") == dt.datetime(2024, 6, 21, 9, tzinfo=utc)

    @pytest.mark.parametrize("date,expected", [
        # perihelion 2024-01-03: 0.98331 AU; aphelion 2024-07-05: 1.01673 AU
        # (US Naval Observatory, Earth's seasons and apsides 2024)
        ("2024-01-03T00:00Z", 0.98331),
        ("2024-07-05T00:00Z", 1.01673),
    ])
    def test_earth_sun_distance(self, date, expected):
        assert float(earth_sun_distance(parse_time(date))) == pytest.approx(expected, abs=3e-5)


class TestPlan:
    def test_default_plan(self):
        p = plan(scene(sun_elevation_deg=40.0, sun_azimuth_deg=120.0))
        assert isinstance(p, Plan)
        assert p.quantity == "XYZ" and p.layers == ("RGB",) and p.chromaticity
        assert p.skip_below_horizon and not p.sun_disc and not p.symmetry  # toy is cheap
        assert p.sun_zenith == pytest.approx(math.radians(50.0))
        np.testing.assert_allclose(p.sun_direction, scene(
            sun_elevation_deg=40.0, sun_azimuth_deg=120.0).sun_direction(), atol=1e-15)

    def test_luminance_only(self):
        p = plan(scene(output="luminance"))
        assert p.quantity == "Y" and p.layers == ("Y",) and not p.chromaticity
        p = plan(scene(model="toy_haze", output="luminance"))
        assert p.spectral_integration == "Y only"

    def test_no_haze_at_turbidity_one(self):
        assert not plan(scene(model="toy_haze", turbidity=1.0)).haze
        assert plan(scene(model="toy_haze", turbidity=1.5)).haze

    def test_elevated_observer_integrates_below_horizon(self):
        assert plan(scene(model="toy_haze", altitude=0.0)).skip_below_horizon
        assert not plan(scene(model="toy_haze", altitude=12000.0)).skip_below_horizon
        # a ground-only model keeps skipping (it is undefined below the horizon)
        assert plan(scene(model="toy", altitude=12000.0)).skip_below_horizon

    def test_symmetry_choice(self):
        assert plan(scene(model="toy_haze")).symmetry  # expensive model: auto uses it
        assert not plan(scene(model="toy_haze", symmetry="off")).symmetry
        assert plan(scene(model="toy", symmetry="on")).symmetry

    def test_spectral_output_needs_spectral_model(self):
        with pytest.raises(ValueError, match="needs a spectral model"):
            plan(scene(output="spectral"))
        p = plan(scene(model="toy_haze", output="spectral"))
        assert p.quantity == "spectral" and "spectral" in p.layers

    def test_alpha_layer_and_sun_disc(self):
        p = plan(scene(alpha=True, sun_disc=True))
        assert p.layers == ("RGB", "A") and p.sun_disc

    def test_explain_and_json(self):
        p = plan(scene(model="toy_haze", turbidity=1.0, output="luminance"))
        text = p.explain()
        assert "haze term        : skipped" in text and "chromaticity     : skipped" in text
        assert "not evaluated" in text and "sun disc         : skipped" in text
        d = json.loads(p.to_json())
        assert d["haze"] is False and d["quantity"] == "Y" and d["model"] == "toy_haze"

    def test_explain_states_the_numerics_of_the_physical_models(self):
        """--explain says how many scattering orders multiple scattering sums (automatic
        or fixed) and on which grid, and the model's accuracy statement for the scene."""
        from atmoscatter.render import get_model
        from atmoscatter.sky.multiple import MULTIPLE_SCATTERING_GRID

        sc = Scene(model="multiple_scattering", sun_elevation_deg=5.0, width=8, height=4)
        text = plan(sc).explain()
        assert "numerics         : all scattering orders" in text
        assert f"n_phi {MULTIPLE_SCATTERING_GRID.n_phi}" in text
        assert "accuracy         : " + get_model("multiple_scattering").error_estimate(sc) in text
        assert "sun 0–10° above the horizon" in text  # the regime of a 5° sun
        fixed = plan(Scene(model="multiple_scattering", orders=3, width=8, height=4)).explain()
        assert "3 scattering orders (fixed)" in fixed
        ss = plan(Scene(model="single_scattering", width=8, height=4))
        assert "'graded'" in ss.numerics and "table" in ss.numerics
        assert plan(Scene(width=8, height=4)).numerics == ""  # analytic: nothing to state
        assert json.loads(plan(sc).to_json())["numerics"] == plan(sc).numerics

    def test_bad_batch_size(self):
        with pytest.raises(ValueError, match="batch_size"):
            plan(scene(), batch_size=0)

    def test_flat_api(self):
        assert ac.Scene is Scene and ac.plan is plan and ac.load_scene is load_scene


@pytest.mark.parametrize("fields, match", [
    ({"method": "graded"}, "only applies to model='single_scattering'"),
    ({"model": "multiple_scattering", "method": "graded"}, "only applies"),
    ({"model": "single_scattering", "method": "bogus"}, "method='bogus' is not valid"),
])
def test_method_is_an_effect_or_an_error(fields, match):
    """issue 12: ``method`` used to be accepted and silently ignored by every model but
    single_scattering."""
    with pytest.raises(ValueError, match=match):
        Scene(**fields)
    assert Scene(model="single_scattering", method="midpoint").method == "midpoint"

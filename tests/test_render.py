"""The renderer follows the plan: skipped work is not done, memory stays bounded,
physical models come out in absolute units."""

import dataclasses
import importlib
import math
import tracemalloc

import numpy as np
import pytest
from scipy import integrate

import atmoscatter as ac
from atmoscatter.colour import K_M
from atmoscatter.render import (
    ModelAdapter,
    physical_adapter,
    plan,
    register_model,
    rgb_sampling_matrix,
    unregister_model,
)
from atmoscatter.render.photometry import FINE_GRID
from atmoscatter.scene import Scene
from atmoscatter.solar import solar_spectrum_table

render_mod = importlib.import_module("atmoscatter.render.evaluate")
CALLS = []


def toy_luminance(d, sun):
    """A horizontally uniform toy sky [cd m^-2]: depends on z and the angle to the sun."""
    c = d @ sun
    return 2000.0 + 3000.0 * c**2 + 1000.0 * d[:, 2]


def _toy_prepare(scene, plan):
    sun = plan.sun_direction

    def evaluate(d):
        CALLS.append((plan.quantity, len(d), float(d[:, 2].min()) if len(d) else 1.0))
        y = toy_luminance(d, sun)
        if plan.quantity == "Y":
            return {"Y": y}
        return {"XYZ": np.stack([0.9505 * y, y, 1.089 * y], -1)}

    return evaluate


@pytest.fixture(autouse=True)
def toy_models():
    CALLS.clear()
    register_model(ModelAdapter(name="toy", description="toy", prepare=_toy_prepare), replace=True)
    register_model(ModelAdapter(name="toy_slow", description="toy, declared expensive",
                                prepare=_toy_prepare, cost_per_direction=1e-4,
                                ground_only=False), replace=True)
    yield
    unregister_model("toy")
    unregister_model("toy_slow")


def scene(**kw):
    kw.setdefault("model", "toy")
    kw.setdefault("sun_elevation_deg", 35.0)
    kw.setdefault("sun_azimuth_deg", 150.0)
    kw.setdefault("width", 64)
    kw.setdefault("height", 32)
    return Scene(**kw)


def n_evaluated():
    return sum(n for _, n, _ in CALLS)


class TestPlanIsFollowed:
    def test_below_horizon_not_evaluated(self):
        s = scene()
        img = ac.render(s, workers=1)
        # rows 0..15 of 32 are above the horizon: exactly those directions reach the model
        assert n_evaluated() == 16 * 64
        assert all(zmin >= 0 for _, _, zmin in CALLS)
        assert np.all(img.rgb[16:] == 0.0) and np.all(img.alpha[16:] == 0.0)
        assert np.all(img.alpha[:16] == 1.0)

    def test_elevated_observer_evaluates_below_horizon(self):
        ac.render(scene(model="toy_slow", altitude=5000.0, symmetry="off"), workers=1)
        assert n_evaluated() == 32 * 64

    def test_values_match_model(self):
        s = scene()
        img = ac.render(s)
        d = img.directions[:16]
        y = toy_luminance(d.reshape(-1, 3), s.sun_direction()).reshape(16, 64)
        np.testing.assert_allclose(img.luminance[:16], y, rtol=1e-6)
        rgb = ac.XYZ_to_linear_rgb(np.stack([0.9505 * y, y, 1.089 * y], -1))
        np.testing.assert_allclose(img.rgb[:16], rgb, rtol=1e-5)
        assert img.rgb.dtype == np.float32

    def test_luminance_only_asks_for_Y(self):
        img = ac.render(scene(output="luminance"))
        assert {q for q, _, _ in CALLS} == {"Y"}
        assert img.rgb is None and img.xyz is None and img.luminance.shape == (32, 64)

    def test_xyz_output(self):
        img = ac.render(scene(output="xyz"))
        assert img.xyz.shape == (32, 64, 3)
        np.testing.assert_allclose(img.luminance, img.xyz[..., 1])

    def test_mirror_symmetry_halves_the_work(self):
        # sun azimuth 0: the latlong columns are mirror images of each other
        s_off = scene(sun_azimuth_deg=0.0, symmetry="off")
        ref = ac.render(s_off)
        n_off = n_evaluated()
        CALLS.clear()
        img = ac.render(scene(sun_azimuth_deg=0.0, symmetry="on"))
        n_on = n_evaluated()
        assert n_off == 16 * 64 and n_on == 16 * 32
        np.testing.assert_allclose(img.rgb, ref.rgb, rtol=1e-6)

    def test_dome_is_symmetric_for_any_sun(self):
        s = scene(projection="dome", width=24, height=8, sun_azimuth_deg=137.0)
        ref = ac.render(s.replace_from_strings(["symmetry=off"]))
        n_off = n_evaluated()
        CALLS.clear()
        img = ac.render(s.replace_from_strings(["symmetry=on"]))
        assert n_evaluated() < 0.6 * n_off
        np.testing.assert_allclose(img.rgb, ref.rgb, rtol=1e-6)
        assert img.faces is not None and img.shape == (len(img.directions),)

    def test_no_sun_disc_work_when_not_drawn(self, monkeypatch):
        def boom(*a, **k):
            raise AssertionError("sun disc evaluated although not drawn")

        monkeypatch.setattr(render_mod, "sun_disc_radiance", boom)
        ac.render(scene(sun_disc=False))
        with pytest.raises(AssertionError, match="sun disc evaluated"):
            ac.render(scene(sun_disc=True))

    def test_fisheye_outside_circle_not_evaluated(self):
        s = scene(projection="fisheye", width=40, height=40)
        img = ac.render(s)
        valid = img.directions_set.all_valid()
        assert n_evaluated() == int(valid.sum())
        assert np.all(img.alpha[~valid] == 0)

    def test_threads_give_identical_results(self):
        s = scene(width=128, height=64)
        a = ac.render(s, workers=1, batch_size=300)
        b = ac.render(s, workers=3, batch_size=300)
        np.testing.assert_array_equal(a.rgb, b.rgb)

    def test_render_rejects_bad_directions(self):
        with pytest.raises(ValueError, match="finite unit vectors"):
            ac.render(scene(), directions=np.array([[0.0, 0.0, 2.0]]))
        with pytest.raises(ValueError, match="finite unit vectors"):
            ac.render(scene(), directions=np.array([[np.nan, 0.0, 1.0]]))

    def test_render_given_directions(self):
        d = np.array([[0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [0.0, -1.0, 0.0]])
        img = ac.render(scene(), directions=d)
        np.testing.assert_allclose(img.luminance, toy_luminance(d, scene().sun_direction()),
                                   rtol=1e-6)


class TestGround:
    def test_ground_value_is_lambertian_under_the_model_sky(self):
        s = scene(ground_albedo=0.3)
        img = ac.render(s)
        sun = s.sun_direction()

        def integrand(phi, theta):
            d = np.array([[math.sin(theta) * math.sin(phi), math.sin(theta) * math.cos(phi),
                           math.cos(theta)]])
            return toy_luminance(d, sun)[0] * math.cos(theta) * math.sin(theta)

        e_h, _ = integrate.dblquad(integrand, 0, math.pi / 2, 0, 2 * math.pi, epsabs=1e-6)
        # plus the direct beam: transmitted disc radiance integrated over the disc, times cos
        y_c, alpha, _ = ac.sun_disc_radiance(s)
        e_sun = y_c[1] * (1 - ac.LIMB_DARKENING_U / 3) * 2 * math.pi * (1 - math.cos(alpha))
        e_h += e_sun * math.sin(math.radians(35.0))
        expected = 0.3 * e_h / math.pi
        np.testing.assert_allclose(img.luminance[20:], expected, rtol=1e-6)
        assert np.all(img.alpha[20:] == 0)


class TestSunDisc:
    def test_disc_energy_and_limb_darkening(self):
        s = scene(model="toy", sun_disc=True, sun_elevation_deg=40.0, projection="latlong",
                  width=3072, height=1536, output="luminance")
        p = plan(s)
        y_c, alpha, _ = ac.sun_disc_radiance(s, p)
        with_disc = ac.render(s)
        without = ac.render(s.replace_from_strings(["sun_disc=false"]))
        diff = (with_disc.luminance - without.luminance).ravel().astype(float)
        om = with_disc.directions_set.solid_angles(0, with_disc.directions_set.size)
        omega_sun = 2 * math.pi * (1 - math.cos(alpha))
        # illuminance of the disc = L_centre * (1 - u/3) * Omega_sun (pixels resolve it)
        expected = y_c[1] * (1 - ac.LIMB_DARKENING_U / 3) * omega_sun
        assert (diff * om).sum() == pytest.approx(expected, rel=0.05)
        # the brightest pixel: limb darkening 1 - u (1 - mu) at its distance from the centre
        i = int(np.argmax(diff))
        d = with_disc.directions_set.directions(i, i + 1)[0][0]
        rho = math.acos(min(1.0, float(d @ p.sun_direction))) / alpha
        ld = 1 - ac.LIMB_DARKENING_U * (1 - math.sqrt(1 - rho**2))
        assert diff[i] == pytest.approx(y_c[1] * ld, rel=1e-5)

    def test_small_disc_energy_goes_to_nearest_pixel(self):
        s = scene(sun_disc=True, width=64, height=32, output="luminance")
        img = ac.render(s)
        base = ac.render(s.replace_from_strings(["sun_disc=false"]))
        diff = (img.luminance - base.luminance).ravel().astype(float)
        om = img.directions_set.solid_angles(0, img.directions_set.size)
        y_c, alpha, _ = ac.sun_disc_radiance(s)
        expected = y_c[1] * (1 - ac.LIMB_DARKENING_U / 3) * 2 * math.pi * (1 - math.cos(alpha))
        assert np.count_nonzero(diff) == 1
        assert (diff * om).sum() == pytest.approx(expected, rel=1e-5)

    def test_disc_never_changes_the_models_arrays(self):
        # the disc is added to a copy (made only for batches that contain it), so a model
        # that hands out the same array every call is left intact
        held = {}

        def prepare(sc, p):
            def evaluate(d):
                held.setdefault("xyz", np.full((len(d), 3), 1000.0))
                return {"XYZ": held["xyz"][: len(d)]}
            return evaluate

        register_model(ModelAdapter(name="toy_held", description="x", prepare=prepare),
                       replace=True)
        try:
            s = scene(model="toy_held", sun_disc=True, sun_elevation_deg=40.0,
                      projection="latlong", width=1024, height=512)
            img = ac.render(s, batch_size=4096, workers=1)
        finally:
            unregister_model("toy_held")
        assert np.all(held["xyz"] == 1000.0)
        assert img.rgb.max() > 1e6  # the disc was drawn

    def test_transmittance_is_physical(self):
        # clear, high sun: the direct beam at the ground is ~ 0.7-0.9 of the ETR at 550 nm
        s = scene(sun_elevation_deg=60.0, turbidity=2.0)
        _, alpha, (wl, L) = ac.sun_disc_radiance(s)
        omega = 2 * math.pi * (1 - math.cos(alpha))
        e_ground = L * omega * (1 - ac.LIMB_DARKENING_U / 3)
        e_top = np.interp(wl, *solar_spectrum_table()) / plan(s).distance_au**2
        t550 = np.interp(550.0, wl, e_ground / e_top)
        assert 0.6 < t550 < 0.95
        # sun below the horizon: no direct beam
        xyz, _, _ = ac.sun_disc_radiance(scene(sun_elevation_deg=-2.0))
        assert np.all(xyz == 0)


class TestMemory:
    def test_8k_latlong_streams_in_bounded_memory(self):
        s = scene(width=8192, height=4096, output="luminance")
        p = plan(s, batch_size=8192 * 8)
        tracemalloc.start()
        total = 0
        try:
            for start, stop, b in ac.render_batches(s, plan=p):
                assert stop - start <= p.batch_size
                assert b["values"].shape == (stop - start, 1)
                total += stop - start
            _, peak = tracemalloc.get_traced_memory()
        finally:
            tracemalloc.stop()
        assert total == 8192 * 4096
        # the whole map would be 32M directions (>= 800 MB as float64 vectors);
        # a batch of 65536 directions needs a few MB
        assert peak < 40e6, peak
        # only the upper half reached the model
        assert n_evaluated() == 8192 * 2048

    def test_render_peak_is_output_plus_a_bound(self):
        def peak_of(w, h):
            s = scene(width=w, height=h, output="luminance")
            tracemalloc.start()
            try:
                ac.render(s, batch_size=16384, workers=2)
                return tracemalloc.get_traced_memory()[1]
            finally:
                tracemalloc.stop()

        small, big = peak_of(512, 256), peak_of(2048, 1024)
        out_small, out_big = 512 * 256 * 4 * 2, 2048 * 1024 * 4 * 2  # Y + alpha, float32
        # overhead beyond the output does not grow with the resolution
        assert (big - out_big) < (small - out_small) + 5e6
        assert big - out_big < 20e6


class TestSkyImage:
    def test_to_numpy_and_xarray(self):
        img = ac.render(scene(output="xyz", alpha=True))
        arrays = img.to_numpy()
        assert set(arrays) >= {"directions", "luminance", "rgb", "xyz", "alpha"}
        xr = pytest.importorskip("xarray")
        ds = img.to_xarray()
        assert isinstance(ds, xr.Dataset)
        assert ds["rgb"].shape == (32, 64, 3) and ds.attrs["turbidity"] == "2.5"

    def test_metadata(self):
        img = ac.render(scene(turbidity=3.0))
        md = img.metadata
        assert md["atmoscatter:package"] == "atmoscatter"
        assert md["atmoscatter:version"] == ac.__version__
        assert md["turbidity"] == "3.0" and md["model"] == "toy"
        assert '"skip_below_horizon": true' in md["atmoscatter:plan"]
        assert md["atmoscatter:error_estimate"]


# ---------------------------------------------------------------------------
# physical adapter, with a fake per-irradiance model (the real one is tested in its issue)
# ---------------------------------------------------------------------------
class FakePhysical:
    """Records the atmosphere it receives and returns a chosen f(lambda) [sr^-1]."""

    def __init__(self, law):
        self.law = law
        self.atmospheres = []
        self.sizes = []

    def __call__(self, atmosphere, view_directions, sun_direction, *, altitude=0.0, method=None,
                 rtol=None):
        self.atmospheres.append(atmosphere)
        self.sizes.append(len(view_directions))
        wl = atmosphere.wavelengths_array
        return np.broadcast_to(self.law(wl), view_directions.shape[:-1] + (wl.size,)).copy()


@pytest.fixture
def fake_single(monkeypatch):
    previous = ac.MODELS.get("single_scattering")

    def install(law):
        fake = FakePhysical(law)
        monkeypatch.setattr(ac, "single_scattering", fake, raising=False)
        register_model(physical_adapter("single_scattering"), replace=True)
        return fake

    yield install
    unregister_model("single_scattering")
    if previous is not None:  # put the real adapter back for the rest of the session
        register_model(previous)


def _independent_xyz(f_of_lambda, distance_au):
    """K_m ∫ f(λ) E(λ) cmf(λ) dλ on the 1 nm CIE table (colour-science) and the raw ETR."""
    import colour

    cmfs = colour.MSDS_CMFS["CIE 1931 2 Degree Standard Observer"]
    wl = np.arange(380.0, 781.0)
    cm = np.stack([np.interp(wl, cmfs.wavelengths, cmfs.values[:, i]) for i in range(3)], -1)
    e = np.interp(wl, *solar_spectrum_table()) / distance_au**2
    return K_M * np.trapezoid(f_of_lambda(wl)[:, None] * e[:, None] * cm, wl, axis=0)


class TestPhysicalAdapter:
    def test_no_haze_constituent_at_turbidity_one(self, fake_single):
        fake = fake_single(lambda wl: 1e-2 * (550.0 / wl) ** 4)
        ac.render(scene(model="single_scattering", turbidity=1.0, width=16, height=8))
        assert fake.atmospheres and all(
            "mie" not in [c.name for c in a.constituents] for a in fake.atmospheres)
        fake.atmospheres.clear()
        ac.render(scene(model="single_scattering", turbidity=3.0, width=16, height=8))
        assert "mie" in [c.name for c in fake.atmospheres[0].constituents]

    def test_spectral_sampling_absolute_units(self, fake_single):
        law = lambda wl: 0.02 * (550.0 / wl) ** 4  # noqa: E731
        fake_single(law)
        s = scene(model="single_scattering", sampling="spectral", wavelength_step=5.0,
                  output="xyz", width=8, height=4, time="2024-01-03T12:00:00Z")
        img = ac.render(s)
        expected = _independent_xyz(law, plan(s).distance_au)
        np.testing.assert_allclose(img.xyz[0, 0], expected, rtol=2e-3)

    def test_rgb_sampling_power_law_is_exact(self, fake_single):
        law = lambda wl: 0.02 * (550.0 / wl) ** 4  # noqa: E731
        fake = fake_single(law)
        s = scene(model="single_scattering", output="xyz", width=8, height=4)
        img = ac.render(s)
        assert fake.atmospheres[0].n_wavelengths == 3  # only the three RGB samples
        expected = _independent_xyz(law, plan(s).distance_au)
        np.testing.assert_allclose(img.xyz[0, 0], expected, rtol=2e-3)

    def test_luminance_only_matches_Y(self, fake_single):
        fake_single(lambda wl: 0.01 * (550.0 / wl) ** 2)
        s = scene(model="single_scattering", width=8, height=4)
        y = ac.render(s.replace_from_strings(["output=luminance"])).luminance
        xyz = ac.render(s.replace_from_strings(["output=xyz"])).xyz
        np.testing.assert_allclose(y, xyz[..., 1], rtol=1e-6)

    def test_spectral_layers(self, fake_single):
        law = lambda wl: 0.01 * np.ones_like(wl)  # noqa: E731
        fake_single(law)
        s = scene(model="single_scattering", output="spectral", wavelength_step=20.0,
                  width=8, height=4)
        img = ac.render(s)
        assert img.spectral.shape == (4, 8, 21)
        assert img.wavelengths[0] == 380.0 and img.wavelengths[-1] == 780.0
        # radiance = f * band-averaged ETR
        assert np.all(img.spectral[0, 0] > 0)
        np.testing.assert_allclose(img.spectral[0, 0, 8], 0.01 * np.mean(
            np.interp(np.linspace(530, 550, 2001), *solar_spectrum_table())) /
            plan(s).distance_au**2, rtol=2e-3)

    def test_symmetry_used_for_expensive_model(self, fake_single):
        fake = fake_single(lambda wl: 0.01 * (550.0 / wl) ** 4)
        s = scene(model="single_scattering", projection="dome", width=24, height=6)
        img = ac.render(s)
        assert plan(s).symmetry
        assert sum(fake.sizes) < 0.6 * img.directions_set.size


def test_multiple_scattering_adapter_passes_orders_and_albedo(monkeypatch):
    seen = []

    def fake(atmosphere, view_directions, sun_direction, **kw):
        seen.append(kw)
        return np.full(view_directions.shape[:-1] + (atmosphere.n_wavelengths,), 1e-2)

    previous = ac.MODELS.get("multiple_scattering")
    monkeypatch.setattr(ac, "multiple_scattering", fake, raising=False)
    register_model(physical_adapter("multiple_scattering"), replace=True)
    try:
        s = scene(model="multiple_scattering", orders=3, ground_albedo=0.25, altitude=100.0,
                  width=8, height=4)
        ac.render(s)
        assert seen[0] == {"altitude": 100.0, "ground_albedo": 0.25, "orders": 3,
                           "grid": ac.MULTIPLE_SCATTERING_GRID}  # Scene.ms_grid unset
        seen.clear()
        ac.render(dataclasses.replace(s, orders=None))  # None: the function's default
        assert "orders" not in seen[0]
    finally:
        unregister_model("multiple_scattering")
        if previous is not None:
            register_model(previous)


class TestCustomAtmosphere:
    def _atm(self, wl=(680.0, 550.0, 440.0)):
        wl = np.asarray(wl)
        ray = ac.Constituent("rayleigh", ac.rayleigh_scattering(wl), 0.0,
                             ac.ExponentialProfile(8000.0), ac.RayleighPhase())
        empty = ac.Constituent("dust", np.zeros(wl.size), 0.0, ac.ExponentialProfile(1000.0),
                               ac.HenyeyGreensteinPhase(0.7))
        return ac.Atmosphere(6.36e6, 6.42e6, tuple(wl), (ray, empty), name="my_air")

    def test_custom_atmosphere_reaches_the_model(self, fake_single):
        fake = fake_single(lambda wl: 0.02 * (550.0 / wl) ** 4)
        atm = self._atm()
        s = scene(model="single_scattering", width=8, height=4, output="xyz")
        p = plan(s, atmosphere=atm)
        assert p.wavelengths == (680.0, 550.0, 440.0) and not p.haze
        assert any("custom atmosphere 'my_air'" in n for n in p.notes)
        assert p.to_dict()["atmosphere"] == "my_air"
        img = ac.render(s, atmosphere=atm)
        # the empty constituent is dropped, the rest is the user's atmosphere
        assert [c.name for c in fake.atmospheres[0].constituents] == ["rayleigh"]
        assert fake.atmospheres[0].wavelengths == atm.wavelengths
        expected = _independent_xyz(lambda wl: 0.02 * (550.0 / wl) ** 4, p.distance_au)
        np.testing.assert_allclose(img.xyz[0, 0], expected, rtol=2e-3)
        assert "my_air" in img.metadata["atmoscatter:custom_atmosphere"]

    def test_spectral_custom_atmosphere_and_sun_disc(self, fake_single):
        fake_single(lambda wl: 0.01 * np.ones_like(wl))
        atm = self._atm(np.arange(380.0, 781.0, 20.0))
        s = scene(model="single_scattering", width=64, height=32, sun_disc=True,
                  output="luminance")
        img = ac.render(s, atmosphere=atm)
        assert np.isfinite(img.luminance).all() and img.luminance.max() > 1e5  # the disc

    def test_only_physical_models_take_one(self):
        with pytest.raises(ValueError, match="physical models only"):
            plan(scene(), atmosphere=self._atm())

    def test_atmosphere_file_in_a_scene_file(self, tmp_path, fake_single):
        # a scene file may name a custom atmosphere file (relative to the scene file); the
        # plan then loads it and the model receives exactly that atmosphere
        import json

        fake = fake_single(lambda wl: 0.02 * (550.0 / wl) ** 4)
        atm = self._atm()
        (tmp_path / "air.json").write_text(json.dumps(ac.atmosphere_to_dict(atm)))
        (tmp_path / "scene.toml").write_text(
            'model = "single_scattering"\natmosphere = "air.json"\nwidth = 8\nheight = 4\n'
            'output = "xyz"\nsun_elevation_deg = 30.0\nsun_azimuth_deg = 90.0\n')
        s = ac.load_scene(tmp_path / "scene.toml")
        assert s.atmosphere == str(tmp_path / "air.json")
        from_file = ac.render(s)
        direct = ac.render(dataclasses.replace(s, atmosphere="earth"), atmosphere=atm)
        np.testing.assert_array_equal(from_file.xyz, direct.xyz)
        assert [c.name for c in fake.atmospheres[0].constituents] == ["rayleigh"]
        with pytest.raises(ValueError, match="atmosphere file .* does not exist"):
            ac.load_scene(overrides={"atmosphere": str(tmp_path / "nope.toml")})
        with pytest.raises(ValueError, match="physical models only"):
            ac.render(dataclasses.replace(s, model="preetham"))


def test_rgb_sampling_matrix_reproduces_power_laws():
    lam = np.array([680.0, 550.0, 440.0])
    A = rgb_sampling_matrix(lam)
    for p in (-4.0, -1.3, 0.0, 2.0):
        np.testing.assert_allclose(np.exp(np.log(lam**p) @ A), FINE_GRID**p, rtol=1e-10)


@pytest.mark.skipif("preetham" not in ac.MODELS, reason="preetham_sky has not landed")
def test_default_scene_renders_preetham():
    s = Scene(width=64, height=32)
    img = ac.render(s)
    assert img.metadata["model"] == "preetham"
    sky = img.luminance[:16]
    assert np.all(np.isfinite(sky)) and np.all(sky > 0)
    # a clear sky is bluer than white at the zenith (B > R in linear sRGB)
    assert img.rgb[0, 0, 2] > img.rgb[0, 0, 0]


# ---------------------------------------------------------------------------
# the real analytic adapters (skipped where a model has not landed)
# ---------------------------------------------------------------------------
def _needs(*names):
    return pytest.mark.skipif(any(n not in ac.MODELS for n in names),
                              reason=f"needs {names}")


ZENITH = np.array([[0.0, 0.0, 1.0]])


@_needs("preetham")
class TestPreethamAdapter:
    @pytest.mark.parametrize("T,elev", [(2.0, 60.0), (3.0, 30.0), (6.0, 10.0)])
    def test_zenith_luminance_is_Yz(self, T, elev):
        # errata 003.3 (Preetham 1999 App. A.2): Y_z in kcd m^-2
        theta_s = math.radians(90.0 - elev)
        chi = (4.0 / 9.0 - T / 120.0) * (math.pi - 2.0 * theta_s)
        y_z = 1000.0 * ((4.0453 * T - 4.9710) * math.tan(chi) - 0.2155 * T + 2.4192)
        s = Scene(turbidity=T, sun_elevation_deg=elev, sun_azimuth_deg=200.0, output="xyz")
        img = ac.render(s, directions=ZENITH)
        assert img.xyz[0, 1] == pytest.approx(y_z, rel=1e-6)

    def test_luminance_only_never_evaluates_chromaticity(self, monkeypatch):
        s = Scene(turbidity=3.0, sun_elevation_deg=35.0, sun_azimuth_deg=140.0, width=64,
                  height=32)
        ref = ac.render(s.replace_from_strings(["output=xyz"]))

        def no_xyz(*a, **k):
            raise AssertionError("preetham_sky (Y, x and y) called for a luminance-only scene")

        monkeypatch.setattr(ac, "preetham_sky", no_xyz)
        lum = ac.render(s.replace_from_strings(["output=luminance"]))
        np.testing.assert_allclose(lum.luminance[:16], ref.xyz[:16, :, 1], rtol=1e-5)
        with pytest.raises(AssertionError, match="luminance-only"):
            ac.render(s)

    def test_plan_notes_turbidity_outside_fit(self):
        text = plan(Scene(turbidity=12.0, sun_elevation_deg=30.0)).explain()
        assert "outside preetham's fit range 2-10" in text


@_needs("cie_overcast", "cie_clear")
class TestCieAdapters:
    def test_overcast_zenith_is_krochmann(self):
        # Krochmann (1963): Y_z = 123 + 8600 sin(h) cd m^-2; colour D65 (x, y)
        s = Scene(model="cie_overcast", sun_elevation_deg=30.0, output="xyz")
        xyz = ac.render(s, directions=ZENITH).xyz[0]
        assert xyz[1] == pytest.approx(123.0 + 8600.0 * 0.5, rel=1e-6)
        assert xyz[0] / xyz.sum() == pytest.approx(0.3127, abs=1e-6)
        # (1 + 2 cos theta)/3 at the horizon: a third of the zenith value
        horizon = ac.render(s, directions=np.array([[0.0, 1.0, 0.0]])).xyz[0, 1]
        assert horizon == pytest.approx(xyz[1] / 3.0, rel=1e-6)

    def test_clear_is_luminance_distribution(self):
        s = Scene(model="cie_clear", sun_elevation_deg=40.0, sun_azimuth_deg=90.0, width=64,
                  height=32)
        img = ac.render(s)
        rgb = img.rgb[:16]
        np.testing.assert_allclose(rgb[..., 0], rgb[..., 1], rtol=2e-3)  # D65 = sRGB white


@_needs("hoffman_preetham")
class TestHoffmanPreethamAdapter:
    def test_haze_from_turbidity_and_none_at_one(self, monkeypatch):
        seen = []
        real = ac.hoffman_preetham_sky

        airs = []

        def spy(d, sun, **kw):
            seen.append(kw["haze"])
            airs.append(kw["air_scattering"])
            return real(d, sun, **kw)

        monkeypatch.setattr(ac, "hoffman_preetham_sky", spy)
        ac.render(Scene(model="hoffman_preetham", turbidity=1.0, width=16, height=8,
                        sun_elevation_deg=30.0))
        assert seen and all(h is None for h in seen)
        seen.clear()
        airs.clear()
        ac.render(Scene(model="hoffman_preetham", turbidity=4.0, width=16, height=8,
                        sun_elevation_deg=30.0))
        # real air (Bodhaine 1999) and T = (τ_m + τ_h)/τ_m by extinction at 550 nm with the
        # model's zenith optical lengths 8400 m (air) / 1250 m (haze) (seed 000; errata
        # 004.3): β_ext,h(λ) = (T − 1) β_air(550) 8400/1250 · λ⁻² K(λ) / (550⁻² K(550)),
        # K linear 0.656 (400 nm) → 0.69 (770 nm) (seed 004), ω = 0.9, g = 0.8
        wl = np.array(ac.HOFFMAN_PREETHAM_WAVELENGTHS)
        np.testing.assert_allclose(airs[0], ac.rayleigh_scattering_standard_air(wl), rtol=1e-14)

        def k(x):
            return 0.656 + (x - 400.0) * 0.034 / 370.0

        ext = 3.0 * float(ac.rayleigh_scattering_standard_air(550.0)) * 8400.0 / 1250.0 \
            * (550.0 / wl) ** 2 * k(wl) / k(550.0)
        np.testing.assert_allclose(seen[0].scattering, 0.9 * ext, rtol=1e-12)
        np.testing.assert_allclose(seen[0].absorption, 0.1 * ext, rtol=1e-12)
        assert seen[0].g == 0.8

    def test_absolute_units_against_a_fine_spectrum(self):
        # independent: evaluate the model's own per-irradiance radiance on a 1 nm grid (three
        # wavelengths per call, via its air_scattering argument), multiply by the raw ETR and
        # integrate with the 1 nm CIE table; the adapter uses only 650/570/475 nm
        s = Scene(model="hoffman_preetham", turbidity=1.0, sun_elevation_deg=45.0,
                  sun_azimuth_deg=180.0, output="xyz", time="2024-03-20T12:00:00Z")
        d = np.array([[0.0, 0.0, 1.0], [0.0, 0.8, 0.6], [0.6, -0.8, 0.0]])
        sun = plan(s).sun_direction
        xyz = ac.render(s, directions=d).xyz
        wl = np.arange(380.0, 782.0)  # 402 = 134 triples
        f = np.concatenate([
            ac.hoffman_preetham_sky(d, sun, haze=None, sun_irradiance=np.ones(3),
                                    air_scattering=ac.rayleigh_scattering_standard_air(w))
            for w in wl.reshape(-1, 3)], axis=-1)
        import colour

        cmfs = colour.MSDS_CMFS["CIE 1931 2 Degree Standard Observer"]
        cm = np.stack([np.interp(wl, cmfs.wavelengths, cmfs.values[:, i]) for i in range(3)], -1)
        e = np.interp(wl, *solar_spectrum_table()) / plan(s).distance_au**2
        expected = K_M * np.trapezoid(f[..., None] * (e[:, None] * cm), wl, axis=1)
        # three samples expanded as a power law: measured Y within 1.2 %, Z within 4.6 %
        np.testing.assert_allclose(xyz[:, 1], expected[:, 1], rtol=0.015)
        np.testing.assert_allclose(xyz, expected, rtol=0.05)
        # spectral sampling (10 nm) removes the interpolation error
        s10 = s.replace_from_strings(["sampling=spectral", "wavelength_step=10"])
        np.testing.assert_allclose(ac.render(s10, directions=d).xyz, expected, rtol=3e-3)


def test_preetham_spectral_output_integrates_back_to_its_luminance(tmp_path):
    # output="spectral" with the Preetham sky: CIE D-series spectra (seed 004) whose
    # 683 ∫ L ȳ dλ reproduces the model's Y (independent CMF quadrature from colour-science
    # weights); with any other output no spectrum is computed at all.
    s = Scene(model="preetham", output="spectral", width=32, height=16, sun_elevation_deg=40.0,
              sun_azimuth_deg=120.0, turbidity=3.0)
    p = plan(s)
    assert p.wavelengths[0] == 380.0 and p.wavelengths[-1] == 780.0
    img = ac.render(s)
    assert img.spectral.shape == (16, 32, len(p.wavelengths))
    assert np.all(img.spectral >= 0)
    W = ac.cmf_weights(np.asarray(p.wavelengths))
    Y = K_M * (img.spectral.astype(float) @ W)[..., 1]
    sky = img.alpha > 0
    np.testing.assert_allclose(Y[sky], img.luminance[sky], rtol=1e-5)
    path = ac.write_exr(tmp_path / "spec.exr", img)
    back = ac.read_exr(path)
    assert any(k.startswith("S0.") or "nm" in k for k in back.channels)
    p_rgb = plan(dataclasses.replace(s, output="rgb"))
    assert p_rgb.wavelengths == () and p_rgb.spectral_integration == "none"


# ---------------------------------------------------------------------------
# the render path close to its kernel (issue 11): shortcuts must not change the result
# ---------------------------------------------------------------------------
@pytest.mark.parametrize("h,bs", [(32, 64), (33, 64), (32, 100), (7, 10**6)])
def test_latlong_up_range_is_that_of_its_directions(h, bs):
    from atmoscatter.render import LatLongDirections

    dset = LatLongDirections(64, h)
    for start, stop in dset.batches(bs) + [(5, 70), (64, 65)]:
        lo, hi = dset.up_range(start, stop)
        z = dset.directions(start, stop)[0][:, 2]
        assert (lo, hi) == (float(z.min()), float(z.max()))  # the same expression: exact


@pytest.mark.parametrize("kw", [
    {},  # ground below the horizon left black
    {"ground_albedo": 0.3, "alpha": True},  # (no sun disc: its pixel energy uses solid angles)
    {"output": "xyz", "ground_albedo": 0.2},
    {"height": 33, "batch_size": 100},  # batches that straddle the horizon
])
def test_latlong_shortcuts_agree_with_the_generic_path(kw):
    """A lat-long render (whole-ground batches filled without generating directions, horizon
    test skipped above it) equals the generic path (the same directions given as an array,
    whose batches are masked direction by direction).  Tolerance: float32 output of identical
    float64 values, so equal to 1 ulp of float32 (rtol 2e-7)."""
    bs = kw.pop("batch_size", 256)
    s = scene(height=kw.pop("height", 32), **kw)
    img = ac.render(s, batch_size=bs)
    ref = ac.render(s, directions=img.directions, batch_size=bs)
    for layer in ("rgb", "xyz", "alpha"):
        a, b = getattr(img, layer), getattr(ref, layer)
        assert (a is None) == (b is None)
        if a is not None:
            np.testing.assert_allclose(a, b, rtol=2e-7, atol=0, err_msg=layer)
    assert img.alpha[-1].max() == 0.0 and img.alpha[0].min() == 1.0


@pytest.mark.parametrize("workers", [1, 3])
def test_progress_callback_reports_every_batch(workers):
    s = scene(width=32, height=16)
    seen = []
    img = ac.render(s, batch_size=64, workers=workers, progress=lambda d, t: seen.append((d, t)))
    n = img.alpha.size
    assert len(seen) == len(img.directions_set.batches(64)) == n // 64
    assert all(t == n for _, t in seen)
    done = [d for d, _ in seen]
    assert done == sorted(done) and done[-1] == n


@pytest.mark.parametrize("samples, grid, match", [
    ([550.0], None, "at least 2"),
    ([450.0, 0.0, 650.0], None, "sample_wavelengths must be positive"),
    ([450.0, np.nan], None, "sample_wavelengths must be positive"),
    ([450.0, 550.0, 550.0], None, "distinct"),
    ([450.0, 650.0], [500.0, -1.0], "grid must be positive"),
])
def test_rgb_sampling_matrix_rejects_bad_wavelengths(samples, grid, match):
    """Before: NaN weights for a zero, negative or repeated wavelength."""
    with pytest.raises(ValueError, match=match):
        rgb_sampling_matrix(samples) if grid is None else rgb_sampling_matrix(samples, grid)


def test_sky_image_replace_changes_one_layer_and_shares_the_rest():
    """``SkyImage.replace`` (the former dataclasses.replace): new layer, others shared."""
    img = ac.render(ac.Scene(width=16, height=8))
    new_rgb = np.zeros_like(img.rgb)
    other = img.replace(rgb=new_rgb, metadata={"k": "v"})
    np.testing.assert_array_equal(other.rgb, new_rgb)
    assert np.any(img.rgb != 0)  # the original is untouched
    np.testing.assert_array_equal(other.alpha, img.alpha)
    assert other.metadata == {"k": "v"} and img.metadata != {"k": "v"}
    with pytest.raises(TypeError, match="unknown attribute"):
        img.replace(colour=1)

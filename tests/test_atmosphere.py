"""Tests for atmoscatter.atmosphere: profiles, Constituent and Atmosphere dataclasses."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

import atmoscatter as ac


def issue_atmosphere():
    # The exact constructor call of issue 2 ("Interface that other issues and independent
    # checks rely on").
    return ac.Atmosphere(
        planet_radius=6.36e6, top_radius=6.42e6, wavelengths=[680.0, 550.0, 440.0],
        constituents=[
            ac.Constituent(name="rayleigh", scattering=[5.8e-6, 1.36e-5, 3.31e-5], absorption=[0, 0, 0],
                           profile=ac.ExponentialProfile(scale_height=8000.0), phase=ac.RayleighPhase()),
            ac.Constituent(name="mie", scattering=[4e-6] * 3, absorption=[4.4e-7] * 3,
                           profile=ac.ExponentialProfile(scale_height=1200.0), phase=ac.HenyeyGreensteinPhase(g=0.8)),
        ])  # fmt: skip


def test_issue_constructor_call_works():
    atm = issue_atmosphere()
    assert atm.planet_radius == 6.36e6
    assert atm.top_radius == 6.42e6
    assert atm.thickness == pytest.approx(60e3)
    assert atm.n_wavelengths == 3
    np.testing.assert_array_equal(atm.wavelengths_array, [680.0, 550.0, 440.0])
    ray = atm.constituent("rayleigh")
    np.testing.assert_array_equal(ray.scattering_array, [5.8e-6, 1.36e-5, 3.31e-5])
    np.testing.assert_array_equal(ray.absorption_array, [0.0, 0.0, 0.0])
    mie = atm.constituent("mie")
    np.testing.assert_allclose(mie.extinction_array, [4.44e-6] * 3, rtol=1e-14)
    np.testing.assert_allclose(mie.single_scattering_albedo, 4e-6 / 4.44e-6, rtol=1e-14)
    assert mie.phase.g == 0.8
    assert [c.name for c in atm.constituents] == ["rayleigh", "mie"]
    # stored immutably
    assert isinstance(atm.constituents, tuple)
    assert isinstance(atm.wavelengths, tuple)
    assert isinstance(ray.scattering, tuple)


def test_frozen_and_hashable():
    atm = issue_atmosphere()
    with pytest.raises(dataclasses.FrozenInstanceError):
        atm.planet_radius = 1.0  # type: ignore[misc]
    with pytest.raises(dataclasses.FrozenInstanceError):
        atm.constituents[0].scattering = (0.0, 0.0, 0.0)  # type: ignore[misc]
    with pytest.raises(dataclasses.FrozenInstanceError):
        atm.constituents[0].profile.scale_height = 1.0  # type: ignore[misc]
    with pytest.raises(dataclasses.FrozenInstanceError):
        ac.TentProfile().center = 0.0  # type: ignore[misc]
    assert hash(atm) == hash(issue_atmosphere())
    assert atm == issue_atmosphere()


def test_accessors_and_without():
    atm = issue_atmosphere()
    with pytest.raises(KeyError, match="rayleigh"):
        atm.constituent("ozone")
    only = atm.without("mie")
    assert [c.name for c in only.constituents] == ["rayleigh"]
    assert only.planet_radius == atm.planet_radius
    empty = ac.Constituent("nothing", [0.0, 0.0, 0.0])
    atm2 = ac.Atmosphere(6.36e6, 6.42e6, [680.0, 550.0, 440.0], [*atm.constituents, empty])
    assert empty.is_empty
    assert [c.name for c in atm2.active_constituents()] == ["rayleigh", "mie"]
    np.testing.assert_array_equal(empty.single_scattering_albedo, [1.0, 1.0, 1.0])


def test_scalar_absorption_broadcasts():
    c = ac.Constituent("r", [1e-6, 2e-6, 3e-6], 1e-7)
    assert c.absorption == (1e-7, 1e-7, 1e-7)
    c = ac.Constituent("r", 1e-6, [1e-7, 2e-7])
    assert c.scattering == (1e-6, 1e-6)


# ---------------------------------------------------------------------------------------
# derived quantities
# ---------------------------------------------------------------------------------------


def test_extinction_and_scattering_at_values_and_shapes():
    atm = issue_atmosphere()
    h = np.array([[0.0, 1000.0], [8000.0, 20000.0]])
    ext = atm.extinction_at(h)
    sca = atm.scattering_at(h)
    assert ext.shape == sca.shape == (2, 2, 3)
    ray = np.array([5.8e-6, 1.36e-5, 3.31e-5])
    for idx in np.ndindex(h.shape):
        z = h[idx]
        exp_sca = ray * np.exp(-z / 8000.0) + 4e-6 * np.exp(-z / 1200.0)
        exp_ext = ray * np.exp(-z / 8000.0) + 4.44e-6 * np.exp(-z / 1200.0)
        np.testing.assert_allclose(sca[idx], exp_sca, rtol=1e-13)
        np.testing.assert_allclose(ext[idx], exp_ext, rtol=1e-13)
    assert atm.extinction_at(0.0).shape == (3,)
    out = atm.extinction_at(np.array([0.0, np.nan]))
    assert np.all(np.isnan(out[1])) and np.all(np.isfinite(out[0]))


def test_vertical_optical_depth_analytic():
    # τ = Σ β_ext,i H_i (1 − e^{−Z/H_i}) for exponential profiles (Z = 60 km), exact
    atm = issue_atmosphere()
    Z = 60e3
    ray = np.array([5.8e-6, 1.36e-5, 3.31e-5])
    expected = ray * 8000.0 * -np.expm1(-Z / 8000.0) + 4.44e-6 * 1200.0 * -np.expm1(-Z / 1200.0)
    np.testing.assert_allclose(atm.vertical_optical_depth(), expected, rtol=1e-10)
    # tent profile: ∫ = half width
    oz = ac.Constituent("ozone", [0.0] * 3, [1e-6, 2e-6, 1e-7], ac.TentProfile(25e3, 15e3))
    atm2 = ac.Atmosphere(6.36e6, 6.42e6, [680.0, 550.0, 440.0], [oz])
    np.testing.assert_allclose(atm2.vertical_optical_depth(), np.array([1e-6, 2e-6, 1e-7]) * 15e3, rtol=1e-10)


# ---------------------------------------------------------------------------------------
# profiles
# ---------------------------------------------------------------------------------------


def test_exponential_profile():
    p = ac.ExponentialProfile(8000.0)
    z = np.array([0.0, 8000.0, 16000.0])
    np.testing.assert_allclose(p.density(z), np.exp(-z / 8000.0), rtol=1e-15)
    q = ac.ExponentialProfile(8000.0, reference_altitude=1000.0)
    assert float(q.density(1000.0)) == 1.0
    assert p.breakpoints == ()
    assert p.scale == 8000.0
    # far below the reference (inside the planet) it must not overflow (no RuntimeWarning)
    assert np.isfinite(p.density(-1e7))
    assert np.isnan(p.density(np.nan))


def test_tent_profile():
    p = ac.TentProfile(25e3, 15e3)
    z = np.array([0.0, 10e3, 17.5e3, 25e3, 32.5e3, 40e3, 50e3])
    np.testing.assert_allclose(p.density(z), [0, 0, 0.5, 1, 0.5, 0, 0], atol=1e-15)
    assert p.breakpoints == (10e3, 25e3, 40e3)
    assert np.isnan(p.density(np.nan))


def test_tabulated_profile_log_linear():
    # exact for an exponential: log-linear interpolation reproduces e^{−z/H} between nodes
    z = np.array([0.0, 1000.0, 5000.0, 10000.0])
    p = ac.TabulatedProfile(tuple(z), tuple(np.exp(-z / 7000.0)))
    zz = np.linspace(-500.0, 10000.0, 43)
    np.testing.assert_allclose(p.density(zz), np.exp(-zz / 7000.0), rtol=1e-12)
    assert float(p.density(10000.1)) == 0.0  # above the last node
    assert p.breakpoints == tuple(z)
    assert p.scale == pytest.approx(7000.0, rel=1e-9)
    # zero densities: linear interpolation
    q = ac.TabulatedProfile((0.0, 10.0, 20.0), (1.0, 0.5, 0.0))
    np.testing.assert_allclose(q.density([5.0, 15.0, 20.0]), [0.75, 0.25, 0.0], atol=1e-15)
    assert np.isnan(p.density(np.nan))
    assert p.density(np.zeros((2, 3))).shape == (2, 3)


# ---------------------------------------------------------------------------------------
# bad input: each error names the parameter (issue 2, "Bad input")
# ---------------------------------------------------------------------------------------

WL = [680.0, 550.0, 440.0]


def _ray(**kw):
    args = {"name": "rayleigh", "scattering": [5.8e-6, 1.36e-5, 3.31e-5]}
    args.update(kw)
    return ac.Constituent(**args)


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"planet_radius": -6.36e6}, r"planet_radius must be in \(0, inf\)"),
        ({"planet_radius": 0.0}, "planet_radius"),
        ({"planet_radius": np.nan}, "planet_radius must be finite"),
        ({"planet_radius": np.inf}, "planet_radius must be finite"),
        ({"top_radius": np.inf}, "top_radius must be finite"),
        ({"top_radius": -1.0}, "top_radius"),
        ({"top_radius": 6.0e6}, r"top_radius must be > planet_radius.*6000000"),
        ({"top_radius": 6.36e6}, "top_radius must be > planet_radius"),
        ({"wavelengths": [680.0, -550.0, 440.0]}, r"wavelengths must be in \(0, inf\) nm.*-550"),
        ({"wavelengths": [680.0, 0.0, 440.0]}, "wavelengths"),
        ({"wavelengths": [680.0, np.nan, 440.0]}, "wavelengths must be finite"),
        ({"wavelengths": [680.0, np.inf, 440.0]}, "wavelengths must be finite"),
        ({"wavelengths": [[680.0, 550.0, 440.0]]}, "wavelengths must be 1-D"),
        ({"wavelengths": [680.0, 550.0]}, "3 coefficients but the atmosphere has 2 wavelengths"),
        ({"constituents": [_ray(), _ray()]}, "names must be unique"),
    ],
)
def test_atmosphere_bad_input(kwargs, match):
    args = {"planet_radius": 6.36e6, "top_radius": 6.42e6, "wavelengths": WL, "constituents": [_ray()]}
    args.update(kwargs)
    with pytest.raises(ValueError, match=match):
        ac.Atmosphere(**args)


def test_atmosphere_wrong_constituent_type():
    with pytest.raises(TypeError, match="constituents"):
        ac.Atmosphere(6.36e6, 6.42e6, WL, [{"name": "rayleigh"}])
    with pytest.raises(TypeError, match="wavelengths"):
        ac.Atmosphere(6.36e6, 6.42e6, ["red", "green", "blue"], [])


@pytest.mark.parametrize(
    ("kwargs", "exc", "match"),
    [
        ({"scattering": [5.8e-6, -1e-6, 3.3e-5]}, ValueError, r"rayleigh\.scattering must be in \[0, inf\)"),
        ({"scattering": [5.8e-6, np.nan, 3.3e-5]}, ValueError, r"rayleigh\.scattering must be finite"),
        ({"scattering": [[1e-6, 2e-6]]}, ValueError, r"rayleigh\.scattering must be a scalar or a 1-D"),
        ({"absorption": [0.0, -1.0, 0.0]}, ValueError, r"rayleigh\.absorption"),
        ({"absorption": [0.0, np.inf, 0.0]}, ValueError, r"rayleigh\.absorption must be finite"),
        ({"absorption": [0.0, 0.0]}, ValueError, "scattering has 3 values but absorption has 2"),
        ({"name": ""}, TypeError, "name must be a non-empty string"),
        ({"name": 3}, TypeError, "name"),
        ({"profile": "exponential"}, TypeError, r"rayleigh\.profile must be one of"),
        ({"phase": lambda mu: mu}, TypeError, r"rayleigh\.phase must be one of"),
        ({"scattering": ["a", "b", "c"]}, TypeError, r"rayleigh\.scattering"),
    ],
)
def test_constituent_bad_input(kwargs, exc, match):
    with pytest.raises(exc, match=match):
        _ray(**kwargs)


@pytest.mark.parametrize(
    ("factory", "match"),
    [
        (lambda: ac.ExponentialProfile(0.0), r"scale_height must be in \(0, inf\) m"),
        (lambda: ac.ExponentialProfile(-8000.0), "scale_height"),
        (lambda: ac.ExponentialProfile(np.nan), "scale_height must be finite"),
        (lambda: ac.ExponentialProfile(8000.0, reference_altitude=np.inf), "reference_altitude"),
        (lambda: ac.TentProfile(25e3, 0.0), "half_width"),
        (lambda: ac.TentProfile(np.nan, 15e3), "center"),
        (lambda: ac.TabulatedProfile((0.0, 1.0), (1.0, -0.5)), r"densities must be in \[0, inf\)"),
        (lambda: ac.TabulatedProfile((0.0, 1.0), (1.0, np.nan)), "densities must be finite"),
        (lambda: ac.TabulatedProfile((0.0, np.inf), (1.0, 0.5)), "altitudes must be finite"),
        (lambda: ac.TabulatedProfile((0.0, 1.0, 2.0), (1.0, 0.5)), "same length"),
        (lambda: ac.TabulatedProfile((0.0,), (1.0,)), "same length >= 2"),
        (lambda: ac.TabulatedProfile((0.0, 2.0, 1.0), (1.0, 0.5, 0.2)), "strictly increasing"),
    ],
)
def test_profile_bad_input(factory, match):
    with pytest.raises(ValueError, match=match):
        factory()


# --- plain-data form and atmosphere files ------------------------------------------------
def test_atmosphere_dict_round_trip_for_every_profile_and_phase():
    import json

    atm = ac.Atmosphere(6.36e6, 6.42e6, [440.0, 550.0, 680.0], [
        ac.Constituent("air", [3.3e-5, 1.36e-5, 5.8e-6], 0.0, ac.ExponentialProfile(8000.0),
                       ac.RayleighPhase()),
        ac.Constituent("haze", [4e-6] * 3, 4.4e-7, ac.ExponentialProfile(1200.0, 10.0),
                       ac.HenyeyGreensteinPhase(0.76)),
        ac.Constituent("dust", [1e-6] * 3, 1e-7, ac.TabulatedProfile([0, 1e3, 5e3], [1, 0.5, 0.0]),
                       ac.CornetteShanksPhase(0.6)),
        ac.Constituent("ozone", 0.0, [1e-7, 2e-6, 7e-7], ac.TentProfile(25e3, 15e3),
                       ac.IsotropicPhase()),
    ], name="test")
    # through JSON text, as a file would store it: every field comes back exactly
    back = ac.atmosphere_from_dict(json.loads(json.dumps(ac.atmosphere_to_dict(atm))))
    assert back == atm
    assert ac.atmosphere_from_dict(ac.atmosphere_to_dict(ac.earth_atmosphere())) == ac.earth_atmosphere()


@pytest.mark.parametrize("change,match", [
    ({"colour": 1}, "unknown atmosphere keys"),
    ({"top_radius": 6.0e6}, "top_radius"),
    ({"constituents": [{"name": "a", "scattering": 1e-5, "profile": {"type": "linear"}}]},
     "profile type 'linear' is not valid"),
    ({"constituents": [{"name": "a", "scattering": 1e-5,
                        "profile": {"type": "exponential", "scale_height": 8e3, "foo": 1}}]},
     "unknown keys"),
    ({"constituents": [{"name": "a", "scattering": 1e-5, "profile": "exponential"}]},
     "scale_height"),
    ({"constituents": [{"name": "a", "scattering": 1e-5,
                        "profile": {"type": "exponential", "scale_height": 8e3},
                        "phase": {"type": "henyey_greenstein", "g": 1.0}}]}, "g must be in"),
])
def test_atmosphere_from_dict_errors_name_the_problem(change, match):
    data = {"planet_radius": 6.36e6, "top_radius": 6.42e6, "wavelengths": [550.0]}
    data.update(change)
    with pytest.raises((ValueError, TypeError), match=match):
        ac.atmosphere_from_dict(data)


def test_load_atmosphere_toml_and_json(tmp_path):
    import json

    d = ac.atmosphere_to_dict(ac.mars_atmosphere())
    (tmp_path / "a.json").write_text(json.dumps(d))
    assert ac.load_atmosphere(tmp_path / "a.json") == ac.mars_atmosphere()
    toml = """planet_radius = 3389500.0
top_radius = 3489500.0
wavelengths = [680.0, 550.0, 440.0]
[[constituents]]
name = "co2"
scattering = [2e-7, 5e-7, 1.2e-6]
profile = { type = "exponential", scale_height = 11100.0 }
phase = "rayleigh"
"""
    (tmp_path / "a.toml").write_text(toml)
    atm = ac.load_atmosphere(tmp_path / "a.toml")
    assert atm.constituents[0].profile.scale_height == 11100.0
    assert atm.constituents[0].absorption == (0.0, 0.0, 0.0)
    with pytest.raises(ValueError, match="does not exist"):
        ac.load_atmosphere(tmp_path / "missing.toml")
    (tmp_path / "bad.toml").write_text("planet_radius = ")
    with pytest.raises(ValueError, match="not valid TOML"):
        ac.load_atmosphere(tmp_path / "bad.toml")

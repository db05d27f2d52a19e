"""The measured multiple-scattering accuracy and its statement in the EXR header.

``atmoscatter/data/ms_accuracy.json`` is written by ``benchmarks/ms_accurate_grid.py``
(full run: each named grid against a grid finer in every knob, see
``docs/convergence.md``).  Its numbers are not recomputed here (the reference's build
takes many minutes); these tests hold that the file exists, parses, covers every grid a
scene can name and every regime the renderer distinguishes, is internally consistent, and
that the header quotes the figures of the scene's grid and regime.
"""

from __future__ import annotations

import json
import math
from importlib import resources

import numpy as np
import pytest

import atmoscatter as ac
from atmoscatter.render import physical_adapter, plan, register_model, unregister_model
from atmoscatter.render.evaluate import _error_estimate
from atmoscatter.render.physical_adapters import _pct, ms_accuracy
from atmoscatter.scene import Scene

SUN_REGIMES = ("above_10", "0_to_10", "0_to_-6", "-6_to_-12", "below_-12")
OBSERVER_REGIMES = ("ground", "elevated", "space")


def _load():
    text = resources.files("atmoscatter").joinpath("data/ms_accuracy.json").read_text("utf-8")
    return json.loads(text)


def test_file_exists_parses_and_covers_every_grid_and_regime():
    acc = _load()["grids"]
    assert set(acc) == set(ac.MULTIPLE_SCATTERING_GRIDS)
    for name in acc:
        _check_regimes(acc[name])


def _check_regimes(acc):
    assert set(acc["sun_regimes_ground_observer"]) == set(SUN_REGIMES)
    assert set(acc["observer_regimes"]) == set(OBSERVER_REGIMES)
    for group in ("sun_regimes_ground_observer", "observer_regimes"):
        for key, r in acc[group].items():
            tot, part = r["max_rel_total"], r["max_rel_ms"]
            assert math.isfinite(tot) and math.isfinite(part) and tot >= 0.0, key
            # the error is the same absolute difference divided by the total or by the
            # (smaller) multiple-scattering part: the MS figure can never be the smaller
            assert part >= tot * (1 - 1e-12), key
            assert r["scenes"] and r["worst_scene"] in r["scenes"], key
    # every ground scene's figure enters the ground observer's worst case
    ground = acc["observer_regimes"]["ground"]
    worst_sun = max(r["max_rel_total"] for r in acc["sun_regimes_ground_observer"].values())
    assert ground["max_rel_total"] == pytest.approx(worst_sun, rel=1e-12)


@pytest.mark.parametrize("grid", ["default", "accurate", "table"])
def test_measurement_is_of_the_installed_method(grid):
    """Fails when the method or a named grid changed since the measurement was run (the
    header would then flag its figures): rerun ``benchmarks/ms_accurate_grid.py``."""
    from atmoscatter.render.physical_adapters import _ms_accuracy_current

    assert _ms_accuracy_current(_load(), grid)
    assert "CAUTION" not in _header_text(_ms_scene(ms_grid=grid))
    assert not _ms_accuracy_current({**_load(), "field_version": -1}, grid)
    other = {"default": "accurate", "accurate": "default", "table": "default"}[grid]
    wrong = {**_load(), "grids": {grid: _load()["grids"][other]}}
    assert not _ms_accuracy_current(wrong, grid)


#: issue 10's bounds per regime: (total, multiple-scattering part); deep twilight (below
#: −12°) has none — its error is measured and published
_BOUNDS = {"above_10": (0.01, 0.03), "0_to_10": (0.01, 0.03), "0_to_-6": (0.01, 0.03),
           "-6_to_-12": (0.03, None), "elevated": (0.01, 0.03), "space": (0.01, 0.03)}


def test_the_accurate_grid_meets_the_bounds_and_is_better_where_the_default_is_not():
    """The reason the accurate grid exists: measured against the finer reference
    (``benchmarks/ms_accurate_grid.py``), it is within issue 10's bounds in every regime
    down to sun −12° and for every observer, and wherever the default grid is at or above a
    bound the accurate grid is below the default.  (Where both are well inside a bound the
    order of the two is not asserted: in daylight the reference is coarser in solar zenith
    at the sun than grids centred on it, so small figures differ by the reference's own
    discretisation — ``mc.REFERENCE_NOTE``.)"""
    acc = _load()["grids"]
    for group in ("sun_regimes_ground_observer", "observer_regimes"):
        for key, bounds in _BOUNDS.items():
            if key not in acc["accurate"][group]:
                continue
            d, a = acc["default"][group][key], acc["accurate"][group][key]
            for part, bound in zip(("max_rel_total", "max_rel_ms"), bounds, strict=True):
                if bound is None:
                    continue
                assert a[part] < bound, (group, key, part, a[part])
                if d[part] >= 0.9 * bound:
                    assert a[part] < d[part], (group, key, part, a[part], d[part])


def _ms_scene(**kw):
    kw = {"model": "multiple_scattering", "sun_elevation_deg": -8.0, "sun_azimuth_deg": 180.0,
          "width": 8, "height": 4, **kw}
    return Scene(**kw)


def _header_text(s):
    adapter = physical_adapter("multiple_scattering")
    return _error_estimate(adapter, plan(s), s)


@pytest.mark.parametrize(("elevation", "regime"), [
    (-8.0, "-6_to_-12"), (-6.0, "0_to_-6"), (-3.0, "0_to_-6"), (5.0, "0_to_10"),
    (45.0, "above_10"), (-20.0, "below_-12"),
])
def test_ground_scene_quotes_its_sun_regime(elevation, regime):
    r = ms_accuracy()["grids"]["default"]["sun_regimes_ground_observer"][regime]
    text = _header_text(_ms_scene(sun_elevation_deg=elevation))
    assert "default grid" in text
    assert f"max {_pct(r['max_rel_total'])} of total" in text
    assert f"({_pct(r['max_rel_ms'])} of the MS part)" in text
    assert r["description"] in text and "docs/convergence.md" in text


@pytest.mark.parametrize(("altitude", "regime"), [(12e3, "elevated"), (500e3, "space")])
def test_elevated_and_space_observers_quote_their_regime(altitude, regime):
    r = ms_accuracy()["grids"]["default"]["observer_regimes"][regime]
    text = _header_text(_ms_scene(sun_elevation_deg=20.0, altitude=altitude))
    assert f"max {_pct(r['max_rel_total'])} of total" in text and r["description"] in text


@pytest.mark.parametrize(("elevation", "altitude", "group", "regime"), [
    (-8.0, 0.0, "sun_regimes_ground_observer", "-6_to_-12"),
    (30.0, 0.0, "sun_regimes_ground_observer", "above_10"),
    (20.0, 500e3, "observer_regimes", "space"),
])
def test_accurate_grid_scene_quotes_the_accurate_figures(elevation, altitude, group, regime):
    r = ms_accuracy()["grids"]["accurate"][group][regime]
    text = _header_text(_ms_scene(sun_elevation_deg=elevation, altitude=altitude,
                                  ms_grid="accurate"))
    assert "accurate grid" in text
    assert f"max {_pct(r['max_rel_total'])} of total ({_pct(r['max_rel_ms'])} of the MS part)" in text


def test_scene_grid_reaches_the_model_and_the_plan(monkeypatch):
    """``ms_grid`` selects the grid ``multiple_scattering`` is called with (and the one
    ``--explain`` names); ``None`` is the default grid."""
    seen = []

    def fake(atmosphere, view_directions, sun_direction, **kw):
        seen.append(kw.get("grid"))
        wl = atmosphere.wavelengths_array
        return np.full(np.shape(view_directions)[:-1] + (wl.size,), 1e-3)

    previous = ac.MODELS.get("multiple_scattering")
    monkeypatch.setattr(ac, "multiple_scattering", fake, raising=False)
    register_model(physical_adapter("multiple_scattering"), replace=True)
    try:
        for name, grid in (("accurate", ac.ACCURATE_MULTIPLE_SCATTERING_GRID),
                           ("table", ac.TABLE_MULTIPLE_SCATTERING_GRID),
                           (None, ac.MULTIPLE_SCATTERING_GRID)):
            seen.clear()
            s = _ms_scene(ms_grid=name)
            ac.render(s)
            assert seen and all(g == grid for g in seen), name
            assert f"{name or 'default'} grid (n_altitude {grid.n_altitude:g}" in plan(s).numerics
    finally:
        unregister_model("multiple_scattering")
        if previous is not None:
            register_model(previous)


def test_scene_grid_bad_values_are_one_line_errors():
    with pytest.raises(ValueError, match=r"ms_grid='fine' is not valid; choose one of \['accurate', 'default', 'table'\]"):
        _ms_scene(ms_grid="fine")
    with pytest.raises(ValueError, match="ms_grid='accurate' only applies to model='multiple_scattering'"):
        Scene(model="preetham", ms_grid="accurate")


def test_fixed_orders_and_bright_ground_are_flagged():
    text = _header_text(_ms_scene(orders=4, ground_albedo=0.3))
    assert "orders=4" in text and "black ground" in text
    assert "orders=" not in _header_text(_ms_scene())


def test_header_of_a_render_names_the_twilight_figures(monkeypatch):
    """End to end through :func:`atmoscatter.render` (a fake field: only the header counts)."""
    previous = ac.MODELS.get("multiple_scattering")

    def fake(atmosphere, view_directions, sun_direction, **kw):
        wl = atmosphere.wavelengths_array
        return np.full(np.shape(view_directions)[:-1] + (wl.size,), 1e-3)

    monkeypatch.setattr(ac, "multiple_scattering", fake, raising=False)
    register_model(physical_adapter("multiple_scattering"), replace=True)
    try:
        img = ac.render(_ms_scene(sun_elevation_deg=-9.0))
    finally:
        unregister_model("multiple_scattering")
        if previous is not None:
            register_model(previous)
    r = ms_accuracy()["grids"]["default"]["sun_regimes_ground_observer"]["-6_to_-12"]
    md = img.metadata["atmoscatter:error_estimate"]
    assert f"max {_pct(r['max_rel_total'])} of total ({_pct(r['max_rel_ms'])} of the MS part)" in md


def test_string_error_estimates_still_work():
    adapter = physical_adapter("single_scattering")
    s = _ms_scene(model="single_scattering")
    assert _error_estimate(adapter, plan(s), s).startswith(adapter.error_estimate)


def test_ms_convergence_quick_smoke(tmp_path, monkeypatch):
    """``benchmarks/ms_convergence.py --quick`` (tiny grids, two scenes, a few seconds)
    writes its files; a grid compared with itself must give error 0 (self-check of the
    error measure: same field, same directions)."""
    import csv
    import os
    import subprocess
    import sys
    from pathlib import Path

    root = Path(__file__).resolve().parents[1]
    env = {**os.environ, "PYTHONPATH": str(root)}
    subprocess.run([sys.executable, str(root / "benchmarks" / "ms_convergence.py"), "--quick",
                    "--out", str(tmp_path)], check=True, env=env, capture_output=True, timeout=300)
    for name in ("ms_convergence.csv", "ms_convergence_table.md", "ms_convergence.png"):
        assert (tmp_path / name).stat().st_size > 0, name
    with open(tmp_path / "ms_convergence.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    assert {r["scene"] for r in rows} == {"clear_noon", "civil_twilight"}
    assert all(float(r["build_s"]) > 0 and float(r["max_rel_total"]) >= 0 for r in rows)
    # the EXR header's figures come from ms_accurate_grid.py, not from this study
    assert not (tmp_path / "ms_accuracy.json").exists()

    # the script turns the persistent cache off at import: undo that after the test
    monkeypatch.setenv("ATMOSCATTER_CACHE_DIR", os.environ.get("ATMOSCATTER_CACHE_DIR", "off"))
    sys.path.insert(0, str(root / "benchmarks"))
    try:
        import ms_convergence as mc
    finally:
        sys.path.pop(0)
    ref = np.array([[1.0, 2.0], [1e-9, 3.0]])
    single = np.array([[0.5, 1.0], [0.0, 1.0]])
    assert mc.errors(ref, ref, single) == (0.0, 0.0)
    # 1 % off in one bright direction: 1 % of the total, 2 % of the MS part (0.5)
    e_tot, e_ms = mc.errors(ref * np.array([[1.01, 1.0], [1.0, 1.0]]), ref, single)
    assert e_tot == pytest.approx(0.01) and e_ms == pytest.approx(0.02)
    # directions below 1e-6 of the maximum are ignored, however wrong
    assert mc.errors(ref * np.array([[1.0, 1.0], [5.0, 1.0]]), ref, single) == (0.0, 0.0)


def test_ms_accurate_grid_quick_writes_the_header_figures(tmp_path):
    """``benchmarks/ms_accurate_grid.py --quick`` (tiny grids, two scenes, seconds) writes
    the table and an ``ms_accuracy.json`` of the layout the renderer reads, for both
    named grids."""
    import os
    import subprocess
    import sys
    from pathlib import Path

    root = Path(__file__).resolve().parents[1]
    env = {**os.environ, "PYTHONPATH": str(root)}
    subprocess.run([sys.executable, str(root / "benchmarks" / "ms_accurate_grid.py"), "--quick",
                    "--out", str(tmp_path)], check=True, env=env, capture_output=True, timeout=300)
    assert (tmp_path / "ms_accurate_grid.md").stat().st_size > 0
    js = json.loads((tmp_path / "ms_accuracy.json").read_text())
    assert set(js["grids"]) == {"default", "accurate", "table"}
    for g in js["grids"].values():
        assert set(g["sun_regimes_ground_observer"]) == {"above_10", "0_to_-6"}
        assert set(g["observer_regimes"]) == {"ground"}
        assert g["grid_fields"]["n_altitude"] >= 2 and "order_tolerance" in g["grid_fields"]
        for r in g["sun_regimes_ground_observer"].values():
            assert r["max_rel_ms"] >= r["max_rel_total"] * (1 - 1e-12) >= 0.0


@pytest.mark.parametrize("model", ["single_scattering", "multiple_scattering"])
def test_twilight_fisheye_uses_the_single_scattering_table(model, monkeypatch):
    """A twilight sky evaluated in many calls uses the single-scattering table when the
    whole sky is large enough (TWILIGHT_TABLE_THRESHOLD), not when one call is: a 256²
    fisheye (51 000 sky directions, no mirror symmetry at this sun azimuth) took 49 s by
    direct integration and 4.5 s with the table.  The order 1 of multiple scattering
    follows the same rule."""
    from atmoscatter.render.physical_adapters import _evaluated_directions
    from atmoscatter.sky import single

    seen = []

    def fake(atmosphere, view_directions, sun_direction, **kw):
        seen.append(kw.get("single_method" if model == "multiple_scattering" else "method"))
        wl = atmosphere.wavelengths_array
        return np.full(np.shape(view_directions)[:-1] + (wl.size,), 1e-3)

    s = Scene(model=model, sun_elevation_deg=-6.0, sun_azimuth_deg=295.0,
              projection="fisheye", width=256, height=256, sampling="rgb")
    n = _evaluated_directions(s, symmetry=plan(s).symmetry)
    assert n >= single.TWILIGHT_TABLE_THRESHOLD
    assert n <= int(256 * 256 * math.pi / 4)  # a lower estimate of the sky pixels
    previous = ac.MODELS.get(model)
    monkeypatch.setattr(ac, model, fake, raising=False)
    register_model(physical_adapter(model), replace=True)
    try:
        ac.render(s)
        assert seen and set(seen) == {"table"}
        seen.clear()
        ac.render(Scene(model=model, sun_elevation_deg=-6.0, sun_azimuth_deg=295.0,
                        projection="fisheye", width=64, height=64, sampling="rgb"))
        assert seen and set(seen) == {None}  # small sky: the default chooses per call
    finally:
        unregister_model(model)
        if previous is not None:
            register_model(previous)


def test_the_study_reuses_its_stored_reference_only_for_the_same_method(tmp_path, monkeypatch):
    """``benchmarks/ms_convergence.reference_values`` reads the reference radiances back
    from its store for the same field version, reference grid, atmosphere and scenes, and
    computes them anew when any of those changed (a stale reference is never reused)."""
    from dataclasses import replace
    from pathlib import Path

    monkeypatch.setenv("ATMOSCATTER_CACHE_DIR", "off")
    monkeypatch.syspath_prepend(str(Path(__file__).resolve().parents[1] / "benchmarks"))
    import ms_convergence as mc

    from atmoscatter.sky import multiple as M

    atm = mc.ATMOSPHERES["mars"]()
    store = tmp_path / "ref.npz"
    quiet = {"progress": lambda *_: None}
    first, t_first, _ = mc.reference_values(atm, ["mars"], mc.QUICK_REFERENCE, store, **quiet)

    def recomputed(*_a, **_k):
        raise AssertionError("recomputed")

    monkeypatch.setattr(mc, "evaluate", recomputed)
    again, t_again, note = mc.reference_values(atm, ["mars"], mc.QUICK_REFERENCE, store, **quiet)
    np.testing.assert_array_equal(again["mars"], first["mars"])  # the stored bytes
    assert t_again == t_first and note.startswith("computed ")
    grid, tol = mc.QUICK_REFERENCE
    changed = [
        (atm, ["mars"], (replace(grid, n_sun=grid.n_sun + 2), tol)),  # another reference grid
        (atm, ["mars"], (grid, tol / 2)),
        (mc.ATMOSPHERES["earth_t2.5"](), ["clear_noon"], mc.QUICK_REFERENCE),  # atmosphere, scene
    ]
    for args in changed:
        with pytest.raises(AssertionError, match="recomputed"):
            mc.reference_values(*args, store, **quiet)
    monkeypatch.setattr(M, "_FIELD_VERSION", M._FIELD_VERSION + 1)  # the method changed
    with pytest.raises(AssertionError, match="recomputed"):
        mc.reference_values(atm, ["mars"], mc.QUICK_REFERENCE, store, **quiet)

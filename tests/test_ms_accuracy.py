"""The measured multiple-scattering accuracy and its statement in the EXR header.

``atmoscatter/data/ms_accuracy.json`` is written by ``benchmarks/ms_convergence.py``
(full run: the default grid against a refined grid, see ``docs/convergence.md``).  Its
numbers are not recomputed here (a field build takes tens of seconds); these tests hold
that the file exists, parses, covers every regime the renderer distinguishes, is
internally consistent, and that the header quotes the figures of the scene's regime.
"""

from __future__ import annotations

import json
import math
from importlib import resources

import numpy as np
import pytest

import atmoscatter as ac
from atmoscatter.models import _pct, ms_accuracy, physical_adapter, register_model, unregister_model
from atmoscatter.render.evaluate import _error_estimate
from atmoscatter.scene import Scene, plan

SUN_REGIMES = ("above_10", "0_to_10", "0_to_-6", "-6_to_-12", "below_-12")
OBSERVER_REGIMES = ("ground", "elevated", "space")


def _load():
    text = resources.files("atmoscatter").joinpath("data/ms_accuracy.json").read_text("utf-8")
    return json.loads(text)


def test_file_exists_parses_and_covers_every_regime():
    acc = _load()
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


def test_measurement_is_of_the_installed_method():
    """Fails when the method or its default grid changed since the study was run (the
    header would then flag its figures): rerun ``benchmarks/ms_convergence.py``."""
    from atmoscatter.models import _ms_accuracy_current

    assert _ms_accuracy_current(_load())
    assert "CAUTION" not in _header_text(_ms_scene())
    assert not _ms_accuracy_current({**_load(), "field_version": -1})


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
    r = ms_accuracy()["sun_regimes_ground_observer"][regime]
    text = _header_text(_ms_scene(sun_elevation_deg=elevation))
    assert f"max {_pct(r['max_rel_total'])} of total" in text
    assert f"({_pct(r['max_rel_ms'])} of the MS part)" in text
    assert r["description"] in text and "docs/convergence.md" in text


@pytest.mark.parametrize(("altitude", "regime"), [(12e3, "elevated"), (500e3, "space")])
def test_elevated_and_space_observers_quote_their_regime(altitude, regime):
    r = ms_accuracy()["observer_regimes"][regime]
    text = _header_text(_ms_scene(sun_elevation_deg=20.0, altitude=altitude))
    assert f"max {_pct(r['max_rel_total'])} of total" in text and r["description"] in text


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
    r = ms_accuracy()["sun_regimes_ground_observer"]["-6_to_-12"]
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
    for name in ("ms_convergence.csv", "ms_convergence_table.md", "ms_convergence.png",
                 "ms_accuracy.json"):
        assert (tmp_path / name).stat().st_size > 0, name
    with open(tmp_path / "ms_convergence.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    assert {r["scene"] for r in rows} == {"clear_noon", "civil_twilight"}
    assert all(float(r["build_s"]) > 0 and float(r["max_rel_total"]) >= 0 for r in rows)
    js = json.loads((tmp_path / "ms_accuracy.json").read_text())
    assert set(js["sun_regimes_ground_observer"]) == {"above_10", "0_to_-6"}

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

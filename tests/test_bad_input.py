"""Deliberately bad or unusual input (issue 11): each case is one clear error naming the
parameter (or file), the value and the valid range — before any work, with no file left."""

import math
import os
import subprocess
import sys
import warnings

import numpy as np
import pytest

import atmoscatter as ac
from atmoscatter.cli import main
from atmoscatter.exr import atomic_write, read_exr
from atmoscatter.render import plan
from atmoscatter.scene import Scene, load_scene

pytestmark = pytest.mark.usefixtures("toy_model")

TOY = ["--set", "model=toy", "--set", "sun_elevation_deg=30", "--set", "width=16",
       "--set", "height=8"]


def _env():
    return dict(os.environ, PYTHONPATH=os.pathsep.join(
        [os.path.dirname(os.path.dirname(ac.__file__)), os.environ.get("PYTHONPATH", "")]))


def _one_line_error(capsys, *needles):
    err = capsys.readouterr().err
    assert err.startswith("atmoscatter: error: ") and err.count("\n") == 1, err
    for n in needles:
        assert n in err, err
    return err


# --- huge images ----------------------------------------------------------------------
@pytest.mark.parametrize("projection,width,height", [
    ("latlong", 65536, 32768), ("cubemap", 65536, 1), ("cubemap", 8192, 1),
    ("fisheye", 65536, 65536), ("dome", 65536, 65536),
])
def test_huge_images_are_refused_before_allocating(projection, width, height):
    with pytest.raises(ValueError, match=r"GiB of output arrays; the limit is 4 GiB") as exc:
        Scene(projection=projection, width=width, height=height)
    assert f"{width}" in str(exc.value) and "ATMOSCATTER_MAX_OUTPUT_GIB" in str(exc.value)


def test_large_but_reasonable_images_pass_and_the_limit_is_adjustable(monkeypatch):
    Scene(width=16384, height=8192)  # 2 GiB of RGB + alpha: allowed
    Scene(projection="cubemap", width=4096)
    with pytest.raises(ValueError, match="GiB"):  # spectral layers count too
        Scene(width=16384, height=8192, model="single_scattering", output="spectral")
    monkeypatch.setenv("ATMOSCATTER_MAX_OUTPUT_GIB", "0.001")
    with pytest.raises(ValueError, match="the limit is 0.001 GiB"):
        Scene(width=1024, height=512)
    monkeypatch.setenv("ATMOSCATTER_MAX_OUTPUT_GIB", "lots")
    with pytest.raises(ValueError, match="ATMOSCATTER_MAX_OUTPUT_GIB must be a number"):
        Scene()


# --- output files ---------------------------------------------------------------------
def test_unwritable_output_is_found_before_rendering(tmp_path, capsys, monkeypatch):
    blocker = tmp_path / "a_file"
    blocker.write_text("x")
    target = blocker / "sub" / "sky.exr"

    def no_render(*a, **k):  # pragma: no cover - must not be reached
        raise AssertionError("rendered before checking the output")

    monkeypatch.setattr(sys.modules["atmoscatter.render"], "render", no_render)
    assert main(["render", "-o", str(target), *TOY]) == 2
    err = _one_line_error(capsys, str(target), "cannot write")
    assert ".tmp" not in err


@pytest.mark.skipif(os.geteuid() == 0, reason="root can write into read-only directories")
def test_read_only_directory(tmp_path, capsys):  # pragma: no cover - CI runs as a user
    ro = tmp_path / "ro"
    ro.mkdir()
    ro.chmod(0o500)
    try:
        assert main(["render", "-o", str(ro / "sky.exr"), *TOY]) == 2
        _one_line_error(capsys, str(ro / "sky.exr"), "cannot write")
    finally:
        ro.chmod(0o700)


def test_atomic_write_names_the_target_not_the_temporary(tmp_path):
    blocker = tmp_path / "f"
    blocker.write_text("x")
    with pytest.raises(OSError, match="cannot write") as exc, atomic_write(blocker / "x.exr"):
        pass  # pragma: no cover
    assert str(blocker / "x.exr") in str(exc.value) and ".tmp" not in str(exc.value)


@pytest.mark.parametrize("argv,needle", [
    (["render", "-o", "sky.png"], "must end in .exr"),
    (["render", "-o", "sky.exr", "--preview", "sky.jpg"], "--preview 'sky.jpg' must end in .png"),
])
def test_output_extension_is_checked(argv, needle, tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert main(argv + TOY) == 2
    _one_line_error(capsys, needle)
    assert not list(tmp_path.iterdir())


def test_preview_output_must_be_png(tmp_path, capsys):
    src = tmp_path / "sky.exr"
    assert main(["render", "-o", str(src), *TOY]) == 0
    capsys.readouterr()
    assert main(["preview", str(src), "-o", str(tmp_path / "p.exr")]) == 2
    _one_line_error(capsys, "must end in .png")


# --- malformed files ------------------------------------------------------------------
def test_non_utf8_scene_files_name_the_file(tmp_path):
    j = tmp_path / "s.json"
    j.write_bytes('{"model": "toy", "name": "Zürich"}'.encode("latin-1"))
    with pytest.raises(ValueError, match="not UTF-8") as exc:
        load_scene(j)
    assert str(j) in str(exc.value)
    t = tmp_path / "s.toml"
    t.write_bytes('model = "toy"\nname = "Zürich"\n'.encode("latin-1"))
    with pytest.raises(ValueError, match="not UTF-8") as exc:
        load_scene(t)
    assert str(t) in str(exc.value)


def test_json_scene_with_bom(tmp_path):
    j = tmp_path / "s.json"
    j.write_bytes('\ufeff{"model": "toy", "width": 8}'.encode())
    assert load_scene(j).width == 8


@pytest.mark.parametrize("name,text", [
    ("atm.json", '{"name": "bad", "constituents": 3}'),
    ("atm.toml", 'name = "x"\n[[constituent]]\nkind = "foo"\n'),
    ("atm.json", "{not json"),
])
def test_bad_atmosphere_files_name_the_file(tmp_path, name, text):
    f = tmp_path / name
    f.write_text(text)
    if "single_scattering" not in ac.MODELS:  # pragma: no cover
        pytest.skip("needs a physical model")
    with pytest.raises(ValueError) as exc:
        plan(Scene(model="single_scattering", atmosphere=str(f)))
    assert str(f) in str(exc.value) and "\n" not in str(exc.value)


def test_corrupt_exr_is_one_line_without_openexr_noise(tmp_path, capfd):
    src = tmp_path / "sky.exr"
    assert main(["render", "-o", str(src), *TOY]) == 0
    data = src.read_bytes()
    bad = tmp_path / "broken.exr"
    bad.write_bytes(data[: len(data) // 2])
    capfd.readouterr()
    assert main(["info", str(bad)]) == 2
    out, err = capfd.readouterr()
    assert out == ""
    assert err.startswith("atmoscatter: error: ") and err.count("\n") == 1, err
    assert str(bad) in err and "not a readable OpenEXR file" in err
    # the C++ library's messages go nowhere, but the descriptors work again afterwards
    print("still here")
    assert "still here" in capfd.readouterr().out


# --- the Python API -------------------------------------------------------------------
def test_render_takes_a_dict_or_a_scene_file(tmp_path):
    img = ac.render({"model": "toy", "sun_elevation_deg": 30, "width": 8, "height": 4})
    assert img.rgb.shape == (4, 8, 3)
    f = tmp_path / "scene.toml"
    f.write_text('model = "toy"\nsun_elevation_deg = 30.0\nwidth = 6\nheight = 3\n')
    assert ac.render(str(f)).rgb.shape == (3, 6, 3)
    assert ac.render(f).scene.width == 6
    with pytest.raises(TypeError, match="scene must be a Scene, a dict"):
        ac.render(42)
    with pytest.raises(ValueError, match="unknown scene field 'widht'"):
        ac.render({"widht": 8})


@pytest.mark.parametrize("workers", [0, -3, 1.5])
def test_render_workers_must_be_a_positive_integer(workers):
    with pytest.raises((ValueError, TypeError), match=r"workers must be an integer in \[1, inf\)"):
        ac.render({"model": "toy", "sun_elevation_deg": 30, "width": 8, "height": 4},
                  workers=workers)


@pytest.mark.parametrize("command", ["render", "batch"])
@pytest.mark.parametrize("value", ["0", "-3", "two"])
def test_cli_workers_must_be_positive(command, value, tmp_path, capsys):
    argv = (["render", "-o", str(tmp_path / "x.exr")] if command == "render"
            else ["batch", str(tmp_path / "s.csv"), "-o", str(tmp_path / "out")])
    with pytest.raises(SystemExit) as exc:
        main(argv + ["--workers", value])
    assert exc.value.code == 2
    err = capsys.readouterr().err
    assert f"argument --workers: must be an integer in [1, inf), got '{value}'" in err
    # one line, like every other CLI error (no argparse usage block before it)
    assert err.count("\n") == 1 and err.startswith(f"atmoscatter {command}: error:")
    assert not list(tmp_path.iterdir())


@pytest.mark.parametrize("when", ["-5000-01-01", "10000-01-01", "6001-01-01"])
def test_sun_position_years_outside_the_spa_range(when):
    with pytest.raises(ValueError, match=r"time must be within the years -2000\.\.6000"):
        ac.sun_position(np.datetime64(when), 51.0, 0.0)


def test_sun_position_years_at_the_ends_of_the_range_and_nat_elements():
    t = np.array(["-2000-01-01", "6000-12-31T23:59", "NaT"], dtype="datetime64[m]")
    z = ac.sun_position(t, 51.0, 0.0).zenith
    assert np.all(np.isfinite(z[:2])) and np.isnan(z[2])
    with pytest.raises(ValueError, match=r"6001-01-01T00:00:00 \(at index \(1,\)\)"):
        ac.sun_position(np.array(["2000-01-01", "6001-01-01"], dtype="datetime64[D]"), 51, 0)


def test_scene_time_outside_the_spa_range():
    with pytest.raises(ValueError, match=r"time must be within the years -2000\.\.6000"):
        Scene(time="9999-06-21T12:00:00Z")


# --- CLI values -----------------------------------------------------------------------
@pytest.mark.parametrize("value", ["nan", "inf", "-1", "0"])
def test_preview_transparency_must_be_positive_and_finite(value, tmp_path, capsys):
    src = tmp_path / "sky.exr"
    assert main(["render", "-o", str(src), *TOY]) == 0
    capsys.readouterr()
    png = tmp_path / "p.png"
    assert main(["preview", str(src), "-o", str(png), "--alpha", "sky",
                 "--transparency", value]) == 2
    _one_line_error(capsys, "transparency must be in (0, inf)", value)
    assert not png.exists()
    nested = tmp_path / "new" / "dir" / "p.png"  # a failed command creates no directory
    assert main(["preview", str(src), "-o", str(nested), "--transparency", value]) == 2
    assert not (tmp_path / "new").exists()


@pytest.mark.parametrize("command", ["render", "batch"])
def test_set_with_an_empty_value_is_an_error(command, tmp_path, capsys):
    csv = tmp_path / "s.csv"
    csv.write_text("name,model,sun_elevation_deg,width,height\na,toy,30,8,4\n")
    argv = (["render", "-o", str(tmp_path / "x.exr"), *TOY] if command == "render"
            else ["batch", str(csv), "-o", str(tmp_path / "out")])
    assert main(argv + ["--set", "time="]) == 2
    _one_line_error(capsys, "'time='", "empty")
    assert not (tmp_path / "x.exr").exists() and not (tmp_path / "out").exists()


def test_info_json_into_a_closed_pipe_has_no_traceback(tmp_path):
    src = tmp_path / "sky.exr"
    assert main(["render", "-o", str(src), *TOY]) == 0
    p = subprocess.Popen([sys.executable, "-m", "atmoscatter", "info", "--json", str(src)],
                         stdout=subprocess.PIPE, stderr=subprocess.PIPE, env=_env())
    p.stdout.close()  # like `| head` that has already gone
    err = p.stderr.read().decode()
    p.wait(timeout=120)
    assert "Traceback" not in err and "BrokenPipe" not in err, err
    assert p.returncode == 141


def test_broken_pipe_in_process(tmp_path, capsys, monkeypatch):
    src = tmp_path / "sky.exr"
    assert main(["render", "-o", str(src), *TOY]) == 0

    class Gone:
        def write(self, text):
            raise BrokenPipeError(32, "Broken pipe")

        def flush(self):
            pass

    monkeypatch.setattr(sys, "stdout", Gone())
    assert main(["info", "--json", str(src)]) == 141


# --- compare and models ---------------------------------------------------------------
def test_compare_counts_nan_pixels_of_the_other_image():
    rng = np.random.default_rng(1)
    ref = rng.uniform(100.0, 200.0, (8, 16, 3))
    other = ref.copy()
    other[0, :5] = np.nan
    other[1, 0, 2] = np.inf
    c = ac.compare_images(other, ref, other_space="XYZ", reference_space="XYZ")
    assert c.nonfinite_other == 6 and c.nonfinite_reference == 0
    assert c.pixels_compared == 8 * 16 - 6
    assert "6 in the other image" in c.summary_text()
    assert c.to_dict()["pixels_not_finite"] == {"other": 6, "reference": 0}
    clean = ac.compare_images(ref, ref, other_space="XYZ", reference_space="XYZ")
    assert clean.nonfinite_other == 0 and "not finite" not in clean.summary_text()


@pytest.mark.skipif("preetham" not in ac.MODELS, reason="preetham not registered")
def test_preetham_with_the_sun_below_the_horizon_warns_once_in_one_line(tmp_path, capsys):
    with pytest.warns(UserWarning, match="preetham is undefined with the sun below the horizon"):
        p = plan(Scene(model="preetham", sun_elevation_deg=-4.0))
    assert any("undefined with the sun below the horizon" in n for n in p.notes)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        plan(Scene(model="preetham", sun_elevation_deg=4.0))  # no warning above the horizon
    out = tmp_path / "night.exr"
    assert main(["render", "-o", str(out), "--set", "sun_elevation_deg=-4", "--set",
                 "width=16", "--set", "height=8"]) == 0
    err = capsys.readouterr().err
    assert err.startswith("atmoscatter: warning: preetham is undefined") and \
        err.count("\n") == 1, err
    assert read_exr(out).rgb.max() == 0.0  # values unchanged: black, as before


# --- scene fields: NaN, inf, negative -------------------------------------------------
@pytest.mark.parametrize("field,value,match", [
    ("turbidity", math.nan, "turbidity must be finite"),
    ("turbidity", math.inf, "turbidity must be finite"),
    ("altitude", -1.0, r"altitude must be in \[0, inf\)"),
    ("altitude", math.inf, "altitude must be finite"),
    ("ground_albedo", math.nan, "ground_albedo must be finite"),
    ("width", math.nan, "width must be an integer"),
    ("width", math.inf, "width must be an integer"),
    ("height", -4, r"height must be in \[1, 65536\]"),
    ("orders", 0, r"orders must be in \[1, 1000\]"),
    ("orders", 10**9, r"orders must be in \[1, 1000\]"),
    ("refinement", -1, r"refinement must be in \[0, 8\]"),
    ("exposure", math.nan, "exposure must be finite"),
    ("exposure", -1.0, r"exposure must be in \(0, inf\)"),
    ("wavelength_step", math.inf, "wavelength_step must be finite"),
    ("wavelength_step", -10.0, r"wavelength_step must be in \[1, 100\]"),
    ("latitude", math.nan, "latitude must be finite"),
    ("longitude", -math.inf, "longitude must be finite"),
    ("sun_elevation_deg", math.nan, "sun_elevation_deg must be finite"),
    ("sun_elevation_deg", 91.0, r"sun_elevation_deg must be in \[-90, 90\]"),
])
def test_non_finite_and_negative_scene_fields(field, value, match):
    with pytest.raises(ValueError, match=match):
        Scene(**{field: value})
    with pytest.raises(ValueError, match=match):  # the same from strings (CSV, --set)
        Scene.from_dict({field: str(value)})

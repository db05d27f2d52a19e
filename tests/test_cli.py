"""The `atmoscatter` command: render, batch, info, preview; one-line errors."""

import os
import subprocess
import sys

import numpy as np
import pytest

import atmoscatter as ac
from atmoscatter.cli import main
from atmoscatter.exr import read_exr

pytestmark = pytest.mark.usefixtures("toy_model")


TOY = ["--set", "model=toy", "--set", "sun_elevation_deg=30", "--set", "sun_azimuth_deg=200",
       "--set", "width=32", "--set", "height=16"]


def test_render_set_and_info(tmp_path, capsys):
    out = tmp_path / "sky.exr"
    assert main(["render", "-o", str(out), *TOY, "--set", "turbidity=5"]) == 0
    assert "wrote" in capsys.readouterr().out
    img = read_exr(out)
    assert img.rgb.shape == (16, 32, 3) and img.header["turbidity"] == "5.0"
    assert main(["info", str(out)]) == 0
    text = capsys.readouterr().out
    assert "turbidity          = 5.0" in text and "atmoscatter:version" in text
    assert "below horizon    : not evaluated" in text
    assert main(["info", str(out), "--json"]) == 0
    assert '"turbidity": "5.0"' in capsys.readouterr().out


def test_render_scene_file_and_preview(tmp_path, capsys):
    f = tmp_path / "scene.toml"
    f.write_text('model = "toy"\nsun_elevation_deg = 20.0\nwidth = 16\nheight = 8\n'
                 'projection = "fisheye"\n')
    out = tmp_path / "fish.exr"
    png = tmp_path / "fish.png"
    assert main(["render", str(f), "-o", str(out), "--preview", str(png)]) == 0
    assert read_exr(out).header["projection"] == "fisheye"
    assert png.read_bytes()[:4] == b"\x89PNG"
    png2 = tmp_path / "p2.png"
    assert main(["preview", str(out), "-o", str(png2), "--alpha", "sky", "--tone",
                 "reinhard"]) == 0
    assert png2.exists()


def test_explain_only(capsys, tmp_path):
    assert main(["render", "--explain", *TOY, "--set", "output=luminance"]) == 0
    text = capsys.readouterr().out
    assert "chromaticity     : skipped" in text and "below horizon" in text
    assert not list(tmp_path.iterdir())


@pytest.mark.parametrize("argv,match", [
    (["render", "-o", "x.exr", "--set", "turbidty=3"], "unknown scene field 'turbidty'"),
    (["render", "-o", "x.exr", "--set", "model=toy", "--set", "turbidity=0"],
     r"turbidity must be in \[1, inf\)"),
    (["render", "missing.toml", "-o", "x.exr"], "does not exist"),
    (["render", "--set", "model=toy", "--set", "sun_elevation_deg=10"], "needs an output file"),
    (["info", "nothing.exr"], "does not exist"),
    (["batch", "nothing.csv", "-o", "out"], "does not exist"),
])
def test_errors_are_one_line(argv, match, capsys, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.startswith("atmoscatter: error: ") and err.count("\n") == 1
    assert "Traceback" not in err
    import re

    assert re.search(match, err)
    assert not (tmp_path / "x.exr").exists()


def test_debug_shows_traceback():
    with pytest.raises(ValueError, match="turbidty"):
        main(["render", "-o", "x.exr", "--set", "turbidty=3", "--debug"])


def test_batch_command(tmp_path, capsys):
    csv = tmp_path / "s.csv"
    csv.write_text("name,model,turbidity,sun_elevation_deg,width,height\n"
                   "a,toy,2,30,16,8\nb,toy,-2,30,16,8\n")
    out = tmp_path / "out"
    assert main(["batch", str(csv), "-o", str(out), "--quiet"]) == 1  # one scene failed
    text = capsys.readouterr().out
    assert "1 rendered" in text and "FAILED b" in text
    assert (out / "a.exr").exists() and not (out / "b.exr").exists()
    assert main(["batch", str(csv), "-o", str(out), "--set", "turbidity=3", "--quiet",
                 "--no-resume"]) == 0
    assert read_exr(out / "b.exr").header["turbidity"] == "3.0"


def test_models_listing(capsys):
    assert main(["models"]) == 0
    assert "toy" in capsys.readouterr().out


def test_console_entry_point_error_in_subprocess(tmp_path):
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(
        [os.path.dirname(os.path.dirname(ac.__file__)), os.environ.get("PYTHONPATH", "")]))
    r = subprocess.run([sys.executable, "-m", "atmoscatter", "render", "-o", "x.exr",
                        "--set", "width=-3"], capture_output=True, text=True, cwd=tmp_path,
                       env=env, timeout=120)
    assert r.returncode == 2
    assert r.stderr.count("\n") == 1 and "Traceback" not in r.stderr
    assert "width" in r.stderr or "model" in r.stderr


@pytest.mark.skipif("preetham" not in ac.MODELS, reason="preetham_sky has not landed")
def test_readme_command_renders_default_sky(tmp_path):
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(
        [os.path.dirname(os.path.dirname(ac.__file__)), os.environ.get("PYTHONPATH", "")]))
    r = subprocess.run([sys.executable, "-m", "atmoscatter", "render", "-o", "sky.exr",
                        "--set", "width=128", "--set", "height=64"],
                       capture_output=True, text=True, cwd=tmp_path, env=env, timeout=300)
    assert r.returncode == 0, r.stderr
    img = read_exr(tmp_path / "sky.exr")
    assert img.header["model"] == "preetham" and img.header["time"].startswith("2024-06-21")
    sky = img.rgb[:32]
    assert np.all(np.isfinite(sky)) and sky.min() > 0


def test_batch_on_a_dask_scheduler_address(tmp_path, capsys):
    distributed = pytest.importorskip("dask.distributed")
    csv = tmp_path / "s.csv"
    csv.write_text("name,model,sun_elevation_deg,width,height\na,toy,30,16,8\nb,toy,50,16,8\n")
    with distributed.LocalCluster(processes=False, n_workers=1, threads_per_worker=2,
                                  dashboard_address=None) as cluster:
        code = main(["batch", str(csv), "-o", str(tmp_path / "out"), "--quiet",
                     "--scheduler", cluster.scheduler_address])
    assert code == 0
    assert "2 rendered" in capsys.readouterr().out
    assert read_exr(tmp_path / "out" / "b.exr").header["sun_elevation_deg"] == "50.0"


class _Tty:
    """A stderr stand-in that says it is a terminal and keeps what is written."""

    def __init__(self, tty=True):
        self.tty, self.parts = tty, []

    def isatty(self):
        return self.tty

    def write(self, s):
        self.parts.append(s)

    def flush(self):
        pass


def test_render_progress_is_off_when_quiet_or_not_a_terminal():
    from atmoscatter.cli import _render_progress

    for quiet, tty in ((True, True), (False, False)):
        with _render_progress(quiet=quiet, stream=_Tty(tty)) as progress:
            assert progress is None


def test_render_progress_bar_on_a_terminal(monkeypatch):
    pytest.importorskip("tqdm")
    import atmoscatter.cli as cli

    monkeypatch.setattr(cli, "PROGRESS_DELAY", 0.0)
    err = _Tty()
    with cli._render_progress(quiet=False, stream=err) as progress:
        img = ac.render(ac.Scene(model="toy", width=32, height=16), batch_size=64,
                        progress=progress)
    text = "".join(err.parts)
    assert img.alpha.size == 512 and "render" in text and "512" in text


def test_render_progress_bar_waits_for_long_renders():
    pytest.importorskip("tqdm")
    from atmoscatter.cli import _render_progress

    err = _Tty()
    with _render_progress(quiet=False, stream=err) as progress:  # default delay: ~2 s
        ac.render(ac.Scene(model="toy", width=32, height=16), batch_size=64, progress=progress)
    assert "render" not in "".join(err.parts)  # a short render draws no bar


def test_precompute_progress_shows_each_multiple_scattering_order(monkeypatch):
    """The multiple-scattering field build reports one stage per order; on a terminal
    each becomes a bar; quiet or off a terminal, no reporter is installed at all."""
    pytest.importorskip("tqdm")
    import atmoscatter.cli as cli
    from atmoscatter import _progress
    from atmoscatter.sky import multiple

    for quiet, tty in ((True, True), (False, False)):
        with cli._precompute_progress(quiet=quiet, stream=_Tty(tty)):
            assert not _progress.active()
    monkeypatch.setattr(cli, "PROGRESS_DELAY", 0.0)
    monkeypatch.setattr(multiple, "_RESULTS", {})
    monkeypatch.setattr(multiple, "_CACHE", type(multiple._CACHE)())
    monkeypatch.setenv("ATMOSCATTER_CACHE_DIR", "off")
    err = _Tty()
    # 10 solar-zenith nodes: with 6 the field's order 2 comes out brighter than order 1
    # near the horizon (GridTooCoarseError)
    grid = ac.MultipleScatteringGrid(n_altitude=4, n_sun=10, n_mu=4, n_phi=3, order=2)
    seen = []
    with cli._precompute_progress(quiet=False, stream=err):
        assert _progress.active()
        bar = _progress._REPORTER
        with _progress.reporting(lambda *a: (seen.append(a), bar(*a))):
            ac.multiple_scattering(ac.earth_atmosphere(), [[0.0, 0.0, 1.0]], [0.0, 0.6, 0.8],
                                   orders=4, grid=grid)
    assert not _progress.active()
    # first the node rays of each of the 4 altitudes are marched (shared by every sun);
    # orders=4: the fields of orders 1-3 are built (the gather adds the last order);
    # order 1 in 4 altitudes × 10 suns = 40 cells, the later orders in work units of a
    # few view zeniths of one altitude for every sun (the slice gather: 4 altitudes × 4
    # view zeniths here), every cell or unit reported once; after order 1 the phase
    # operators, one per distinct view-cosine quadrature (at most one per altitude)
    stages = [f"multiple scattering: order {k}" for k in (1, 2, 3)]
    phase = "multiple scattering: phase operators"
    assert list(dict.fromkeys(a[0] for a in seen)) == (
        ["multiple scattering: view rays", stages[0], phase] + stages[1:])
    assert sorted(d for s_, d, t in seen if s_ == "multiple scattering: view rays") == [1, 2, 3, 4]
    n_phase = [t for s_, d, t in seen if s_ == phase]
    assert 1 <= n_phase[0] <= 4 and sorted(d for s_, d, t in seen if s_ == phase) == list(
        range(1, n_phase[0] + 1))
    for st, n in zip(stages, (40, 16, 16), strict=True):
        assert sorted(d for s_, d, t in seen if s_ == st) == list(range(1, n + 1))
        assert {t for s_, d, t in seen if s_ == st} == {n}
        assert st in "".join(err.parts)


def test_progress_reporter_errors_are_ignored():
    from atmoscatter import _progress

    def broken(stage, done, total):
        raise RuntimeError("display broke")

    with _progress.reporting(broken):
        _progress.report("x", 1, 2)  # no exception
    assert not _progress.active()


def test_render_quiet_flag(tmp_path, capsys):
    out = tmp_path / "sky.exr"
    assert main(["render", "-o", str(out), *TOY, "--quiet"]) == 0
    assert "wrote" in capsys.readouterr().out and out.exists()

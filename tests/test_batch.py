"""Batch runs: tables and sweeps, resume, failure isolation, processes and Dask."""

import io
import json
import os
import signal
import subprocess
import sys
import textwrap
import time

import numpy as np
import pytest

import atmoscatter as ac
from atmoscatter.batch import (
    FINGERPRINT_KEY,
    BatchInterrupted,
    expand_sweep,
    load_batch,
    run_batch,
)
from atmoscatter.exr import read_exr

pytestmark = pytest.mark.usefixtures("toy_model")


CSV = """name,model,turbidity,sun_elevation_deg,sun_azimuth_deg,width,height
clear,toy,2,40,120,16,8
hazy,toy,6,40,120,16,8
broken,toy,-1,40,120,16,8
"""


def quiet():
    return None


class TestLoad:
    def test_csv(self, tmp_path):
        p = tmp_path / "s.csv"
        p.write_text(CSV)
        items = load_batch(p)
        assert [n for n, _ in items] == ["clear", "hazy", "broken"]
        assert items[1][1]["turbidity"] == "6" and items[1][1]["name"] == "hazy"

    def test_overrides_and_default_names(self, tmp_path):
        p = tmp_path / "s.csv"
        p.write_text("model,turbidity\ntoy,2\ntoy,3\n")
        items = load_batch(p, overrides={"width": "8"})
        assert [n for n, _ in items] == ["scene_00000", "scene_00001"]
        assert all(f["width"] == "8" for _, f in items)

    def test_bad_tables(self, tmp_path):
        p = tmp_path / "s.csv"
        p.write_text("name,turbidty\na,2\n")
        with pytest.raises(ValueError, match="unknown scene field 'turbidty'"):
            load_batch(p)
        p.write_text("name,turbidity\na,2\na,3\n")
        with pytest.raises(ValueError, match="duplicate name 'a'"):
            load_batch(p)
        p.write_text("name,turbidity\n../evil,2\n")
        with pytest.raises(ValueError, match="not a valid file stem"):
            load_batch(p)
        with pytest.raises(ValueError, match="does not exist"):
            load_batch(tmp_path / "nope.csv")

    def test_toml_with_sweep(self, tmp_path):
        p = tmp_path / "b.toml"
        p.write_text(
            '[base]\nmodel = "toy"\nwidth = 8\nheight = 4\nlatitude = 45.0\n'
            '[[scene]]\nname = "one"\nsun_elevation_deg = 10.0\n'
            '[sweep]\nname = "h_{time}_T{turbidity:g}"\nturbidity = [2, 3]\n'
            'time = { start = "2024-06-21T10:00:00Z", stop = "2024-06-21T12:00:00Z", step = "1h" }\n'
        )
        items = load_batch(p)
        names = [n for n, _ in items]
        assert names[0] == "one" and len(items) == 1 + 2 * 3
        assert "h_2024-06-21T100000Z_T2" in names  # ":" dropped from file stems
        assert all(f["width"] == 8 for _, f in items)

    def test_sweep_every_hour_of_a_year(self):
        rows = expand_sweep({"time": {"start": "2023-01-01T00:00:00Z",
                                      "stop": "2023-12-31T23:00:00Z", "step": "1h"}})
        assert len(rows) == 8760 and rows[-1]["time"] == "2023-12-31T23:00:00Z"
        assert rows[0]["name"] == "sky_00000"
        rows = expand_sweep({"turbidity": {"start": 2, "stop": 3, "step": 0.5}})
        assert [r["turbidity"] for r in rows] == [2.0, 2.5, 3.0]
        with pytest.raises(ValueError, match="step must look like"):
            expand_sweep({"time": {"start": "2023-01-01", "stop": "2023-01-02", "step": "x"}})


def test_many_suns_on_the_default_multiple_scattering_grid_get_a_table_hint():
    """Ten or more multiple-scattering scenes of one atmosphere with distinct suns on the
    default grid (a field each) are told about ms_grid=table (one field for all); fewer
    suns, another grid set, other models or the suns spread over atmospheres are not."""
    from atmoscatter.batch.run import MS_TABLE_HINT_SUNS, ms_grid_hint

    def rows(n, **extra):
        return [(f"s{k}", {"model": "multiple_scattering", "sun_elevation_deg": 5.0 + k,
                           **extra}, "") for k in range(n)]

    n = MS_TABLE_HINT_SUNS
    hint = ms_grid_hint(rows(n))
    assert hint is not None and f"{n} multiple_scattering scenes" in hint
    assert "ms_grid=table" in hint
    assert ms_grid_hint(rows(n - 1)) is None
    assert ms_grid_hint(rows(n, ms_grid="table")) is None
    assert ms_grid_hint(rows(n, ms_grid="accurate")) is None
    assert ms_grid_hint([(a, dict(f, model="preetham"), b) for a, f, b in rows(n)]) is None
    # the same sun n times: one field
    assert ms_grid_hint([(f"s{k}", {"model": "multiple_scattering"}, "") for k in range(n)]) is None
    # n suns over two atmospheres: fewer than n per field
    spread = [(a, dict(f, turbidity=2 + k % 2), b) for k, (a, f, b) in enumerate(rows(n))]
    assert ms_grid_hint(spread) is None


class TestRun:
    def test_failure_isolated_and_summary(self, tmp_path):
        p = tmp_path / "s.csv"
        p.write_text(CSV)
        out = tmp_path / "out"
        summary = run_batch(load_batch(p), out, progress=None)
        assert summary.count("done") == 2 and summary.count("failed") == 1
        assert not summary.ok
        bad = summary.failed[0]
        assert bad.name == "broken" and "turbidity must be in [1, inf)" in bad.error
        assert sorted(os.listdir(out)) == ["batch_summary.json", "clear.exr", "hazy.exr"]
        h = read_exr(out / "hazy.exr").header
        assert h["turbidity"] == "6.0" and h["name"] == "hazy"
        data = json.loads((out / "batch_summary.json").read_text())
        assert data["failed"] == 1 and data["done"] == 2
        assert "FAILED broken" in summary.text()

    def test_resume_skips_complete_and_redoes_partial(self, tmp_path, capsys):
        p = tmp_path / "s.csv"
        p.write_text(CSV)
        out = tmp_path / "out"
        run_batch(load_batch(p), out, progress=None)
        mtime = os.path.getmtime(out / "clear.exr")
        # a truncated output (e.g. a killed copy) and a leftover temp file of a killed write
        data = (out / "hazy.exr").read_bytes()
        (out / "hazy.exr").write_bytes(data[:200])
        (out / ".hazy.exr.abc123.tmp").write_bytes(b"partial")
        log = io.StringIO()  # an explicit non-terminal stream gets one line per scene
        summary = run_batch(load_batch(p), out, progress=log)
        status = {r.name: r.status for r in summary.results}
        assert status == {"clear": "skipped", "hazy": "done", "broken": "failed"}
        assert os.path.getmtime(out / "clear.exr") == mtime
        assert read_exr(out / "hazy.exr").rgb.shape == (8, 16, 3)
        assert not (out / ".hazy.exr.abc123.tmp").exists()
        assert "3/3" in log.getvalue() and "hazy: done" in log.getvalue()
        # resume=False re-renders everything
        again = run_batch(load_batch(p), out, progress=None, resume=False)
        assert again.count("skipped") == 0 and again.count("done") == 2

    def test_local_processes(self, tmp_path):
        p = tmp_path / "s.csv"
        p.write_text(CSV)
        summary = run_batch(load_batch(p), tmp_path / "out", workers=2, progress=None)
        assert summary.count("done") == 2 and summary.count("failed") == 1
        ref = run_batch(load_batch(p), tmp_path / "ref", progress=None)
        assert ref.count("done") == 2
        np.testing.assert_array_equal(read_exr(tmp_path / "out" / "clear.exr").rgb,
                                      read_exr(tmp_path / "ref" / "clear.exr").rgb)


def test_dask_local_cluster(tmp_path):
    distributed = pytest.importorskip("dask.distributed")
    p = tmp_path / "s.csv"
    p.write_text(CSV)
    with distributed.LocalCluster(processes=False, n_workers=1, threads_per_worker=2,
                                  dashboard_address=None) as cluster, \
            distributed.Client(cluster) as client:
        summary = run_batch(load_batch(p), tmp_path / "out", client=client, progress=None)
    assert summary.count("done") == 2 and summary.count("failed") == 1
    assert read_exr(tmp_path / "out" / "clear.exr").header["model"] == "toy"


class TestCsvMalformed:
    """Malformed tables are errors naming the file and the line; Excel's BOM is fine."""

    def test_utf8_bom(self, tmp_path):
        p = tmp_path / "excel.csv"
        p.write_bytes("\ufeffname,model,turbidity\na,toy,2\n".encode())
        assert load_batch(p)[0][0] == "a"

    @pytest.mark.parametrize("text,match", [
        ("name,turbidity\na,2,9\n", r"line 2 has 3 cells, more than the 2 columns"),
        ("name,turbidity,width\na,2,8\nb,3\n", r"line 3 has 2 cells, fewer than the 3 columns"),
        ("name,turbidity,turbidity\na,2,3\n", r"duplicate column 'turbidity' \(columns 2 and 3\)"),
        ("name,,turbidity\na,,2\n", r"column 2 has no name"),
    ])
    def test_bad_rows_name_the_line(self, tmp_path, text, match):
        p = tmp_path / "s.csv"
        p.write_text(text)
        with pytest.raises(ValueError, match=match) as exc:
            load_batch(p)
        assert str(p) in str(exc.value)

    def test_blank_lines_are_skipped(self, tmp_path):
        p = tmp_path / "s.csv"
        p.write_text("name,turbidity\na,2\n\n,\nb,3\n")
        assert [n for n, _ in load_batch(p)] == ["a", "b"]

    def test_not_utf8(self, tmp_path):
        p = tmp_path / "latin1.csv"
        p.write_bytes("name,model\nZürich,toy\n".encode("latin-1"))
        with pytest.raises(ValueError, match="not UTF-8") as exc:
            load_batch(p)
        assert str(p) in str(exc.value)


class TestRunInputs:
    @pytest.mark.parametrize("workers", [0, -3])
    def test_workers_must_be_positive(self, tmp_path, workers):
        p = tmp_path / "s.csv"
        p.write_text(CSV)
        with pytest.raises(ValueError, match=rf"workers must be an integer in \[1, inf\), got {workers}"):
            run_batch(load_batch(p), tmp_path / "out", workers=workers, progress=None)
        assert not (tmp_path / "out").exists() or not list((tmp_path / "out").iterdir())

    def test_unwritable_output_directory_before_rendering(self, tmp_path, monkeypatch):
        p = tmp_path / "s.csv"
        p.write_text(CSV)
        blocker = tmp_path / "file"
        blocker.write_text("not a directory")
        calls = []
        monkeypatch.setattr("atmoscatter.batch.run._render_one", lambda *a: calls.append(a))
        with pytest.raises(ValueError, match="cannot write output directory") as exc:
            run_batch(load_batch(p), blocker / "out", progress=None)
        assert str(blocker / "out") in str(exc.value) and ".tmp" not in str(exc.value)
        assert calls == []


class TestResumeFingerprint:
    def test_changed_row_is_rendered_again(self, tmp_path):
        p = tmp_path / "s.csv"
        p.write_text(CSV)
        out = tmp_path / "out"
        run_batch(load_batch(p), out, progress=None)
        assert len(read_exr(out / "clear.exr").header[FINGERPRINT_KEY]) == 64
        clear_mtime = os.path.getmtime(out / "clear.exr")
        old_hazy = read_exr(out / "hazy.exr").rgb
        p.write_text(CSV.replace("hazy,toy,6,", "hazy,toy,9,"))
        summary = run_batch(load_batch(p), out, progress=None)
        status = {r.name: r.status for r in summary.results}
        assert status == {"clear": "skipped", "hazy": "done", "broken": "failed"}
        assert os.path.getmtime(out / "clear.exr") == clear_mtime
        img = read_exr(out / "hazy.exr")
        assert img.header["turbidity"] == "9.0"
        # the toy sky grows by 1000 cd/m^2 per unit of turbidity: the sky pixels changed too
        # (rows 0-3 are above the horizon; the ground below is 0 in both)
        assert np.all(img.rgb[:4, :, 1] > old_hazy[:4, :, 1] + 2000.0)
        # the --set overrides are part of the scene as well
        again = run_batch(load_batch(p, overrides={"turbidity": "9"}), out, progress=None)
        assert {r.name: r.status for r in again.results}["clear"] == "done"

    def test_new_package_version_renders_again(self, tmp_path, monkeypatch):
        p = tmp_path / "s.csv"
        p.write_text(CSV)
        out = tmp_path / "out"
        run_batch(load_batch(p), out, progress=None)
        assert run_batch(load_batch(p), out, progress=None).count("skipped") == 2
        monkeypatch.setattr(ac, "__version__", "99.0.0")
        assert run_batch(load_batch(p), out, progress=None).count("done") == 2

    def test_changed_numerical_default_changes_the_fingerprint(self, monkeypatch):
        """A new default multiple-scattering grid (or single-scattering table setting)
        changes the values of physical renders: their files must not be kept."""
        from dataclasses import replace

        from atmoscatter.batch import scene_fingerprint
        from atmoscatter.scene import Scene
        from atmoscatter.sky import multiple, single

        ms_scene = Scene(model="multiple_scattering", width=8, height=4)
        ss_scene = Scene(model="single_scattering", width=8, height=4)
        an_scene = Scene(model="preetham", width=8, height=4)
        before = [scene_fingerprint(s) for s in (ms_scene, ss_scene, an_scene)]
        # the renderer takes its grids from the named grids (Scene.ms_grid)
        acc_scene = Scene(model="multiple_scattering", ms_grid="accurate", width=8, height=4)
        acc_before = scene_fingerprint(acc_scene)
        monkeypatch.setitem(multiple.MULTIPLE_SCATTERING_GRIDS, "default",
                            replace(multiple.MULTIPLE_SCATTERING_GRID, n_phi=5))
        after = [scene_fingerprint(s) for s in (ms_scene, ss_scene, an_scene)]
        assert after[0] != before[0] and after[1:] == before[1:]
        monkeypatch.setitem(multiple.MULTIPLE_SCATTERING_GRIDS, "accurate",
                            replace(multiple.ACCURATE_MULTIPLE_SCATTERING_GRID, n_phi=5))
        assert scene_fingerprint(acc_scene) != acc_before
        monkeypatch.setattr(single, "TWILIGHT_TABLE_THRESHOLD", 7)
        assert scene_fingerprint(ss_scene) != before[1]
        assert scene_fingerprint(an_scene) == before[2]

    def test_file_without_fingerprint_is_rendered_again(self, tmp_path):
        from atmoscatter.exr import write_exr
        from atmoscatter.render import render

        p = tmp_path / "s.csv"
        p.write_text("name,model,sun_elevation_deg,width,height\na,toy,30,16,8\n")
        out = tmp_path / "out"
        write_exr(out / "a.exr", render({"model": "toy", "sun_elevation_deg": 30,
                                         "width": 16, "height": 8, "name": "a"}))
        assert run_batch(load_batch(p), out, progress=None).count("done") == 1


class TestProgress:
    class _Tty(io.StringIO):
        def isatty(self):
            return True

    def test_quiet_when_stderr_is_not_a_terminal(self, tmp_path, capsys):
        p = tmp_path / "s.csv"
        p.write_text(CSV)
        run_batch(load_batch(p), tmp_path / "out", progress=True)
        assert capsys.readouterr().err == ""

    def test_bar_on_a_terminal(self, tmp_path):
        pytest.importorskip("tqdm")
        p = tmp_path / "s.csv"
        p.write_text(CSV)
        tty = self._Tty()
        run_batch(load_batch(p), tmp_path / "out", progress=tty)
        text = tty.getvalue()
        assert "3/3" in text and "scene" in text and "FAILED broken" in text


# ----------------------------------------------------------------------------
# stopping a running batch (subprocesses with a slow model)
# ----------------------------------------------------------------------------
_SLOW_BATCH = textwrap.dedent("""
    import sys, time
    import numpy as np
    from atmoscatter.cli import run
    from atmoscatter.render import ModelAdapter, register_model

    def prepare(scene, plan):
        def evaluate(d):
            time.sleep(float(sys.argv[3]))  # a slow sky: a sleeping model costs no CPU
            y = 1000.0 + 0.0 * d[:, 2]
            return {"XYZ": np.stack([y, y, y], -1)}
        return evaluate

    register_model(ModelAdapter(name="slow", description="slow toy", prepare=prepare,
                                error_estimate="exact"))
    run(["batch", sys.argv[1], "-o", sys.argv[2], "--workers", "2"])  # the console script
""")


def _children(pid):
    """PIDs whose parent is ``pid`` (Linux /proc)."""
    out = []
    for d in os.listdir("/proc"):
        if d.isdigit():
            try:
                with open(f"/proc/{d}/stat") as fh:
                    fields = fh.read().rsplit(")", 1)[1].split()
            except OSError:
                continue
            if int(fields[1]) == pid:
                out.append(int(d))
    return out


def _alive(pid):
    try:
        with open(f"/proc/{pid}/stat") as fh:
            return fh.read().rsplit(")", 1)[1].split()[0] != "Z"  # zombies are gone
    except OSError:
        return False


def _start_slow_batch(tmp_path, n=24, seconds=1.0):
    script = tmp_path / "slow_batch.py"
    script.write_text(_SLOW_BATCH)
    csv = tmp_path / "long.csv"
    csv.write_text("name,model,sun_elevation_deg,width,height\n"
                   + "".join(f"s{i:02d},slow,30,16,8\n" for i in range(n)))
    out = tmp_path / "out"
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(
        [os.path.dirname(os.path.dirname(ac.__file__)), os.environ.get("PYTHONPATH", "")]))
    proc = subprocess.Popen([sys.executable, str(script), str(csv), str(out), str(seconds)],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env,
                            start_new_session=True)
    # wait until the workers run and the first scenes are written
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline:
        if len(list(out.glob("*.exr"))) >= 2 and len(_children(proc.pid)) >= 2:
            break
        if proc.poll() is not None:
            pytest.fail(f"the batch ended early: {proc.communicate()}")
        time.sleep(0.05)
    else:  # pragma: no cover
        proc.kill()
        pytest.fail("the batch did not start")
    return proc, out, [c for c in _children(proc.pid)]


def _no_partial_files(out):
    assert not [f for f in os.listdir(out) if f.endswith(".tmp")]
    for f in out.glob("*.exr"):
        assert read_exr(f).rgb.shape == (8, 16, 3)


@pytest.mark.parametrize("how", ["SIGINT to the process group (Ctrl-C)", "SIGTERM to the parent"])
def test_signal_stops_the_whole_batch(tmp_path, how):
    n = 24
    proc, out, workers = _start_slow_batch(tmp_path, n=n)
    assert len(workers) >= 2
    if how.startswith("SIGINT"):
        os.killpg(proc.pid, signal.SIGINT)
    else:
        os.kill(proc.pid, signal.SIGTERM)
    try:
        # 24 scenes of >= 1 s on 2 workers need >= 12 s; stopping must take far less (the
        # bound is loose for a loaded machine but below the time the batch would need)
        stdout, stderr = proc.communicate(timeout=8)
    except subprocess.TimeoutExpired:  # pragma: no cover
        os.killpg(proc.pid, signal.SIGKILL)
        pytest.fail("the batch did not stop after the signal")
    assert proc.returncode == (130 if how.startswith("SIGINT") else 143), stderr
    assert "Traceback" not in stderr
    assert "interrupted by SIG" in stdout and "not finished" in stdout
    deadline = time.monotonic() + 5
    while any(_alive(w) for w in workers) and time.monotonic() < deadline:
        time.sleep(0.05)
    assert not [w for w in workers if _alive(w)], "worker processes survived"
    _no_partial_files(out)
    written = len(list(out.glob("*.exr")))
    assert 2 <= written < n
    summary = json.loads((out / "batch_summary.json").read_text())
    assert summary["interrupted"] in ("SIGINT", "SIGTERM")
    assert summary["done"] == written and summary["unfinished"] == n - written
    # resume: a rerun renders only what is missing
    time.sleep(0.1)
    proc2 = subprocess.run([sys.executable, str(tmp_path / "slow_batch.py"),
                            str(tmp_path / "long.csv"), str(out), "0"],
                           capture_output=True, text=True, timeout=120,
                           env=dict(os.environ, PYTHONPATH=os.pathsep.join(
                               [os.path.dirname(os.path.dirname(ac.__file__)),
                                os.environ.get("PYTHONPATH", "")])))
    assert proc2.returncode == 0, proc2.stderr
    assert f"{n - written} rendered, {written} already complete" in proc2.stdout


def test_workers_stop_when_the_parent_is_killed(tmp_path):
    proc, out, workers = _start_slow_batch(tmp_path)
    os.kill(proc.pid, signal.SIGKILL)  # no chance to clean up: the workers must notice
    proc.communicate(timeout=30)
    deadline = time.monotonic() + 15
    while any(_alive(w) for w in workers) and time.monotonic() < deadline:
        time.sleep(0.1)
    assert not [w for w in workers if _alive(w)], "orphaned worker processes"
    _no_partial_files(out)


def test_interrupt_in_process_returns_a_summary(tmp_path, monkeypatch):
    """KeyboardInterrupt while rendering in this process: BatchInterrupted with the summary."""
    from atmoscatter.batch import run as batch

    p = tmp_path / "s.csv"
    p.write_text(CSV)
    real = batch._render_one

    def render_then_interrupt(name, *a):
        if name == "hazy":
            raise KeyboardInterrupt
        return real(name, *a)

    monkeypatch.setattr(batch, "_render_one", render_then_interrupt)
    with pytest.raises(BatchInterrupted) as exc:
        run_batch(load_batch(p), tmp_path / "out", progress=None)
    s = exc.value.summary
    assert {r.name: r.status for r in s.results} == {"clear": "done", "hazy": "unfinished",
                                                     "broken": "unfinished"}
    assert "interrupted by SIGINT" in s.text()
    assert json.loads((tmp_path / "out" / "batch_summary.json").read_text())["unfinished"] == 2

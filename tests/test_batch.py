"""Batch runs: tables and sweeps, resume, failure isolation, processes and Dask."""

import json
import os

import numpy as np
import pytest

from atmoscatter.batch import expand_sweep, load_batch, run_batch
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
        summary = run_batch(load_batch(p), out, progress=True)
        status = {r.name: r.status for r in summary.results}
        assert status == {"clear": "skipped", "hazy": "done", "broken": "failed"}
        assert os.path.getmtime(out / "clear.exr") == mtime
        assert read_exr(out / "hazy.exr").rgb.shape == (8, 16, 3)
        assert not (out / ".hazy.exr.abc123.tmp").exists()
        err = capsys.readouterr().err
        assert "3/3" in err and "hazy: done" in err
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

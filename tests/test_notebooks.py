"""The example notebooks (notebooks/*.ipynb): stored outputs, and they still run.

Two kinds of checks:

* **stored outputs** (no execution, cheap): every committed notebook was executed top to
  bottom in one run by ``scripts/run_notebooks.py`` — every code cell has its execution
  count in order, the notebook has outputs, none of them is an error, and the metadata
  that changes from run to run (timestamps, Python version) is not stored;
* **execution**: each notebook runs top to bottom in a fresh kernel (nbclient, with the
  settings of ``scripts/run_notebooks.py``); any exception — including the ``assert``
  lines the notebooks carry — fails the test, and every code cell that prints or plots
  now must have stored outputs of the same kinds (stream / MIME types), so a cell added
  or changed without re-running the script is caught.  Notebooks marked
  ``"atmoscatter": {"extended": true}`` in their metadata (more than ~10 s) run only with
  ``-m extended``, those marked ``"slow": true`` (minutes) only with ``-m slow``.

A notebook whose package features have not landed in this checkout is skipped with the
missing names (never silently passed).
"""

from __future__ import annotations

import importlib.util
import json
from pathlib import Path

import pytest

import atmoscatter as ac

nbformat = pytest.importorskip("nbformat")
nbclient = pytest.importorskip("nbclient")

ROOT = Path(__file__).resolve().parents[1]
NOTEBOOKS = ROOT / "notebooks"

_spec = importlib.util.spec_from_file_location("run_notebooks", ROOT / "scripts" / "run_notebooks.py")
run_notebooks = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(run_notebooks)

REQUIRES = {
    "quickstart": ("render", "write_exr", "read_exr", "write_preview", "preetham_sky",
                   "diffuse_irradiance", "sh_project"),
    "batch": ("load_batch", "run_batch"),
    "oracle": ("render", "preetham_sky", "compare_exr", "sh_project"),
    "models": ("render", "plan", "MODELS", "write_exr", "read_exr", "write_preview",
               "preview_array"),
    "weather_year": ("weather_batch", "run_batch", "read_exr", "latlong_quadrature",
                     "diffuse_irradiance", "preview_array", "perez_epsilon_bin"),
    "noon_to_night": ("render", "plan", "preview_array", "diffuse_irradiance",
                      "single_scattering", "multiple_scattering"),
    "error_vs_runtime": ("single_scattering", "multiple_scattering",
                         "convergence.CANONICAL_SCENES", "convergence.convergence_study",
                         "earth_turbidity_atmosphere"),
}
#: optional packages a notebook needs beyond the test extra's notebook runner
OPTIONAL = {"weather_year": ("pvlib", "matplotlib")}


def _params():
    out = []
    for name in sorted(REQUIRES):
        path = NOTEBOOKS / f"{name}.ipynb"
        t = run_notebooks.tier(path) if path.is_file() else "quick"
        marks = {"quick": [], "extended": [pytest.mark.extended], "slow": [pytest.mark.slow]}
        out.append(pytest.param(name, marks=marks[t]))
    return out


def _kinds(cell) -> list:
    """What a code cell shows, output by output: stream name or sorted MIME types."""
    kinds = []
    for o in cell.get("outputs", []):
        if o["output_type"] == "stream":
            kind = ("stream", o["name"])
        elif o["output_type"] in ("display_data", "execute_result"):
            kind = ("data", tuple(sorted(o.get("data", {}))))
        else:
            kind = (o["output_type"],)
        if not kinds or kinds[-1] != kind:  # a stream may arrive in one piece or several
            kinds.append(kind)
    return kinds


def _has(dotted: str) -> bool:
    """Whether ``atmoscatter.<dotted>`` exists (a name of the package or of a submodule)."""
    mod, _, attr = dotted.rpartition(".")
    try:
        obj = importlib.import_module(f"atmoscatter.{mod}") if mod else ac
    except ImportError:
        return False
    return hasattr(obj, attr)


def test_every_notebook_requirement_exists():
    """A misspelt requirement would skip its notebook silently: every name must resolve."""
    assert not [n for names in REQUIRES.values() for n in names if not _has(n)]


def test_every_notebook_is_listed():
    assert {p.stem for p in NOTEBOOKS.glob("*.ipynb")} == set(REQUIRES)


@pytest.mark.parametrize("name", sorted(REQUIRES))
def test_notebook_has_stored_outputs(name):
    raw = json.loads((NOTEBOOKS / f"{name}.ipynb").read_text(encoding="utf-8"))
    code = [c for c in raw["cells"] if c["cell_type"] == "code"]
    assert code, f"{name}: no code cells"
    counts = [c.get("execution_count") for c in code]
    assert counts == list(range(1, len(code) + 1)), (
        f"{name}: execution counts {counts}: not executed top to bottom in one run "
        "(run python scripts/run_notebooks.py)")
    assert sum(bool(c.get("outputs")) for c in code) >= max(1, len(code) // 2), (
        f"{name}: most code cells have no stored output (run python scripts/run_notebooks.py)")
    errors = [o.get("ename") for c in code for o in c.get("outputs", [])
              if o.get("output_type") == "error"]
    assert not errors, f"{name}: stored error outputs {errors}"
    assert set(raw["metadata"]) <= {"kernelspec", "language_info", "atmoscatter"}, raw["metadata"]
    assert raw["metadata"].get("language_info", {}) == {"name": "python"}
    assert not any("execution" in c.get("metadata", {}) for c in raw["cells"]), (
        f"{name}: execution timestamps stored")


def test_stored_output_check_can_fail(tmp_path):
    """The kinds comparison of the execution test tells a missing output from a present one."""
    cell = nbformat.v4.new_code_cell("print(1)")
    assert _kinds(cell) == []
    cell.outputs = [nbformat.v4.new_output("stream", name="stdout", text="1\n"),
                    nbformat.v4.new_output("stream", name="stdout", text="2\n")]
    assert _kinds(cell) == [("stream", "stdout")]
    cell.outputs.append(nbformat.v4.new_output("display_data", data={"image/png": "", "text/plain": ""}))
    assert _kinds(cell) == [("stream", "stdout"), ("data", ("image/png", "text/plain"))]


@pytest.mark.parametrize("name", _params())
def test_notebook_runs(name, tmp_path):
    missing = [n for n in REQUIRES[name] if not _has(n)]
    if missing:
        pytest.skip(f"atmoscatter lacks {missing} in this checkout")
    for module in OPTIONAL.get(name, ()):
        pytest.importorskip(module, reason=f"notebook {name} needs {module}")
    path = NOTEBOOKS / f"{name}.ipynb"
    stored = nbformat.read(str(path), as_version=4)
    fresh, _cpu, _wall = run_notebooks.execute(path, tmp_path, timeout=1800)
    assert not run_notebooks.errors(fresh)
    stale = []
    for i, (old, new) in enumerate(zip(stored.cells, fresh.cells, strict=True)):
        if new.cell_type == "code" and _kinds(old) != _kinds(new):
            stale.append(f"cell {i}: stored {_kinds(old)}, now {_kinds(new)}")
    assert not stale, (f"{name}: stored outputs do not match a fresh run (run python "
                       "scripts/run_notebooks.py " + name + "):\n" + "\n".join(stale))

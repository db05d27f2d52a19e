"""A light start-up: what ``import atmoscatter`` and ``atmoscatter --help`` import, and what
the package exports.

The heavy dependencies (numba ~0.2 s, colour-science ~1.5 s with SciPy and Matplotlib,
OpenEXR) are imported inside the functions that need them; these tests run the imports in a
fresh interpreter and fail if one of them is loaded.  (Import *times* are measured in
``benchmarks/bench_startup.py``, not here.)
"""

import json
import os
import subprocess
import sys
import types

import pytest

import atmoscatter as ac

HEAVY = ("numba", "scipy", "colour", "matplotlib", "OpenEXR", "tqdm")

_REPORT = (
    "import json, sys; "
    f"print(json.dumps(sorted(m for m in {HEAVY!r} if m in sys.modules)))"
)


def _env():
    root = os.path.dirname(os.path.dirname(ac.__file__))
    return dict(os.environ, PYTHONPATH=os.pathsep.join([root, os.environ.get("PYTHONPATH", "")]))


def _heavy_modules_after(code: str) -> list[str]:
    r = subprocess.run([sys.executable, "-c", code + "\n" + _REPORT], capture_output=True,
                       text=True, env=_env(), timeout=120)
    assert r.returncode == 0, r.stderr
    return json.loads(r.stdout.strip().splitlines()[-1])


def test_import_does_not_load_heavy_dependencies():
    assert _heavy_modules_after("import atmoscatter") == []


def test_help_does_not_load_heavy_dependencies():
    code = ("import contextlib, io, runpy, sys\n"
            "sys.argv = ['atmoscatter', '--help']\n"
            "with contextlib.redirect_stdout(io.StringIO()), contextlib.suppress(SystemExit):\n"
            "    runpy.run_module('atmoscatter', run_name='__main__')\n")
    assert _heavy_modules_after(code) == []
    code_render = code.replace("'--help'", "'render', '--help'")
    assert _heavy_modules_after(code_render) == []


def test_help_runs_as_a_module():
    r = subprocess.run([sys.executable, "-m", "atmoscatter", "--help"], capture_output=True,
                       text=True, env=_env(), timeout=120)
    assert r.returncode == 0 and "render" in r.stdout


def test_scene_validation_and_plan_do_not_load_colour_science():
    code = ("import atmoscatter as ac\n"
            "ac.plan(ac.Scene(colourspace='ITU-R BT.2020'))\n"
            "ac.plan(ac.Scene(colourspace='acescg'))\n"
            "try:\n"
            "    ac.Scene(colourspace='sRGBB')\n"
            "except ValueError:\n"
            "    pass\n"
            "else:\n"
            "    raise SystemExit('sRGBB accepted')\n"
            "ac.XYZ_to_linear_rgb([1.0, 1.0, 1.0], 'ACEScg')\n")
    loaded = _heavy_modules_after(code)
    assert "colour" not in loaded and "matplotlib" not in loaded and "scipy" not in loaded


def test_spectral_colour_conversion_does_not_load_colour_science():
    """The physical models integrate spectra with the shipped CIE 1931 CMF table."""
    code = ("import atmoscatter as ac\n"
            "ac.spectral_to_XYZ([[1.0, 2.0, 3.0]], [450.0, 550.0, 650.0])\n"
            "ac.cmf_weights([400.0, 500.0, 600.0, 700.0])\n")
    loaded = _heavy_modules_after(code)
    assert "colour" not in loaded and "matplotlib" not in loaded and "scipy" not in loaded


def test_all_lists_exactly_the_public_names():
    public = {n for n in dir(ac)
              if not n.startswith("_") and not isinstance(getattr(ac, n), types.ModuleType)}
    assert set(ac.__all__) == public
    assert len(ac.__all__) == len(set(ac.__all__))
    assert "annotations" not in dir(ac)  # no ``from __future__ import annotations`` leak
    for n in ("render", "Scene", "preetham_sky", "XYZ_to_linear_rgb", "colourspace_names"):
        assert n in ac.__all__


def test_star_import_gives_the_public_api():
    ns: dict = {}
    exec("from atmoscatter import *", ns)  # noqa: S102
    assert {n for n in ns if n != "__builtins__"} == set(ac.__all__)


@pytest.mark.parametrize("mod", ["atmoscatter.sky._preetham_kernels",
                                 "atmoscatter.render._direction_kernels"])
def test_kernel_modules_are_private_and_cached(mod):
    """The compiled kernels live in private modules and keep numba's on-disk cache."""
    pytest.importorskip("numba")
    import importlib

    m = importlib.import_module(mod)
    kernels = [v for v in vars(m).values() if hasattr(v, "py_func")]
    assert kernels and all(k.targetoptions.get("nogil") for k in kernels)
    assert all(k._cache.__class__.__name__ == "FunctionCache" for k in kernels)

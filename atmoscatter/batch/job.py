"""One scene of a batch: its fingerprint (what the rendered file depends on), the check that
an existing file is complete and up to date, and the render of one scene to its file, which
never raises (a failure becomes a result)."""

from __future__ import annotations

import hashlib
import json
import os
import time

from .results import BatchResult

#: EXR header attribute holding :func:`scene_fingerprint` of the scene a batch file was
#: rendered from; resume re-renders a file whose fingerprint differs (or is missing).
FINGERPRINT_KEY = "atmoscatter:scene_hash"


def _numerical_defaults(model: str) -> dict:
    """The numerical defaults a physical model's values depend on (a change of the default
    multiple-scattering grid, say, must re-render files made with the old one)."""
    if model not in ("single_scattering", "multiple_scattering"):
        return {}
    from ..sky import multiple, single  # noqa: PLC0415

    out = {"single": [single.DEFAULT_SINGLE_SCATTERING_METHOD,
                      single.DEFAULT_SINGLE_SCATTERING_SAMPLES, single.TABLE_THRESHOLD,
                      single.TWILIGHT_TABLE_THRESHOLD, single.TABLE_FLOOR]}
    if model == "multiple_scattering":
        # every named grid (Scene.ms_grid selects one by name: a change of either grid
        # must re-render the files made with it)
        out["multiple"] = [{k: repr(g) for k, g in multiple.MULTIPLE_SCATTERING_GRIDS.items()},
                           multiple._FIELD_VERSION, multiple._SUM_RULE]
    return out


def scene_fingerprint(scene) -> str:
    """SHA-256 over what a rendered file depends on: every scene field, the package
    version, the model's registration (name, description), the measured defaults of
    ``sampling = "auto"`` and, for the physical models, their numerical defaults (the
    multiple-scattering grid and field version, the single-scattering table settings);
    for a custom atmosphere file, its bytes.

    Batch resume keeps an existing output only when the fingerprint stored in its header
    (:data:`FINGERPRINT_KEY`) equals that of the scene asked for now.

    Parameters
    ----------
    scene : Scene
        The scene of one output.

    Returns
    -------
    str
        Hexadecimal SHA-256 digest.
    """
    from .. import __version__  # noqa: PLC0415
    from ..render.models import MODELS  # noqa: PLC0415
    from ..render.plan import auto_sampling_rule  # noqa: PLC0415
    from ..scene import is_atmosphere_file  # noqa: PLC0415

    adapter = MODELS.get(scene.model)
    payload = {"scene": scene.to_strings(), "version": __version__,
               "model": [scene.model, getattr(adapter, "description", "")],
               "auto_sampling": auto_sampling_rule(),
               "numerics": _numerical_defaults(scene.model)}
    if is_atmosphere_file(scene.atmosphere):
        try:
            with open(scene.atmosphere, "rb") as fh:
                payload["atmosphere_file"] = hashlib.sha256(fh.read()).hexdigest()
        except OSError:
            payload["atmosphere_file"] = "unreadable"
    text = json.dumps(payload, sort_keys=True, default=str)
    return hashlib.sha256(text.encode("utf-8")).hexdigest()


def _render_one(name: str, fields: dict, out_path: str, threads: int | None = 1,
                batch_size: int | None = None) -> BatchResult:
    """Render one scene to ``out_path``; never raises (errors become a failed result)."""
    t0 = time.perf_counter()
    try:
        from ..exr import write_exr  # noqa: PLC0415
        from ..render import render  # noqa: PLC0415
        from ..scene import Scene  # noqa: PLC0415

        scene = Scene.from_dict(fields)
        img = render(scene, workers=threads, batch_size=batch_size)
        img.metadata[FINGERPRINT_KEY] = scene_fingerprint(scene)
        write_exr(out_path, img)
        return BatchResult(name, out_path, "done", time.perf_counter() - t0)
    except Exception as exc:  # failure isolation: report and carry on
        msg = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        return BatchResult(name, out_path, "failed", time.perf_counter() - t0,
                           f"{type(exc).__name__}: {msg}")


def _up_to_date(path: str, fields: dict) -> bool:
    """True if ``path`` is a complete EXR rendered from exactly this scene (fingerprint)."""
    from ..exr import read_exr  # noqa: PLC0415
    from ..scene import Scene  # noqa: PLC0415

    if not os.path.isfile(path):
        return False
    try:
        img = read_exr(path)
        if not img.channels:
            return False
        return img.header.get(FINGERPRINT_KEY) == scene_fingerprint(Scene.from_dict(fields))
    except Exception:  # unreadable, truncated, or a scene that no longer validates
        return False


# --- worker processes ---------------------------------------------------------
_TERMINATING = False

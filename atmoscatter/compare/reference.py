"""Compare an EXR with our reference render of a scene: read it, render ours, compute statistics.

Public objects
--------------
- :func:`compare_exr`: read another renderer's EXR (:func:`~atmoscatter.compare.read_sky_map`),
  render our reference for a scene at the same directions and compare
  (:func:`~atmoscatter.compare.compare_images`) — the Python equivalent of
  ``atmoscatter compare``.
"""

from __future__ import annotations

import math
import os

import numpy as np

from .._validate import check_option, check_positive
from .read import SkyMap, _to_xyz, read_sky_map
from .stats import Comparison, compare_images

__all__ = ["compare_exr"]

REGIONS = ("sky", "all")


# --------------------------------------------------------------------------------------
# EXR against our reference render
# --------------------------------------------------------------------------------------
def _scene_for(scene, sky_map: SkyMap):
    """Load/replace the scene so that it renders at the sky map's directions."""
    import dataclasses

    from ..scene import Scene, load_scene

    if isinstance(scene, str | os.PathLike):
        scene = load_scene(scene)
    elif isinstance(scene, dict):
        scene = Scene.from_dict(scene)
    elif scene is None:
        scene = Scene()
    changes = {"sun_disc": False}
    if sky_map.directions is None:  # else rendered at the file's own directions
        changes.update(projection=sky_map.layout, width=sky_map.width, height=sky_map.height)
    names = {f.name for f in dataclasses.fields(scene)}
    if "output" in names:
        changes["output"] = "xyz"
    return dataclasses.replace(scene, **{k: v for k, v in changes.items() if k in names})


def compare_exr(
    other,
    scene=None,
    *,
    layout: str = "auto",
    rotate_deg: float = 0.0,
    flip: str = "none",
    colourspace: str = "sRGB",
    region: str = "sky",
    sun_exclusion_deg: float = 1.0,
    scale_method: str = "median_log",
    reference=None,
) -> Comparison:
    """Compare another renderer's EXR sky map with our reference render of ``scene``.

    Parameters
    ----------
    other : str or path-like
        The other renderer's EXR (see :func:`read_sky_map` for layouts and options).
    scene : Scene, dict, str or path-like, optional
        The scene (object, field dict, or TOML/JSON file).  Its projection and resolution are
        replaced by the file's, the sun disc is not drawn (renderers differ too much there;
        the cone within ``sun_exclusion_deg`` of the sun is excluded instead).  Default: the
        package's default scene.
    layout, rotate_deg, flip, colourspace
        Passed to :func:`read_sky_map`.
    region : {"sky", "all"}
        Compare the sky above the horizon only (default) or every pixel we render.
    sun_exclusion_deg : float
        Angular radius [deg] around the sun left out of the statistics (≥ 0).
    scale_method : str
        Key of :data:`SCALE_METHODS`.
    reference : SkyImage, optional
        A render to use instead of rendering ``scene`` (it must match the layout and size).

    Returns
    -------
    Comparison
    """
    check_option(region, "region", REGIONS)
    excl = float(check_positive(sun_exclusion_deg, "sun_exclusion_deg", allow_zero=True,
                                unit="deg"))
    sky = read_sky_map(other, layout=layout, rotate_deg=rotate_deg, flip=flip,
                       colourspace=colourspace)
    if reference is None:
        from ..render import render

        sc = _scene_for(scene, sky)
        reference = render(sc) if sky.directions is None else \
            render(sc, directions=sky.directions)
    else:
        sc = reference.scene
    ours_y = np.asarray(reference.luminance, dtype=np.float64)
    if ours_y.shape != sky.luminance.shape:
        raise ValueError(f"our render has shape {ours_y.shape} but {os.fspath(other)!r} has "
                         f"{sky.luminance.shape}; they must match pixel for pixel")
    if reference.xyz is not None:
        ours_xyz = np.asarray(reference.xyz, dtype=np.float64)
    elif reference.rgb is not None:
        ours_xyz, _ = _to_xyz(reference.rgb, sc.colourspace, "reference")
    else:
        ours_xyz = None
    dset = reference.directions_set
    dirs = dset.all_directions()
    solid = np.asarray(dset.solid_angles(0, dset.size)).reshape(ours_y.shape)
    mask = np.ones(ours_y.shape, dtype=bool)
    if reference.alpha is not None:
        mask &= np.asarray(reference.alpha) > 0
    if region == "sky":
        mask &= dirs[..., 2] > 0
    sun = np.asarray(reference.plan.sun_direction, dtype=float)
    if excl > 0:
        mask &= dirs @ sun < math.cos(math.radians(excl))
    if sky.xyz is not None and ours_xyz is not None:
        o, r, o_space, r_space = sky.xyz, ours_xyz, "XYZ", "XYZ"
    else:
        o, r, o_space, r_space = sky.luminance, ours_y, "luminance", "luminance"
    scene_fields = sc.to_dict() if hasattr(sc, "to_dict") else {}
    info = {
        "other": os.fspath(other),
        "other_colour": sky.source,
        "layout": sky.layout,
        "frame": ("local x=east, y=north, z=up; OpenEXR envmap orientation with its frame "
                  "x=west, y=up, z=north"),
        "options": {"rotate_deg": rotate_deg, "flip": flip, "colourspace": colourspace,
                    "region": region, "sun_exclusion_deg": excl},
        "scene": scene_fields,
    }
    if sky.directions is not None:  # rendered at explicit directions
        solid = sky.solid_angles  # None for a bare direction set: per-pixel weights
        if sky.valid is not None:
            mask &= sky.valid
    weights = solid
    return compare_images(o, r, other_space=o_space, reference_space=r_space, weights=weights,
                          mask=mask, scale_method=scale_method, info=info)

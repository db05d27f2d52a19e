"""The per-vertex batch evaluator: Scene → SkyImage (:mod:`atmoscatter.render.image`).

Public objects
--------------
:func:`render`
    Evaluate a scene's sky over its direction set (lat-long, cube map,
    fisheye or sky-dome mesh) in bounded-memory batches spread over threads,
    following :func:`atmoscatter.plan` exactly.
:func:`render_batches`
    The same evaluation as a generator of ``(start, stop, values)`` batches,
    for streaming very large maps without holding them.
:func:`~atmoscatter.render.sun_disc.sun_disc_radiance`
    Transmitted, limb-darkened radiance of the solar disc (XYZ [cd m⁻²]).

Out-of-gamut colours
--------------------
Physical skies near the horizon at low sun can be more saturated than the RGB colourspace
allows: their RGB has a negative channel although their XYZ is non-negative.  The scene's
``gamut`` policy decides what the RGB layer holds (:func:`atmoscatter.rgb_into_gamut`):
``map`` (default) moves such colours into the gamut keeping luminance and hue, ``clip`` sets
negative channels to 0, ``none`` keeps the raw values.  The counts are recorded in
:attr:`SkyImage.metadata` (``atmoscatter:gamut_*``, written to the EXR header).  XYZ,
luminance and spectral layers are never changed.

Memory
------
Directions are generated per batch from their indices (never all at once);
each batch holds ``batch_size`` directions and its model temporaries, and at
most ``workers`` batches are in flight.  Each batch's values go straight into
the output, which is planar (one float32 plane per channel, see
:mod:`atmoscatter.render.image`) so that :func:`~atmoscatter.write_exr` hands the
planes to OpenEXR without copies.  Peak memory is therefore the output arrays
(float32) and a 1-byte mask per direction plus ``O(workers × batch_size)``
regardless of resolution (``benchmarks/bench_memory.py``).
NumPy releases the GIL inside its kernels, so threads use the cores without
copying results between processes.
"""

from __future__ import annotations

import math
import os
import threading
import warnings
from concurrent.futures import ThreadPoolExecutor

import numpy as np

from .. import __version__
from .._validate import check_count
from ..scene import Scene, as_scene
from .directions import ArrayDirections, DirectionSet, direction_set, mirror_pairs
from .image import SkyImage
from .models import get_model
from .plan import Plan
from .plan import plan as make_plan
from .sun_disc import LIMB_DARKENING_U, sun_disc_radiance

__all__ = ["render", "render_batches", "GamutWarning", "GAMUT_WARN_FRACTION"]


#: Fraction of an image's pixels [1] above which :func:`render` warns (:class:`GamutWarning`)
#: that its ``gamut`` policy changed out-of-gamut RGB colours.
GAMUT_WARN_FRACTION = 0.01


class GamutWarning(UserWarning):
    """More than :data:`GAMUT_WARN_FRACTION` of a render's RGB pixels were out of gamut and
    were mapped or clipped (the scene's ``gamut`` policy); XYZ and spectral layers are exact."""





# ----------------------------------------------------------------------------
# the evaluator
# ----------------------------------------------------------------------------
def _prepare(adapter, scene: Scene, plan: Plan, dset: DirectionSet):
    """``adapter.prepare(scene, plan)``; for caller-given directions, an adapter whose
    ``prepare`` takes ``n_directions`` is told their number (its choice of a whole-sky
    table then follows the directions actually evaluated, not the scene's projection)."""
    if isinstance(dset, ArrayDirections):
        import inspect  # noqa: PLC0415

        try:
            takes_n = "n_directions" in inspect.signature(adapter.prepare).parameters
        except (TypeError, ValueError):  # a builtin or C callable: the plain protocol
            takes_n = False
        if takes_n:
            return adapter.prepare(scene, plan, n_directions=dset.size)
    return adapter.prepare(scene, plan)


class _Context:
    """Everything a batch needs, prepared once per render."""

    def __init__(self, scene: Scene, plan: Plan, dset: DirectionSet):
        self.scene, self.plan, self.dset = scene, plan, dset
        self.adapter = get_model(scene.model)
        self.evaluate = _prepare(self.adapter, scene, plan, dset)
        self.sun = plan.sun_direction
        self.key = "Y" if plan.quantity == "Y" else "XYZ"
        self.nval = 1 if self.key == "Y" else 3
        self.nspec = len(plan.wavelengths) if plan.quantity == "spectral" else 0
        self.ground = np.zeros(self.nval)
        self.ground_spec = np.zeros(self.nspec)
        if plan.skip_below_horizon and scene.ground_albedo > 0.0:
            self._ground_value()
        self.disc = None
        if plan.sun_disc:
            xyz, alpha, (grid, L) = sun_disc_radiance(scene, plan)
            self.disc = (xyz[1:2] if self.key == "Y" else xyz, alpha)
            if self.nspec:
                wl = np.asarray(plan.wavelengths)
                self.disc_spec = np.interp(wl, grid, L)
        self.nearest = (-2.0, -1)  # (cos angle to sun, index) of the closest direction
        self.disc_hit = False
        self.lock = threading.Lock()

    def _ground_value(self):
        """ρ (E_sky + E_sun) / π: Lambertian ground under the model's sky and the direct sun.

        E_sky from a 16 × 64 Gauss–Legendre × uniform quadrature of the model's
        upper-hemisphere radiance; E_sun = E·T·cos θ_s, the transmitted direct
        beam of :func:`sun_disc_radiance` (0 with the sun below the horizon).
        """
        x, w = np.polynomial.legendre.leggauss(16)
        mu = 0.5 * (x + 1.0)
        wmu = 0.5 * w
        naz = 64
        az = 2.0 * np.pi * (np.arange(naz) + 0.5) / naz
        st = np.sqrt(1.0 - mu**2)
        d = np.stack([np.outer(st, np.sin(az)), np.outer(st, np.cos(az)),
                      np.outer(mu, np.ones(naz))], -1).reshape(-1, 3)
        res = self.evaluate(d)
        weight = (np.outer(wmu * mu, np.full(naz, 2.0 * np.pi / naz))).ravel()
        vals = res[self.key].reshape(len(d), -1)
        eh = weight @ vals
        cos_sun = max(math.cos(self.plan.sun_zenith), 0.0)
        if cos_sun > 0.0:
            xyz_c, a, (grid, L) = sun_disc_radiance(self.scene, self.plan)
            beam = 2.0 * math.pi * (1.0 - math.cos(a)) * (1.0 - LIMB_DARKENING_U / 3.0) * cos_sun
            eh = eh + (xyz_c[1:2] if self.key == "Y" else xyz_c) * beam
        self.ground = self.scene.ground_albedo * eh / np.pi
        if self.nspec and "spectral" in res:
            es = weight @ res["spectral"]
            if cos_sun > 0.0:
                es = es + np.interp(np.asarray(self.plan.wavelengths), grid, L) * beam
            self.ground_spec = self.scene.ground_albedo * es / np.pi

    def _eval(self, dirs):
        if self.plan.symmetry:
            uniq, inv = mirror_pairs(dirs, self.sun)
            res = self.evaluate(uniq)
            return {k: np.asarray(v)[inv] for k, v in res.items()}
        return self.evaluate(dirs)

    def batch(self, start: int, stop: int) -> dict:
        """Evaluate directions ``start:stop``; returns per-direction arrays.

        ``alpha`` is a bool mask of the evaluated directions, or None when all were.
        """
        plan = self.plan
        up = self.dset.up_range(start, stop) if plan.skip_below_horizon else None
        if up is not None:
            if up[1] < plan.horizon_z:  # all ground: no directions needed
                n = stop - start
                vals = np.empty((n, self.nval))
                vals[...] = self.ground
                spec = None
                if self.nspec:
                    spec = np.empty((n, self.nspec))
                    spec[...] = self.ground_spec
                return {"values": vals, "spectral": spec, "alpha": np.zeros(n, dtype=bool)}
        dirs, valid = self.dset.directions(start, stop)
        n = len(dirs)
        # up_range() vouches that all are valid; all above the horizon: nothing to mask
        todo = None if (up is not None or valid.all()) else valid
        below = None
        if plan.skip_below_horizon and not (up is not None and up[0] >= plan.horizon_z):
            b = dirs[:, 2] < plan.horizon_z
            if todo is not None:
                b &= todo
            if b.any():
                below = b
                todo = ~b if todo is None else (todo & ~b)
        spec = None
        if todo is None:  # everything is evaluated: no masks, no copies
            res = self._eval(dirs)
            vals = np.asarray(res[self.key]).reshape(n, self.nval)
            if self.nspec:
                spec = np.asarray(res["spectral"])
        else:
            vals = np.zeros((n, self.nval))
            if self.nspec:
                spec = np.zeros((n, self.nspec))
            idx = np.flatnonzero(todo)
            if idx.size:
                res = self._eval(dirs[idx])
                vals[idx] = np.asarray(res[self.key]).reshape(idx.size, self.nval)
                if spec is not None:
                    spec[idx] = res["spectral"]
            if below is not None:
                vals[below] = self.ground
                if spec is not None:
                    spec[below] = self.ground_spec
        if self.disc is not None:
            vals, spec = self._add_disc(dirs, todo, vals, spec, start)
        return {"values": vals, "spectral": spec, "alpha": todo}

    def _add_disc(self, dirs, todo, vals, spec, start):
        """Add the sun disc to the directions inside it; ``todo`` None: all were evaluated.

        Returns ``(vals, spec)``: copies with the disc added when a direction of the batch
        is inside it (the model's arrays are never changed), else the inputs themselves
        (most batches miss the disc, and a copy of every batch was a measurable part of
        the evaluator's own cost)."""
        xyz, alpha = self.disc
        c = dirs @ self.sun
        inside = c >= math.cos(alpha)
        if todo is not None:
            inside &= todo
        hit = bool(inside.any())
        if hit:
            vals = np.array(vals, dtype=float)  # own copy: the disc is added in place
            rho = np.arccos(np.clip(c[inside], -1.0, 1.0)) / alpha
            ld = 1.0 - LIMB_DARKENING_U * (1.0 - np.sqrt(np.maximum(1.0 - rho**2, 0.0)))
            vals[inside] += ld[:, None] * xyz
            if spec is not None:
                spec = np.array(spec, dtype=float)
                spec[inside] += ld[:, None] * self.disc_spec
        cm = c if todo is None else np.where(todo, c, -2.0)
        i = int(np.argmax(cm)) if len(cm) else 0
        with self.lock:
            self.disc_hit |= hit
            if len(cm) and cm[i] > self.nearest[0]:
                self.nearest = (float(cm[i]), start + i)
        return vals, spec


def _default_workers():
    return max(1, min(os.cpu_count() or 1, 8))


def render_batches(scene: Scene, *, batch_size: int | None = None, plan: Plan | None = None,
                   atmosphere=None):
    """Yield ``(start, stop, batch)`` for each batch of the scene's directions, in order.

    ``batch`` holds ``values`` (k, 3) XYZ or (k, 1) Y [cd m⁻²], ``spectral``
    (k, n_wl) or None and ``alpha``: a (k,) bool mask of the evaluated
    directions, or None when all were.  Only one batch exists at a time, so a
    map of any size can be streamed with bounded memory.

    Parameters
    ----------
    scene : Scene
        What to render.
    batch_size : int, optional
        Directions per batch, ≥ 1 (default :data:`atmoscatter.scene.DEFAULT_BATCH_SIZE`).
        Batches hold whole rows of the projection, at least one, so a batch can be larger
        when a row is longer than ``batch_size``.  Ignored when ``plan`` is given.
    plan : Plan, optional
        A plan to follow (default: :func:`atmoscatter.plan` of ``scene``, ``batch_size``
        and ``atmosphere``).
    atmosphere : Atmosphere, optional
        A custom atmosphere for the physical models; ignored when ``plan`` is given.

    Yields
    ------
    start : int
        First flat direction index of the batch (pixels in row-major order, or vertices).
    stop : int
        One past its last index, ``start < stop ≤`` the number of directions.
    batch : dict
        ``"values"``: ndarray (k, 3) of CIE XYZ, or (k, 1) of Y for ``output =
        "luminance"`` [cd m⁻²], ``k = stop − start``: the values before :func:`render`'s
        RGB conversion and gamut policy, with the sun disc in the directions that fall
        inside it (a disc smaller than the pixels that no direction hits is not put into
        the nearest pixel, as :func:`render` does); ``"spectral"``: ndarray
        (k, n_wl) [W m⁻² sr⁻¹ nm⁻¹] at ``plan.wavelengths`` for ``output = "spectral"``,
        else None; ``"alpha"``: bool ndarray (k,), False for directions filled with the
        ground value or outside the map, or None when all were evaluated.

    Raises
    ------
    ValueError
        If the plan cannot be made for ``scene`` (see :func:`atmoscatter.plan`) or its
        model is not registered.
    """
    p = make_plan(scene, batch_size=batch_size, atmosphere=atmosphere) if plan is None else plan
    dset = direction_set(scene, p)
    ctx = _Context(scene, p, dset)
    for start, stop in dset.batches(p.batch_size):
        yield start, stop, ctx.batch(start, stop)


def _error_estimate(adapter, plan, scene=None) -> str:
    text = adapter.error_estimate
    if callable(text):  # depends on the scene (e.g. measured per sun/observer regime)
        text = str(text(scene))
    if adapter.spectral and 0 < len(plan.wavelengths) <= 3:
        text += ("; colour from 3 wavelengths expanded as a power law (measured on a clear "
                 "sky: Y within 1.2 %, X and Z within 5 % of a 1 nm spectrum)")
    return text


def _metadata(scene, plan, dset, adapter):
    md = {
        "software": f"atmoscatter {__version__}",
        "atmoscatter:package": "atmoscatter",
        "atmoscatter:version": __version__,
        "atmoscatter:model": scene.model,
        "atmoscatter:model_description": adapter.description,
        "atmoscatter:error_estimate": _error_estimate(adapter, plan, scene),
        "atmoscatter:plan": plan.to_json(),
        "atmoscatter:projection": dset.kind,
        "atmoscatter:units": "cd m-2 (linear RGB and XYZ), W m-2 sr-1 nm-1 (spectral)",
        "atmoscatter:frame": "local x=east, y=north, z=up; azimuth from north toward east",
        "atmoscatter:ground_value": plan.ground_value,
    }
    if dset.kind in ("latlong", "cubemap"):
        md["atmoscatter:envmap_frame"] = "OpenEXR env frame x=west, y=up, z=north"
    if plan.wavelengths:
        md["atmoscatter:wavelengths"] = ",".join(f"{w:g}" for w in plan.wavelengths)
    if plan.atmosphere is not None:
        md["atmoscatter:custom_atmosphere"] = repr(plan.atmosphere)
    md.update(scene.to_strings())
    return md


def render(scene: Scene | None = None, *, directions=None, atmosphere=None,
           batch_size: int | None = None, workers: int | None = None,
           progress=None) -> SkyImage:
    """Render ``scene`` (default: :class:`Scene` ()) to a :class:`SkyImage`.

    Parameters
    ----------
    scene : Scene, dict, str or path-like, optional
        What to render; ``None`` renders the documented default scene, a dict of
        fields goes through :meth:`Scene.from_dict`, a path through
        :func:`~atmoscatter.load_scene`.
    directions : array_like (..., 3), optional
        Evaluate these unit view directions (local frame) instead of the
        scene's projection (e.g. the vertices of your own sky mesh); the
        layers then have shape ``directions.shape[:-1]``.
    atmosphere : Atmosphere, optional
        A custom atmosphere for the physical models (instead of the scene's
        preset); recorded by name in the metadata.
    batch_size : int, optional
        Directions per model call (default :data:`atmoscatter.scene.DEFAULT_BATCH_SIZE`).
    workers : int, optional
        Threads evaluating batches concurrently (default: the number of cores, ≤ 8).
    progress : callable, optional
        Called as ``progress(done, total)`` [directions] in the calling thread after each
        batch (e.g. to drive a progress bar; the CLI uses tqdm).

    Returns
    -------
    SkyImage
        float32 layers in cd m⁻² (see :class:`SkyImage`), with the plan and
        provenance in :attr:`SkyImage.metadata`.

    Notes
    -----
    The renderer follows :func:`atmoscatter.plan`: directions below a ground
    observer's horizon are filled with the plan's ground value without calling
    the model, mirror pairs are evaluated once when the plan says so, and the
    sun disc is only computed when drawn.  When the disc is smaller than the
    pixels and no pixel centre falls inside it, its whole transmitted energy is
    put into the pixel closest to the sun (radiance ``E·T/Ω_pixel``), so the
    map's irradiance stays right.
    """
    scene = as_scene(scene)  # a dict of fields or a scene file work too
    p = make_plan(scene, batch_size=batch_size, atmosphere=atmosphere)
    dset = direction_set(scene, p) if directions is None else ArrayDirections(directions)
    ctx = _Context(scene, p, dset)
    n = dset.size
    chroma_rgb = ctx.key == "XYZ"
    keep_xyz = "XYZ" in p.layers
    # only the layers asked for are stored (float32), planar: one contiguous plane per
    # channel, filled batch by batch (see SkyImage); nothing else is of the map's size
    vals = np.empty((ctx.nval, n), dtype=np.float32) if (keep_xyz or not chroma_rgb) else None
    spec = np.empty((ctx.nspec, n), dtype=np.float32) if ctx.nspec else None
    evaluated = np.empty(n, dtype=bool)
    rgb = np.empty((3, n), dtype=np.float32) if chroma_rgb else None
    out_of_gamut = []  # (start, stop) of the batches whose raw RGB has a channel < 0
    if chroma_rgb:
        from ..colour import XYZ_to_linear_rgb  # noqa: PLC0415

        m_rgb = XYZ_to_linear_rgb(np.eye(3), scene.colourspace)  # rows: RGB of X, Y, Z

    def work(bounds):
        s, e = bounds
        b = ctx.batch(s, e)
        v = b["values"]
        if vals is not None:
            vals[:, s:e] = v.T
        if rgb is not None:
            rgb[:, s:e] = (v @ m_rgb).T
            # (not ``min() < 0``: a NaN would hide the negative values of the batch)
            if e > s and not rgb[:, s:e].min() >= 0.0:  # the policy is applied after the disc
                out_of_gamut.append((s, e))
        if spec is not None:
            spec[:, s:e] = b["spectral"].T
        evaluated[s:e] = True if b["alpha"] is None else b["alpha"]

    bounds = dset.batches(p.batch_size)
    nw = _default_workers() if workers is None else check_count(workers, "workers")
    done = 0
    if nw == 1 or len(bounds) == 1:
        for bd in bounds:
            work(bd)
            if progress is not None:
                done += bd[1] - bd[0]
                progress(done, n)
    else:
        with ThreadPoolExecutor(max_workers=nw) as ex:
            for bd, _ in zip(bounds, ex.map(work, bounds), strict=True):
                if progress is not None:
                    done += bd[1] - bd[0]
                    progress(done, n)

    if ctx.disc is not None and not ctx.disc_hit and ctx.nearest[1] >= 0:
        i = ctx.nearest[1]
        omega_pix = float(dset.solid_angles(i, i + 1)[0])
        xyz_c, a = ctx.disc
        omega_sun = 2.0 * math.pi * (1.0 - math.cos(a))
        # the pixel must actually contain the sun (closest centre within ~ a pixel)
        if omega_pix > 0 and math.acos(min(1.0, ctx.nearest[0])) <= 2.0 * math.sqrt(omega_pix):
            scale = omega_sun * (1.0 - LIMB_DARKENING_U / 3.0) / omega_pix
            add = xyz_c * scale
            if vals is not None:
                vals[:, i] += add.astype(np.float32)
            if rgb is not None:
                rgb[:, i] += (add @ m_rgb).astype(np.float32)
                if not rgb[:, i].min() >= 0.0 and not any(a <= i < b for a, b in out_of_gamut):
                    out_of_gamut.append((i, i + 1))
            if spec is not None:
                spec[:, i] += (ctx.disc_spec * scale).astype(np.float32)

    shape = dset.shape
    planes = {}
    if rgb is not None:
        planes["rgb"] = rgb.reshape((3,) + shape)
    if keep_xyz:
        planes["xyz"] = vals.reshape((3,) + shape)
    if spec is not None:
        planes["spectral"] = spec.reshape((ctx.nspec,) + shape)
    md = _metadata(scene, p, dset, ctx.adapter)
    if rgb is not None:  # (n, 3) view of the planes: the policy changes them in place
        md.update(_apply_gamut_policy(rgb.T, out_of_gamut, scene, nw))
    return SkyImage._from_planes(
        scene, p, dset, planes=planes,
        luminance_only=vals.reshape(shape) if ctx.key == "Y" else None,
        alpha_mask=evaluated.reshape(shape), metadata=md,
        wavelengths=np.asarray(p.wavelengths) if p.wavelengths else None)


_GAMUT_DESCRIPTIONS = {
    "map": "map: RGB colours outside the colourspace's gamut (a channel < 0) desaturated toward "
           "the achromatic colour of the same luminance until the lowest channel is 0 "
           "(luminance Y and hue kept)",
    "clip": "clip: negative RGB channels set to 0 (luminance and hue of those pixels change)",
    "none": "none: raw RGB, out-of-gamut colours keep their negative channels",
}


def _apply_gamut_policy(rgb, ranges, scene, workers) -> dict:
    """Apply ``scene.gamut`` in place to the rows ``ranges`` of ``rgb`` (n, 3); return the
    ``atmoscatter:gamut_*`` metadata and warn (:class:`GamutWarning`) when the policy changed
    more than :data:`GAMUT_WARN_FRACTION` of the pixels.  Only batches that hold a negative
    channel are visited, so an in-gamut render pays one ``min`` per batch."""
    from ..colour import _gamut_map_inplace, _luminance_coefficients  # noqa: PLC0415

    policy = scene.gamut
    lum = _luminance_coefficients(scene.colourspace)

    def one(bounds):
        return _gamut_map_inplace(rgb[bounds[0]:bounds[1]], policy, lum)

    if workers > 1 and len(ranges) > 1:
        with ThreadPoolExecutor(max_workers=workers) as ex:
            stats = list(ex.map(one, ranges))
    else:
        stats = [one(r) for r in ranges]
    n = len(rgb)
    out = sum(st[0] for st in stats)
    changed = sum(st[1] for st in stats)
    desat = max((st[2] for st in stats), default=0.0)
    low = min((st[3] for st in stats), default=0.0)
    md = {
        "atmoscatter:gamut": _GAMUT_DESCRIPTIONS[policy],
        "atmoscatter:gamut_out_of_gamut_pixels": str(out),
        "atmoscatter:gamut_out_of_gamut_fraction": f"{out / n if n else 0.0:.6g}",
        "atmoscatter:gamut_mapped_pixels": str(changed),
        "atmoscatter:gamut_min_raw_value": f"{low:.6g}",
    }
    if policy == "map":
        md["atmoscatter:gamut_max_desaturation"] = f"{desat:.6g}"
    if n and changed > GAMUT_WARN_FRACTION * n:
        how = ("mapped into it keeping luminance and hue (largest desaturation "
               f"{desat:.2f})" if policy == "map" else "clipped to 0")
        warnings.warn(
            f"{changed} of {n} RGB pixels ({100.0 * changed / n:.1f} %) were outside the "
            f"{scene.colourspace} gamut (lowest channel {low:.3g} cd m-2) and were {how}; "
            "XYZ and spectral layers are exact (output='xyz', a wider colourspace such as "
            "'ACES2065-1', or gamut='none' for the raw values)", GamutWarning, stacklevel=3)
    return md

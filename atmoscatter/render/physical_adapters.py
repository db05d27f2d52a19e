"""Adapters of the models that return radiance per unit solar irradiance.

Public objects
--------------
:func:`physical_adapter`
    Adapter of a numerical model (``single_scattering``, ``multiple_scattering``): the
    scene's atmosphere at the plan's wavelengths, the model per batch of directions, the
    result in absolute units (:mod:`atmoscatter.render.photometry`).
:data:`HOFFMAN_PREETHAM_HAZE_G`
    The haze asymmetry of the Hoffman–Preetham two-shell sky (``hoffman_preetham``).

Also here: the measured accuracy of ``multiple_scattering`` per regime (:func:`ms_accuracy`,
the EXR header's ``error_estimate``).  Units and turbidity: :mod:`atmoscatter.render.models`.
Each adapter is registered in :data:`~atmoscatter.render.models.MODELS` on import if its
model's functions are in the package.
"""

from __future__ import annotations

import math

import numpy as np

from .models import ModelAdapter, _lookup, register_model
from .photometry import _per_irradiance_converter

__all__ = ["physical_adapter", "HOFFMAN_PREETHAM_HAZE_G"]



def _build_atmosphere(scene, wavelengths):
    from .. import presets  # noqa: PLC0415

    wl = tuple(float(w) for w in wavelengths)
    if scene.atmosphere in ("earth", "earth_no_ozone"):
        atm = presets.earth_turbidity_atmosphere(
            scene.turbidity, wl, ozone=scene.atmosphere == "earth")
    elif scene.atmosphere == "mars":
        atm = presets.mars_atmosphere(wl)
    else:
        atm = presets.keller_bohn_atmosphere(wl)
    return _drop_empty(atm)


def _drop_empty(atm):
    """Leave out constituents that neither scatter nor absorb (no haze at T = 1)."""
    keep = tuple(c for c in atm.constituents if not c.is_empty)
    if len(keep) != len(atm.constituents):
        import dataclasses  # noqa: PLC0415

        atm = dataclasses.replace(atm, constituents=keep)
    return atm


def _physical_wavelengths(scene):
    """Wavelengths [nm] of a scene whose ``sampling`` is resolved (:func:`atmoscatter.plan`
    turns ``"auto"`` into ``"rgb"`` or ``"spectral"`` first; ``"auto"`` here means rgb)."""
    if scene.sampling == "spectral" or scene.output == "spectral":
        step = scene.wavelength_step
        n = int(math.floor((780.0 - 380.0) / step + 1e-9)) + 1
        return tuple(380.0 + step * np.arange(n))
    if scene.atmosphere == "keller_bohn":
        return (650.0, 570.0, 475.0)
    return (680.0, 550.0, 440.0)


def _evaluated_directions(scene, symmetry: bool = True) -> int:
    """Estimate of the number of directions a render of ``scene`` evaluates.

    Lat-long, cube map and dome: the pixels, halved for the ground that an observer on the
    ground does not integrate and again for the mirror symmetry about the solar vertical
    where the plan uses it (``symmetry``) — a lower estimate.  Fisheye: the disc of the
    upper hemisphere, π/4 of the pixels, not halved: it shows no ground, and its pixels
    mirror onto each other only when the solar vertical lies along an image axis or
    diagonal (a 256² fisheye with the sun at azimuth 295° evaluated all 51 468 of its
    sky pixels)."""
    n = scene.width * (scene.width * 6 if scene.projection == "cubemap" else scene.height)
    if scene.projection == "fisheye":
        return int(n * math.pi / 4.0)
    n //= 2
    return n // 2 if symmetry else n


def _render_uses_table(scene, atm, sun, symmetry: bool = True,
                       n_directions: int | None = None) -> bool:
    """Whether ``single_scattering``'s default would use its table for the whole render
    (``n_directions``: the caller's own direction count, else the scene's estimate)."""
    from ..sky import _quadrature as qd  # noqa: PLC0415
    from ..sky import single  # noqa: PLC0415

    try:
        prepared = qd.prepare_atmosphere(atm)
    except (TypeError, ValueError, AttributeError):  # a duck-typed atmosphere: leave it be
        return False
    n = _evaluated_directions(scene, symmetry) if n_directions is None else int(n_directions)
    return single._table_allowed(prepared, float(scene.altitude), np.asarray(sun, float), n)


def _make_physical_prepare(function_name):
    def prepare(scene, plan, n_directions=None):
        # n_directions: the render evaluates these many caller-given directions (not the
        # scene's projection): a few hundred must not pay for a whole-sky table
        fn = _lookup(function_name)
        if fn is None:
            raise ValueError(f"model {function_name!r} is not available in this installation")
        wl = np.asarray(plan.wavelengths, dtype=float)
        if plan.atmosphere is not None:
            atm = _drop_empty(plan.atmosphere)
            rgb_sampled = wl.size <= 3
        else:
            atm = _build_atmosphere(scene, wl)
            # the plan resolves sampling="auto"; plans without it (old EXR headers): by count
            rgb_sampled = plan.sampling == "rgb" if getattr(plan, "sampling", "") else wl.size <= 3
        sun = plan.sun_direction
        kwargs = {"altitude": scene.altitude}
        if function_name == "multiple_scattering":
            kwargs["ground_albedo"] = scene.ground_albedo
            if scene.orders is not None:
                kwargs["orders"] = scene.orders
            kwargs["grid"] = _ms_grid(scene)[1]
            if _render_uses_table(scene, atm, sun, bool(getattr(plan, "symmetry", True)),
                                  n_directions):
                kwargs["single_method"] = "table"  # order 1: as for single_scattering below
        elif scene.method is not None:
            kwargs["method"] = scene.method
        elif function_name == "single_scattering" and _render_uses_table(
                scene, atm, sun, bool(getattr(plan, "symmetry", True)), n_directions):
            # the renderer calls the model once per batch: the default's choice of the
            # table must follow the whole sky's direction count, not the batch's (at
            # twilight the table pays off from TWILIGHT_TABLE_THRESHOLD directions, and a
            # batch holds fewer sky directions than that)
            kwargs["method"] = "table"
        convert = _per_irradiance_converter(wl, rgb_sampled, plan)

        def evaluate(directions):
            return convert(fn(atm, directions, sun, **kwargs))

        evaluate.atmosphere = atm
        return evaluate

    return prepare


# ----------------------------------------------------------------------------
# Hoffman–Preetham two-shell sky (seed 000)
# ----------------------------------------------------------------------------
#: Hoffman–Preetham haze asymmetry used with turbidity-derived haze (Bruneton 2017's g).
HOFFMAN_PREETHAM_HAZE_G = 0.8


def _hoffman_preetham_wavelengths(scene):
    if scene.sampling == "spectral" or scene.output == "spectral":
        wl = list(_physical_wavelengths(scene))
        while len(wl) % 3:  # the model evaluates three channels per call
            wl.append(wl[-1] + scene.wavelength_step)
        return tuple(wl)
    return tuple(float(w) for w in _lookup("HOFFMAN_PREETHAM_WAVELENGTHS"))


def _prepare_hoffman_preetham(scene, plan):
    fn = _lookup("hoffman_preetham_sky")
    haze_fn = _lookup("turbidity_haze")
    air_fn = _lookup("hoffman_preetham_air_scattering")
    wl = np.asarray(plan.wavelengths, dtype=float)
    sun = plan.sun_direction
    triples = []
    for w in wl.reshape(-1, 3):  # the model works on three channels at a time
        # real air and the turbidity's haze: T = (τ_m + τ_h)/τ_m by extinction at 550 nm
        # with the model's 8.4 km / 1.25 km optical lengths (as the physical presets)
        haze = (haze_fn(scene.turbidity, tuple(w), air="standard", g=HOFFMAN_PREETHAM_HAZE_G)
                if plan.haze else None)  # turbidity 1: no haze shell terms
        triples.append((air_fn(w, air="standard"), haze))
    rgb_sampled = wl.size == 3
    convert = _per_irradiance_converter(wl, rgb_sampled, plan)
    ones = np.ones(3)

    def evaluate(directions):
        # E_sun⁰ = 1 per channel: radiance per unit extraterrestrial irradiance [sr⁻¹]
        f = [fn(directions, sun, haze=h, sun_irradiance=ones, air_scattering=b)
             for b, h in triples]
        return convert(np.concatenate(f, axis=-1))

    evaluate.hazes = [h for _, h in triples]
    return evaluate


_HOFFMAN_PREETHAM = ModelAdapter(
    name="hoffman_preetham",
    description="Hoffman & Preetham (2002) two-shell sky (seed 000), real air and the "
    "turbidity's haze (atmoscatter.turbidity_haze)",
    prepare=_prepare_hoffman_preetham,
    spectral=True,
    separate_haze=True,
    ground_only=True,
    cost_per_direction=4e-7,
    wavelengths=_hoffman_preetham_wavelengths,
    error_estimate=(
        "single scattering in a constant-density two-shell atmosphere (seed 000); "
        "an approximation, not a reference: compare with single_scattering"
    ),
)


_MS_ACCURACY: dict = {}


def ms_accuracy() -> dict:
    """Measured errors of ``multiple_scattering`` per named grid and regime.

    Read (once, lazily) from ``atmoscatter/data/ms_accuracy.json``, written by
    ``benchmarks/ms_accurate_grid.py`` (full run: each grid of
    :data:`~atmoscatter.sky.multiple.MULTIPLE_SCATTERING_GRIDS` against a grid finer in
    every knob; see ``docs/convergence.md``): ``acc["grids"][name]`` holds the worst
    errors per sun regime (ground observer) and per observer regime.
    """
    if not _MS_ACCURACY:
        import json  # noqa: PLC0415
        from importlib import resources  # noqa: PLC0415

        text = resources.files("atmoscatter").joinpath("data/ms_accuracy.json").read_text("utf-8")
        _MS_ACCURACY.update(json.loads(text))
    return _MS_ACCURACY


def _ms_grid(scene):
    """(name, grid) of the scene's ``ms_grid`` (``None``: the default grid)."""
    from ..sky.multiple import MULTIPLE_SCATTERING_GRIDS  # noqa: PLC0415

    name = scene.ms_grid or "default"
    return name, MULTIPLE_SCATTERING_GRIDS[name]


def _ms_regimes(scene) -> tuple[str, str]:
    """(sun regime, observer regime) keys of :func:`ms_accuracy` for a scene."""
    from ..scene import GROUND_OBSERVER_ALTITUDE  # noqa: PLC0415

    e = round(90.0 - math.degrees(scene.sun_angles()[0]), 9)  # -6° given is -6°
    sun = ("above_10" if e > 10.0 else "0_to_10" if e > 0.0 else "0_to_-6" if e >= -6.0
           else "-6_to_-12" if e >= -12.0 else "below_-12")
    if scene.altitude < GROUND_OBSERVER_ALTITUDE:
        return sun, "ground"
    try:
        atm = _build_atmosphere(scene, (550.0,))
        top = atm.top_radius - atm.planet_radius
    except Exception:  # noqa: BLE001 - a custom atmosphere file: Earth's 60 km top
        top = 60e3
    return sun, "elevated" if scene.altitude < top else "space"


def _ms_accuracy_current(acc: dict, name: str = "default") -> bool:
    """The measurement of grid ``name`` is of the installed method (field version) and of
    that grid as installed."""
    import dataclasses  # noqa: PLC0415

    from ..sky import multiple  # noqa: PLC0415

    grid = {**dataclasses.asdict(multiple.MULTIPLE_SCATTERING_GRIDS[name]),
            "order_tolerance": multiple.DEFAULT_ORDER_TOLERANCE}
    measured = acc.get("grids", {}).get(name, {})
    return acc.get("field_version") == multiple._FIELD_VERSION and measured.get("grid_fields") == grid


def _pct(x: float) -> str:
    return f"{100.0 * float(x):.2g} %"


def _ms_error_estimate(scene) -> str:
    """The measured error of ``multiple_scattering`` on the scene's grid for its regime."""
    name, _ = _ms_grid(scene)
    try:
        acc = ms_accuracy()
        sun, obs = _ms_regimes(scene)
        measured = acc["grids"][name]
        if obs == "ground":
            r = measured["sun_regimes_ground_observer"][sun]
            where = r["description"]
        else:
            r = measured["observer_regimes"][obs]
            sun_deg = ", ".join(f"{e:g}°" for e in r["sun_elevations_deg"])
            where = f"an {r['description']} (measured with the sun at {sun_deg})"
    except (OSError, KeyError, ValueError):
        return f"multiple scattering on the {name} grid; measured accuracy not available"
    text = (f"multiple scattering, {name} grid: max {_pct(r['max_rel_total'])} of total "
            f"({_pct(r['max_rel_ms'])} of the MS part) for {where}, measured against a "
            "grid finer in every knob (docs/convergence.md)")
    if not _ms_accuracy_current(acc, name):
        text += (f"; CAUTION: measured for another version of the method or of the {name} "
                 "grid (rerun benchmarks/ms_accurate_grid.py)")
    if scene.orders is not None:
        text += (f"; measured with automatic orders, this scene fixes orders={scene.orders} "
                 "(fewer orders are biased low)")
    if scene.ground_albedo > 0:
        text += "; measured with a black ground"
    return text


def physical_adapter(function_name: str) -> ModelAdapter:
    """Adapter of ``single_scattering`` or ``multiple_scattering`` (see module notes).

    Parameters
    ----------
    function_name : {"single_scattering", "multiple_scattering"}
        The numerical model; the function of that name is looked up in the package when
        the adapter prepares a render.

    Returns
    -------
    ModelAdapter
        A new, unregistered adapter named ``function_name``: spectral, with a separate haze
        term, valid for any observer (not ground-only), taking custom atmospheres, with the
        wavelengths of the scene's ``sampling`` and its error estimate (a fixed statement
        for single scattering, the measured per-regime accuracy for multiple scattering).

    Raises
    ------
    ValueError
        If ``function_name`` is neither of the two.
    """
    if function_name == "single_scattering":
        desc = "numerical single scattering on a spherical planet (Nishita 1993 / seed 002)"
        err = "quadrature error <= 1e-3 relative (default method); single scattering only"
        cost = 3e-5
    elif function_name == "multiple_scattering":
        desc = "numerical multiple scattering (seed 004 orders of scattering)"
        err = _ms_error_estimate  # measured per regime (ms_accuracy.json)
        cost = 1e-4
    else:
        raise ValueError(
            f"function_name={function_name!r} is not valid; choose one of "
            "['multiple_scattering', 'single_scattering']"
        )
    return ModelAdapter(
        name=function_name,
        description=desc,
        prepare=_make_physical_prepare(function_name),
        spectral=True,
        separate_haze=True,
        ground_only=False,
        horizontally_uniform=True,
        cost_per_direction=cost,
        wavelengths=_physical_wavelengths,
        error_estimate=err,
        accepts_atmosphere=True,
    )


def _register_available():
    if all(_lookup(n) is not None for n in ("hoffman_preetham_sky", "turbidity_haze",
                                             "hoffman_preetham_air_scattering",
                                             "HOFFMAN_PREETHAM_WAVELENGTHS")):
        register_model(_HOFFMAN_PREETHAM, replace=True)
    for name in ("single_scattering", "multiple_scattering"):
        if _lookup(name) is not None:
            register_model(physical_adapter(name), replace=True)


_register_available()

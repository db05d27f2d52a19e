"""The plan: the minimal work a scene needs, decided before anything is evaluated.

Public objects
--------------
:class:`Plan`, :func:`plan`
    The minimal set of terms a scene needs.  The renderer follows the plan; the
    plan is printed by ``atmoscatter render --explain`` and stored in the EXR
    header.
:func:`auto_sampling_rule`
    The measured rule by which ``sampling = "auto"`` chooses three wavelengths or a
    spectrum.

The plan reads a :class:`~atmoscatter.scene.Scene` (what the user asked for) and the
model's :class:`~atmoscatter.render.models.ModelAdapter` (what the model can skip), and
records every decision with its reason.  Angles in the plan are in radians
(:attr:`Plan.sun_zenith`, :attr:`Plan.sun_azimuth`, azimuth from north toward east);
:attr:`Plan.sun_direction` uses the local frame x = east, y = north, z = up.
"""

from __future__ import annotations

import dataclasses
import functools
import json
import math
import os
from dataclasses import dataclass, field

import numpy as np

from ..atmosphere import load_atmosphere
from ..scene import GROUND_OBSERVER_ALTITUDE, Scene, is_atmosphere_file, parse_time
from ..sun import earth_sun_distance

__all__ = ["Plan", "plan", "auto_sampling_rule"]

#: Default batch size (directions per model call).  With ~40 float64
#: temporaries per direction this keeps a batch near 20 MB per worker.
DEFAULT_BATCH_SIZE = 65536


# ----------------------------------------------------------------------------
# the plan
# ----------------------------------------------------------------------------
@dataclass(frozen=True)
class Plan:
    """The minimal work a scene needs; the renderer follows it exactly.

    Attributes
    ----------
    model : str
        Model name (key of :data:`atmoscatter.render.models.MODELS`).
    quantity : str
        What the model is asked for: ``"Y"`` (luminance only), ``"XYZ"``, or
        ``"spectral"`` (spectral radiance, integrated to XYZ by the adapter).
    layers : tuple of str
        Output layers: some of ``RGB``, ``XYZ``, ``Y``, ``spectral``.
    chromaticity : bool
        Whether chromaticity (x, y) is computed at all.
    haze : bool
        Whether an aerosol/haze term is evaluated (False at turbidity 1).
    haze_separate : bool
        Whether the model has a separate haze term at all (Preetham and the
        CIE skies fold turbidity into their fits).
    spectral_integration : str
        ``"none"``, ``"Y only"`` (ȳ only) or ``"XYZ"`` (three CMFs).
    wavelengths : tuple of float
        Wavelengths [nm] the physical model is evaluated at (empty otherwise).
    skip_below_horizon : bool
        Directions below the horizon are not evaluated but filled with
        ``ground_value`` (a ground observer sees the ground there).
    horizon_z : float
        Directions with z < horizon_z count as below the horizon.
    ground_value : str
        What below-horizon directions are filled with (documented text).
    symmetry : bool
        Mirror symmetry about the solar vertical: only one of each mirror pair
        of directions in a batch is evaluated.
    sun_disc : bool
        Whether the sun disc is drawn (no sun-disc work otherwise).
    sun_zenith, sun_azimuth : float
        Sun angles [rad] (azimuth from north toward east).
    sun_source : str
        Where the sun angles came from.
    distance_au : float
        Earth–Sun distance [AU] for the scene's date (1.0 if no date).
    batch_size : int
        Directions per model call (bounds memory).
    notes : tuple of str
        Human-readable reasons for each decision.
    atmosphere : Atmosphere or None
        A custom :class:`~atmoscatter.Atmosphere` given to :func:`plan` (physical
        models only); None means the scene's preset.
    sampling : str
        Spectral sampling actually used: ``"rgb"`` (three wavelengths expanded
        as a power law), ``"spectral"``, or ``""`` (not a spectral evaluation).
    sampling_reason : str
        Why (for ``sampling="auto"``: the measured colour error of three
        wavelengths at this sun elevation and where it was measured).
    numerics : str
        The numerical method of the physical models and its settings (for
        ``multiple_scattering``: how many scattering orders and the field grid); ``""``
        for the analytic models.
    accuracy : str
        The model's stated error for this scene (the EXR header's ``error_estimate``;
        for ``multiple_scattering`` the measured figure of the scene's regime).
    """

    model: str
    quantity: str
    layers: tuple
    chromaticity: bool
    haze: bool
    haze_separate: bool
    spectral_integration: str
    wavelengths: tuple
    skip_below_horizon: bool
    horizon_z: float
    ground_value: str
    symmetry: bool
    sun_disc: bool
    sun_zenith: float
    sun_azimuth: float
    sun_source: str
    distance_au: float
    batch_size: int
    notes: tuple = field(default_factory=tuple)
    atmosphere: object = field(default=None, compare=False)
    sampling: str = ""
    sampling_reason: str = ""
    numerics: str = ""
    accuracy: str = ""

    @property
    def sun_direction(self) -> np.ndarray:
        """Unit vector toward the sun (x = east, y = north, z = up)."""
        z, a = self.sun_zenith, self.sun_azimuth
        return np.array([math.sin(z) * math.sin(a), math.sin(z) * math.cos(a), math.cos(z)])

    def to_dict(self) -> dict:
        """The plan as a JSON-serialisable dictionary."""
        d = {f.name: getattr(self, f.name) for f in dataclasses.fields(self)}
        d["atmosphere"] = None if self.atmosphere is None else getattr(
            self.atmosphere, "name", "custom")
        d["layers"] = list(self.layers)
        d["wavelengths"] = list(self.wavelengths)
        d["notes"] = list(self.notes)
        return d

    def to_json(self) -> str:
        """The plan as compact JSON (stored in the EXR header)."""
        return json.dumps(self.to_dict(), sort_keys=True)

    def explain(self) -> str:
        """A readable multi-line description (``atmoscatter render --explain``)."""
        lines = [
            f"model            : {self.model} (asked for {self.quantity})",
            f"layers           : {', '.join(self.layers)}",
            f"sun              : zenith {math.degrees(self.sun_zenith):.4f} deg, azimuth "
            f"{math.degrees(self.sun_azimuth):.4f} deg ({self.sun_source}); "
            f"Earth-Sun distance {self.distance_au:.5f} AU",
            "haze term        : " + (("yes" if self.haze else "skipped") if self.haze_separate
                                     else "part of the fit (turbidity is a fit parameter)"),
            f"chromaticity     : {'yes' if self.chromaticity else 'skipped'}",
            f"spectral integr. : {self.spectral_integration}"
            + (f" over {len(self.wavelengths)} wavelengths" if self.wavelengths else ""),
        ]
        if self.sampling:
            lines.append(f"sampling         : {self.sampling} ({len(self.wavelengths)} wavelengths)"
                         + (f" — {self.sampling_reason}" if self.sampling_reason else ""))
        if self.numerics:
            lines.append(f"numerics         : {self.numerics}")
        if self.accuracy:
            lines.append(f"accuracy         : {self.accuracy}")
        lines += [
            "below horizon    : "
            + (f"not evaluated (z < {self.horizon_z:g}), filled with {self.ground_value}"
               if self.skip_below_horizon else "evaluated"),
            f"mirror symmetry  : {'used' if self.symmetry else 'not used'}",
            f"sun disc         : {'drawn' if self.sun_disc else 'skipped'}",
            f"batch size       : {self.batch_size} directions",
        ]
        if self.notes:
            lines.append("why:")
            lines.extend(f"  - {n}" for n in self.notes)
        return "\n".join(lines)


def _ground_value_text(scene: Scene) -> str:
    if scene.ground_albedo == 0.0:
        return "0 (black ground, ground_albedo = 0)"
    return (f"a Lambertian ground of albedo {scene.ground_albedo:g} lit by the model's own "
            "sky and the transmitted direct sun (rho * E_h / pi)")



#: Models the measured ``sampling="auto"`` rule applies to (preset atmospheres).
AUTO_SAMPLING_MODELS = ("single_scattering", "multiple_scattering")


def auto_sampling_rule() -> dict:
    """The measured rule of ``sampling="auto"`` (``atmoscatter/data/spectral_sampling.json``).

    Generated by ``benchmarks/spectral_sampling.py`` from
    ``docs/convergence/spectral_sampling.md``: ``elevation_threshold_deg`` (spectral
    sampling below it), ``wavelength_step_nm``/``n_wavelengths`` (the step used then),
    ``limit_dE2000`` and ``statistic`` (the target), and the measured ΔE2000 of 3-wavelength
    sampling against the reference spectrum by sun elevation
    (``rgb_dE2000_by_elevation``, worst atmosphere).

    Returns
    -------
    dict
        The rule (keys above; angles [deg], wavelengths [nm]).
    """
    return dict(_auto_rule())


@functools.lru_cache(maxsize=1)
def _auto_rule() -> dict:
    from importlib import resources  # noqa: PLC0415

    path = resources.files("atmoscatter") / "data" / "spectral_sampling.json"
    return json.loads(path.read_text(encoding="utf-8"))


def _measured_rgb_error(rule, elevation_deg):
    """ΔE2000 of 3-wavelength sampling measured at ``elevation_deg`` (linear between the
    measured elevations, the nearest one outside them)."""
    table = sorted((float(k), float(v)) for k, v in rule["rgb_dE2000_by_elevation"].items())
    e, v = np.array(table).T
    return float(np.interp(elevation_deg, e, v))


def _resolve_sampling(scene: Scene, adapter, sun_zenith: float, custom: bool):
    """(scene with a concrete ``sampling``, sampling used, reason) for ``plan``."""
    if not adapter.spectral:
        return scene, "", ""
    if custom:
        return scene, "", "a custom atmosphere: its own wavelengths"
    if scene.output == "spectral":
        return (dataclasses.replace(scene, sampling="spectral"), "spectral",
                f"output = spectral: every {scene.wavelength_step:g} nm (wavelength_step)")
    if scene.sampling != "auto":
        return scene, scene.sampling, "asked for (sampling = " + scene.sampling + ")"
    if scene.model not in AUTO_SAMPLING_MODELS:
        return (dataclasses.replace(scene, sampling="rgb"), "rgb",
                f"auto: the spectral-sampling rule is measured for {', '.join(AUTO_SAMPLING_MODELS)} "
                f"only; {scene.model} keeps 3 wavelengths")
    rule = _auto_rule()
    elev = 90.0 - math.degrees(sun_zenith)
    de = _measured_rgb_error(rule, elev)
    src = rule.get("source", "docs/convergence/spectral_sampling.md")
    stat = "95th percentile over the sky" if rule.get("statistic") == "dE_p95" else rule["statistic"]
    thr = float(rule["elevation_threshold_deg"])
    if elev < thr:
        step = float(rule["wavelength_step_nm"])
        return (dataclasses.replace(scene, sampling="spectral", wavelength_step=step), "spectral",
                f"auto, sun {elev:.4g} deg (below {thr:g} deg): 3-wavelength RGB is off by "
                f"ΔE2000 ≈ {de:.2g} here ({stat}; {src}); every {step:g} nm keeps it within "
                f"{float(rule['limit_dE2000']):g}")
    return (dataclasses.replace(scene, sampling="rgb"), "rgb",
            f"auto, sun {elev:.4g} deg (at or above {thr:g} deg): 3-wavelength RGB is within "
            f"ΔE2000 ≈ {de:.2g} of a spectrum here ({stat}; {src})")


def plan(scene: Scene, *, batch_size: int | None = None, atmosphere=None) -> Plan:
    """Decide the minimal work for ``scene``.

    Decisions (each recorded in :attr:`Plan.notes`):

    * **haze** — skipped at turbidity 1 (no aerosol) for models with a separate
      haze term; the Preetham fit has none (turbidity is a fit parameter).
    * **luminance only** (``output = "luminance"``) — the model is asked for Y
      only: no chromaticity, and for spectral models only the ȳ integral.
    * **spectral** — spectral radiance is only kept when ``output = "spectral"``.
    * **below the horizon** — for an observer on the ground (altitude < 1 m) or
      a ground-only model, directions with z < 0 are not evaluated but filled
      with the documented ground value (0 unless ``ground_albedo`` > 0).
    * **mirror symmetry** — for a horizontally uniform model, mirror pairs of
      directions about the solar vertical are evaluated once (``auto`` uses it
      for the models whose per-direction cost exceeds the cost of finding the
      pairs).
    * **sun disc** — only evaluated when ``sun_disc`` is true.
    * **spectral sampling** (``sampling = "auto"``, physical models with a preset
      atmosphere) — spectral sampling every ``wavelength_step_nm`` when the sun
      is below ``elevation_threshold_deg`` of :func:`auto_sampling_rule`, else
      the three RGB wavelengths: the threshold and the step are measured by
      ``benchmarks/spectral_sampling.py`` (ΔE2000 of the sky map against a
      10 nm spectrum, ``docs/convergence/spectral_sampling.md``).  An explicit
      ``rgb``/``spectral`` is respected.

    ``atmosphere`` (an :class:`~atmoscatter.Atmosphere`) replaces the scene's
    preset for the physical models; its wavelengths are then the ones
    evaluated (three or fewer: expanded as a power law; more: integrated as a
    spectrum, which should cover 380–780 nm).

    Parameters
    ----------
    scene : Scene
        What to render.
    batch_size : int, optional
        Directions per model call, ≥ 1 (default :data:`DEFAULT_BATCH_SIZE`).
    atmosphere : Atmosphere, optional
        Replaces the scene's preset for the physical models.

    Returns
    -------
    Plan
        The decisions and their reasons (``Plan.notes``); the renderer follows it exactly.
    """
    from .models import get_model  # noqa: PLC0415

    adapter = get_model(scene.model)
    notes = []
    if atmosphere is None and is_atmosphere_file(scene.atmosphere):
        atmosphere = _load_atmosphere_file(scene.atmosphere)
    zen, azi, source = scene.sun_angles()
    _note_undefined_sun(scene, adapter, zen, notes)
    distance = float(earth_sun_distance(parse_time(scene.time))) if scene.time else 1.0

    # what is asked for --------------------------------------------------------
    if scene.output == "luminance":
        quantity, layers, chroma = "Y", ("Y",), False
        notes.append("only luminance is asked: no chromaticity, Y only")
    elif scene.output == "xyz":
        quantity, layers, chroma = "XYZ", ("RGB", "XYZ"), True
    elif scene.output == "spectral":
        if not adapter.spectral:
            raise ValueError(
                f"output='spectral' needs a spectral model; {scene.model!r} is photometric "
                f"(spectral models: {', '.join(n for n, a in _models().items() if a.spectral)})"
            )
        quantity, layers, chroma = "spectral", ("RGB", "spectral"), True
    else:
        quantity, layers, chroma = "XYZ", ("RGB",), True
    if scene.alpha and "RGB" in layers:
        layers = layers + ("A",)

    # haze --------------------------------------------------------------------
    if adapter.separate_haze:
        haze = scene.turbidity > 1.0
        if not haze:
            notes.append("turbidity 1: no aerosol, the haze term is left out")
    elif adapter.driven_by:
        haze = False
        notes.append(f"{scene.model}: driven by {adapter.driven_by}; turbidity is not used")
    else:
        haze = scene.turbidity > 1.0
        notes.append(f"{scene.model}: turbidity is a parameter of the fit (no separate haze term)")

    rng = adapter.turbidity_range
    if rng is not None and not rng[0] <= scene.turbidity <= rng[1]:
        notes.append(f"turbidity {scene.turbidity:g} is outside {scene.model}'s fit range "
                     f"{rng[0]:g}-{rng[1]:g}: the model clamps it (with a warning)")

    if atmosphere is not None:
        if not adapter.accepts_atmosphere:
            raise ValueError(
                f"a custom atmosphere is used by the physical models only "
                f"({', '.join(n for n, a in _models().items() if a.accepts_atmosphere)}); "
                f"{scene.model!r} does not take one")
        wl_custom = tuple(float(w) for w in np.atleast_1d(atmosphere.wavelengths_array))
        if len(wl_custom) < 2:
            raise ValueError("a custom atmosphere needs at least 2 wavelengths to give a colour")
        live = [c for c in atmosphere.constituents if not c.is_empty]
        haze = any(c.name not in ("rayleigh", "ozone") for c in live)
        notes.append(f"custom atmosphere {getattr(atmosphere, 'name', 'custom')!r} with "
                     f"{len(wl_custom)} wavelengths; constituents evaluated: "
                     + ", ".join(c.name for c in live))

    # spectral sampling ----------------------------------------------------------
    eff, sampling, sampling_reason = _resolve_sampling(scene, adapter, zen, atmosphere is not None)
    if atmosphere is not None:
        wavelengths = wl_custom
        integration = "Y only" if quantity == "Y" else "XYZ"
        sampling = "rgb" if len(wl_custom) <= 3 else "spectral"
    elif adapter.spectral and adapter.wavelengths(eff):
        wavelengths = adapter.wavelengths(eff)
        integration = "Y only" if quantity == "Y" else "XYZ"
        if quantity == "Y":
            notes.append("luminance only: the spectrum is integrated with y-bar alone")
    else:
        wavelengths = ()
        integration = "none"

    # below the horizon --------------------------------------------------------
    ground_observer = scene.altitude < GROUND_OBSERVER_ALTITUDE
    skip_below = ground_observer or adapter.ground_only
    if skip_below:
        notes.append(
            "observer on the ground: directions below the horizon are not integrated"
            if ground_observer else f"{scene.model} is defined for the upper hemisphere only"
        )

    # symmetry ------------------------------------------------------------------
    if scene.symmetry == "off" or not adapter.horizontally_uniform:
        symmetry = False
        if not adapter.horizontally_uniform:
            notes.append(f"{scene.model} is not horizontally uniform: no mirror symmetry")
    elif scene.symmetry == "on":
        symmetry = True
        notes.append("mirror symmetry about the solar vertical: forced on")
    else:
        symmetry = adapter.cost_per_direction >= 2e-6
        notes.append(
            "mirror symmetry about the solar vertical: each mirror pair evaluated once"
            if symmetry else
            f"{scene.model} is cheaper per direction than finding mirror pairs: symmetry not used"
        )

    if not scene.sun_disc:
        notes.append("sun disc not drawn: no sun-disc work")

    bs = DEFAULT_BATCH_SIZE if batch_size is None else int(batch_size)
    if bs < 1:
        raise ValueError(f"batch_size must be in [1, inf), got {batch_size!r}")
    return Plan(
        model=scene.model,
        quantity=quantity,
        layers=layers,
        chromaticity=chroma,
        haze=haze,
        haze_separate=adapter.separate_haze,
        spectral_integration=integration,
        wavelengths=tuple(float(w) for w in wavelengths),
        skip_below_horizon=skip_below,
        horizon_z=0.0,
        ground_value=_ground_value_text(scene),
        symmetry=symmetry,
        sun_disc=scene.sun_disc,
        sun_zenith=float(zen),
        sun_azimuth=float(azi),
        sun_source=source,
        distance_au=float(distance),
        batch_size=bs,
        notes=tuple(notes),
        atmosphere=atmosphere,
        sampling=sampling if wavelengths else "",
        sampling_reason=sampling_reason if wavelengths else "",
        numerics=_numerics_text(scene),
        accuracy=_accuracy_text(scene, adapter),
    )


def _numerics_text(scene: Scene) -> str:
    """What :attr:`Plan.numerics` says for ``scene`` (physical models only)."""
    if scene.model == "multiple_scattering":

        from ..sky import multiple  # noqa: PLC0415 - light: kernels load on first use

        tol = multiple.DEFAULT_ORDER_TOLERANCE
        if scene.orders is None:
            orders = (f"all scattering orders (summed until the estimated remaining orders are "
                      f"below {multiple._ACCELERATION * tol:g} of the multiple-scattering "
                      f"source, then added as a geometric tail of error < {tol:g}; at most "
                      f"{multiple._MAX_AUTO_ORDERS})")
        else:
            orders = f"{scene.orders} scattering order{'s' if scene.orders != 1 else ''} (fixed)"
        name = scene.ms_grid or "default"
        grid = multiple.MULTIPLE_SCATTERING_GRIDS[name].describe()
        return (f"{orders}; order 1 by single_scattering, higher orders from a precomputed "
                f"field on the {name} grid ({grid}; kept in the on-disk cache)")
    if scene.model == "single_scattering":
        from ..sky import single  # noqa: PLC0415

        method = scene.method or single.DEFAULT_SINGLE_SCATTERING_METHOD
        text = f"single scattering by '{method}'"
        if scene.method is None:
            text += (f"; batches of >= {single.TABLE_THRESHOLD} directions (>= "
                     f"{single.TWILIGHT_TABLE_THRESHOLD} with the sun below the horizon) use "
                     "the self-checked table")
        return text
    return ""


def _accuracy_text(scene: Scene, adapter) -> str:
    est = getattr(adapter, "error_estimate", "")
    try:
        return str(est(scene) if callable(est) else est)
    except Exception as exc:  # noqa: BLE001 - a statement must never break planning
        return f"not available ({type(exc).__name__})"


def _load_atmosphere_file(path):
    """:func:`load_atmosphere`, with every error naming the file."""
    try:
        return load_atmosphere(path)
    except (ValueError, TypeError, KeyError, OSError) as exc:
        msg = " ".join(str(exc).split()) or type(exc).__name__
        if os.fspath(path) in msg:
            raise ValueError(msg) from None
        raise ValueError(f"atmosphere file {os.fspath(path)!r}: {msg}") from None


#: Models whose fit is undefined with the sun below the horizon (they render black there).
SUN_ABOVE_HORIZON_MODELS = ("preetham",)


def _note_undefined_sun(scene, adapter, sun_zenith, notes) -> None:
    """A note (and a warning) when a model is used outside its defined sun range."""
    if scene.model in SUN_ABOVE_HORIZON_MODELS and sun_zenith > math.pi / 2:
        text = (f"{scene.model} is undefined with the sun below the horizon (sun elevation "
                f"{90.0 - math.degrees(sun_zenith):.3g} deg): the sky renders black; use "
                "single_scattering or multiple_scattering for twilight")
        notes.append(text)
        import warnings  # noqa: PLC0415

        warnings.warn(text, UserWarning, stacklevel=3)


def _models():
    from .models import MODELS  # noqa: PLC0415

    return MODELS


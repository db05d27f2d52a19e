"""Sky-model adapters: every model rendered in one set of absolute units.

Public objects
--------------
:class:`ModelAdapter`
    What the renderer needs to know about a model (its capabilities, its cost,
    its error estimate) and how to evaluate it for a batch of directions.
:data:`MODELS`
    Registry name → adapter of the models available in this installation.
    A model whose implementation is not present is simply not registered.
:func:`get_model`, :func:`register_model`, :func:`unregister_model`
    Look up and extend the registry (tests inject cheap or spying models).
:func:`physical_adapter`
    Adapter of a numerical model returning radiance per unit solar irradiance
    (``single_scattering``, ``multiple_scattering``).

Units
-----
Every adapter returns **CIE XYZ in cd m⁻²** (``quantity = "XYZ"``), or the
luminance **Y in cd m⁻²** alone (``quantity = "Y"``), or additionally the
spectral radiance [W m⁻² sr⁻¹ nm⁻¹] (``quantity = "spectral"``), so that two
models of one scene can be compared pixel by pixel.

* Photometric models (Preetham, CIE) return luminance/XYZ directly.  The CIE
  overcast and clear skies are luminance distributions only: their colour is
  taken as CIE D65 (:data:`CIE_SKY_CHROMATICITY`), so R = G = B in sRGB.
* Preetham asked for luminance only evaluates the Y row of the fit alone
  (``Y_z F_Y(θ, γ)/F_Y(0, θ_s)``), not the chromaticity distributions.
* Physical models return radiance per unit extraterrestrial irradiance
  [sr⁻¹]; the adapter multiplies by the ASTM G-173 ETR spectrum
  (:func:`atmoscatter.extraterrestrial_irradiance`, band-averaged over each
  sample's interval and scaled by ``1/d²`` for the Earth–Sun distance ``d`` of
  the scene's date) and integrates with the CIE 1931 2° CMFs
  (:func:`atmoscatter.cmf_weights`, K_m = 683 lm W⁻¹).
* RGB-sampled atmospheres (three wavelengths, 680/550/440 nm by default) are
  turned into a spectrum by interpolating the per-irradiance radiance ``f(λ)``
  as a power law between the samples (piecewise linear in ``log f`` against
  ``log λ``, extrapolated with the end slopes to 380–780 nm, 5 nm grid) — exact
  for a pure ``λ⁻⁴`` Rayleigh sky.  The output R, G, B are the colourspace's
  RGB of that XYZ: "R" is *not* the 680 nm radiance.

Turbidity
---------
``scene.turbidity`` is ``T = (τ_m + τ_h)/τ_m``, the vertical *extinction* optical depth of
molecules plus haze over that of the molecules (Rayleigh scattering only, ozone excluded),
at 550 nm (Preetham et al. 1999; errata 004.3):

* ``single_scattering`` / ``multiple_scattering``: the atmosphere
  :func:`atmoscatter.earth_turbidity_atmosphere` (real air, haze τ_h = (T − 1)·0.0970).
* ``hoffman_preetham``: real air (:func:`atmoscatter.hoffman_preetham_air_scattering`,
  ``air="standard"``) and :func:`atmoscatter.turbidity_haze` — the same definition with the
  model's 8.4 km / 1.25 km zenith optical lengths; same aerosol (Junge v = 4, ω = 0.9,
  HG g = 0.8).
* ``preetham`` and ``cie_clear`` (its zenith luminance): T is the *parameter of Preetham's
  fit*.  Preetham et al. defined it by the same ratio for the skies they simulated, so the
  renderer passes the scene's T unchanged; how bright that sky is against the physical
  sky of the same T is measured in the validation report (brightness table).
"""

from __future__ import annotations

import importlib
import math
from collections.abc import Callable
from dataclasses import dataclass, field
from functools import lru_cache

import numpy as np

__all__ = [
    "ModelAdapter",
    "MODELS",
    "get_model",
    "register_model",
    "unregister_model",
    "physical_adapter",
    "rgb_sampling_matrix",
    "CIE_SKY_CHROMATICITY",
    "HOFFMAN_PREETHAM_HAZE_G",
]


@dataclass(frozen=True)
class ModelAdapter:
    """A sky model as the renderer sees it.

    Parameters
    ----------
    name : str
        Registry key (the scene's ``model``).
    description : str
        One line for ``--explain`` and the docs.
    prepare : callable
        ``prepare(scene, plan) -> evaluate``; ``evaluate(directions)`` takes unit
        directions (n, 3) [local frame] and returns a dict with ``"XYZ"`` (n, 3)
        or ``"Y"`` (n,) [cd m⁻²] (per ``plan.quantity``) and, for
        ``quantity = "spectral"``, ``"spectral"`` (n, n_wl) [W m⁻² sr⁻¹ nm⁻¹].
        Setup that does not depend on the directions happens once in ``prepare``.
    spectral : bool
        The model computes spectra (can output spectral layers).
    separate_haze : bool
        The model has a haze/aerosol term that can be left out at turbidity 1.
    ground_only : bool
        Defined only for the upper hemisphere of a ground observer.
    horizontally_uniform : bool
        The sky depends on the direction only through its zenith angle and its
        azimuth relative to the sun (mirror symmetry about the solar vertical).
    cost_per_direction : float
        Rough evaluation cost [s] per direction (decides whether finding mirror
        pairs pays off).
    wavelengths : callable
        ``wavelengths(scene) -> tuple`` [nm] evaluated by a spectral model.
    error_estimate : str or callable
        Stated accuracy of the model (recorded in the EXR header), or
        ``error_estimate(scene) -> str`` when it depends on the scene (sun, observer).
    turbidity_range : tuple of float, optional
        Turbidity range of a fitted model (outside it the model clamps and warns).
    accepts_atmosphere : bool
        The model takes a custom :class:`~atmoscatter.Atmosphere` (``plan.atmosphere``).
    """

    name: str
    description: str
    prepare: Callable
    spectral: bool = False
    separate_haze: bool = False
    ground_only: bool = True
    horizontally_uniform: bool = True
    cost_per_direction: float = 2e-7
    wavelengths: Callable = field(default=lambda scene: ())
    error_estimate: str | Callable = "not stated"
    turbidity_range: tuple | None = None
    accepts_atmosphere: bool = False


MODELS: dict[str, ModelAdapter] = {}


def register_model(adapter: ModelAdapter, *, replace: bool = False) -> None:
    """Add ``adapter`` to :data:`MODELS` (``replace=True`` to overwrite a name).

    The model is then a valid ``scene.model`` (registered under ``adapter.name``) for
    :func:`~atmoscatter.plan` and :func:`~atmoscatter.render`.

    Parameters
    ----------
    adapter : ModelAdapter
        The model to register.
    replace : bool, optional
        Overwrite a model already registered under ``adapter.name`` (default False).

    Raises
    ------
    TypeError
        If ``adapter`` is not a :class:`ModelAdapter`.
    ValueError
        If ``adapter.name`` is already registered and ``replace`` is False.
    """
    if not isinstance(adapter, ModelAdapter):
        raise TypeError(f"adapter must be a ModelAdapter, got {type(adapter).__name__}")
    if adapter.name in MODELS and not replace:
        raise ValueError(f"model {adapter.name!r} is already registered")
    MODELS[adapter.name] = adapter


def unregister_model(name: str) -> None:
    """Remove ``name`` from :data:`MODELS` (no error if absent).

    Parameters
    ----------
    name : str
        Registry name of the model (``ModelAdapter.name``).  Built-in models can be removed
        too; they come back only with a new :func:`register_model`.
    """
    MODELS.pop(name, None)


def get_model(name: str) -> ModelAdapter:
    """The adapter registered as ``name``; ValueError listing the valid names.

    Parameters
    ----------
    name : str
        Registry name, a key of :data:`MODELS` (a ``scene.model`` value such as
        ``"preetham"`` or ``"multiple_scattering"``).

    Returns
    -------
    ModelAdapter
        The registered adapter (the object itself, not a copy).

    Raises
    ------
    ValueError
        If no model is registered as ``name``; the message lists the registered names.
    """
    if name not in MODELS:
        raise ValueError(f"model={name!r} is not valid; choose one of {sorted(MODELS)}")
    return MODELS[name]


def _lookup(name: str):
    """Find a public function of the package (flat API first, then known modules)."""
    pkg = importlib.import_module("atmoscatter")
    fn = getattr(pkg, name, None)
    if fn is not None:
        return fn
    for mod in ("sky", "sky.preetham", "sky.perez", "sky.cie", "sky.aerial", "sky.single",
                "sky.multiple", "sun"):
        try:
            m = importlib.import_module(f"atmoscatter.{mod}")
        except ImportError:
            continue
        fn = getattr(m, name, None)
        if fn is not None:
            return fn
    return None


# ----------------------------------------------------------------------------
# Preetham (analytic)
# ----------------------------------------------------------------------------
def _preetham_luminance_function(scene, plan):
    """Y only: ``Y = Y_z F_Y(θ, γ)/F_Y(0, θ_s)`` from the Y row of the Preetham fit.

    Uses the public pieces of :mod:`atmoscatter.sky.preetham` (coefficients,
    zenith value) and :func:`atmoscatter.perez`; the x and y distributions are
    never evaluated.  Returns None if those pieces are not available.
    """
    coef_fn = _lookup("preetham_distribution_coefficients")
    zen_fn = _lookup("preetham_zenith")
    perez = _lookup("perez")
    if coef_fn is None or zen_fn is None or perez is None:
        return None
    sun = plan.sun_direction
    theta_s = float(plan.sun_zenith)
    if sun[2] < 0.0:  # the Preetham policy: dark sky for a sun below the horizon
        return lambda d: {"Y": np.zeros(len(d))}
    A, B, C, D, E = np.asarray(coef_fn(scene.turbidity), dtype=float)[0]
    y_zenith = float(np.asarray(zen_fn(scene.turbidity, theta_s))[..., 0])
    norm = float(perez(0.0, theta_s, A, B, C, D, E))

    def evaluate(directions):
        d = np.asarray(directions, dtype=float)
        theta = np.arccos(np.clip(d[:, 2], 0.0, 1.0))
        # γ = 2 atan2(|v − s|, |v + s|): accurate at the sun and the anti-solar point
        gamma = 2.0 * np.arctan2(np.linalg.norm(d - sun, axis=-1), np.linalg.norm(d + sun, axis=-1))
        return {"Y": y_zenith * np.asarray(perez(theta, gamma, A, B, C, D, E)) / norm}

    return evaluate


def _prepare_preetham(scene, plan):
    if plan.quantity == "Y":
        lum = _preetham_luminance_function(scene, plan)
        if lum is not None:
            return lum
    fn = _lookup("preetham_sky")
    sun = plan.sun_direction
    turbidity = scene.turbidity
    if plan.quantity == "spectral":
        spectral = _lookup("preetham_sky_spectral")
        wl = np.asarray(plan.wavelengths, dtype=float)

        def evaluate_spectral(directions):
            # the D-series reconstruction can dip below zero far from the daylight locus
            # (low sun); an image gets the clipped spectrum rescaled to the model's Y
            return {"XYZ": np.asarray(fn(directions, sun, turbidity), dtype=float),
                    "spectral": np.asarray(spectral(directions, sun, turbidity, wl,
                                                    clip_negative=True), dtype=float)}

        return evaluate_spectral

    def evaluate(directions):
        xyz = np.asarray(fn(directions, sun, turbidity), dtype=float)
        if plan.quantity == "Y":
            return {"Y": xyz[..., 1]}
        return {"XYZ": xyz}

    return evaluate


def _preetham_wavelengths(scene):
    """Spectral layers of the Preetham sky only when asked for (CIE D-series, 380–780 nm)."""
    if scene.output != "spectral":
        return ()
    step = scene.wavelength_step
    n = int(math.floor((780.0 - 380.0) / step + 1e-9)) + 1
    return tuple(380.0 + step * np.arange(n))


# ----------------------------------------------------------------------------
# CIE overcast and clear skies (luminance distributions)
# ----------------------------------------------------------------------------
#: Chromaticity given to the luminance-only CIE skies: CIE D65 (x, y).
CIE_SKY_CHROMATICITY = (0.3127, 0.3290)


def _with_d65(y, quantity):
    if quantity == "Y":
        return {"Y": y}
    x, yy = CIE_SKY_CHROMATICITY
    return {"XYZ": np.stack([x / yy * y, y, (1.0 - x - yy) / yy * y], axis=-1)}


def _prepare_cie_overcast(scene, plan):
    fn = _lookup("cie_overcast_sky")
    zl = _lookup("cie_zenith_luminance")
    y_zenith = float(zl(plan.sun_zenith, method="krochmann"))

    def evaluate(directions):
        return _with_d65(np.asarray(fn(directions, y_zenith), dtype=float), plan.quantity)

    return evaluate


def _prepare_cie_clear(scene, plan):
    fn = _lookup("cie_clear_sky")
    zl = _lookup("cie_zenith_luminance")
    sun = plan.sun_direction
    y_zenith = float(zl(plan.sun_zenith, method="preetham", turbidity=scene.turbidity))

    def evaluate(directions):
        return _with_d65(np.asarray(fn(directions, sun, y_zenith), dtype=float), plan.quantity)

    return evaluate


_CIE_OVERCAST = ModelAdapter(
    name="cie_overcast",
    description="CIE standard overcast sky (Moon & Spencer 1942), zenith luminance after "
    "Krochmann (1963); colour: D65 chromaticity",
    prepare=_prepare_cie_overcast,
    cost_per_direction=5e-8,
    error_estimate="CIE standard distribution (exact by definition); absolute level from "
    "Krochmann's zenith-luminance fit; chromaticity assumed D65",
)

_CIE_CLEAR = ModelAdapter(
    name="cie_clear",
    description="CIE clear sky (Kittler), zenith luminance from Preetham et al. (1999); "
    "colour: D65 chromaticity",
    prepare=_prepare_cie_clear,
    cost_per_direction=2e-7,
    turbidity_range=(2.0, 10.0),
    error_estimate="CIE standard distribution; absolute level from the Preetham zenith fit "
    "(turbidity 2-10); chromaticity assumed D65",
)


_PREETHAM = ModelAdapter(
    name="preetham",
    description="Preetham, Shirley & Smits (1999) analytic clear sky (Perez fits of Y, x, y)",
    prepare=_prepare_preetham,
    spectral=True,
    wavelengths=_preetham_wavelengths,
    separate_haze=False,
    ground_only=True,
    cost_per_direction=3e-7,
    turbidity_range=(2.0, 10.0),
    error_estimate=(
        "Preetham 1999 fit to Nishita-type simulations; the authors do not state a bound; "
        "valid for turbidity 2-10 and the sun above the horizon"
    ),
)


# ----------------------------------------------------------------------------
# physical models: radiance per unit solar irradiance → absolute units
# ----------------------------------------------------------------------------
#: Fine grid [nm] on which RGB samples are expanded to a spectrum.
FINE_GRID = np.arange(380.0, 780.0 + 0.5, 5.0)


def rgb_sampling_matrix(sample_wavelengths, grid=FINE_GRID) -> np.ndarray:
    """Matrix ``A`` (n_samples, n_grid): ``log f(grid) = log f(samples) @ A``.

    Piecewise-linear interpolation in ``log λ`` between the (sorted) samples,
    linear extrapolation with the end segments' slopes: a power law
    ``f ∝ λ^p`` is reproduced exactly on the whole grid.

    Parameters
    ----------
    sample_wavelengths : array_like, shape (n_samples,)
        Wavelengths [nm] at which ``f`` is known, in any order, at least 2, positive,
        finite and distinct.
    grid : array_like, shape (n_grid,), optional
        Wavelengths [nm] > 0 to expand to (default :data:`FINE_GRID`, 380–780 nm every
        5 nm).

    Returns
    -------
    ndarray, shape (n_samples, n_grid)
        float64 weights; row ``i`` belongs to ``sample_wavelengths[i]`` (input order).  Each
        column has at most two non-zero entries and sums to 1; outside the samples' range
        the extrapolation gives one negative entry.

    Raises
    ------
    ValueError
        If fewer than 2 sample wavelengths are given, or any sample or grid wavelength is
        not positive and finite, or two samples are equal.
    """
    wl = np.asarray(sample_wavelengths, dtype=float).ravel()
    g = np.asarray(grid, dtype=float).ravel()
    if wl.size < 2:
        raise ValueError("RGB sampling needs at least 2 sample wavelengths")
    for name, v in (("sample_wavelengths", wl), ("grid", g)):
        if not np.all(np.isfinite(v) & (v > 0)):
            raise ValueError(f"{name} must be positive and finite [nm], got {v.tolist()!r}")
    if np.unique(wl).size != wl.size:
        raise ValueError(f"sample_wavelengths must be distinct, got {wl.tolist()!r}")
    lam = np.log(wl)
    order = np.argsort(lam)
    ls = lam[order]
    x = np.log(g)
    seg = np.clip(np.searchsorted(ls, x) - 1, 0, ls.size - 2)
    t = (x - ls[seg]) / (ls[seg + 1] - ls[seg])
    A_sorted = np.zeros((ls.size, x.size))
    cols = np.arange(x.size)
    A_sorted[seg, cols] = 1.0 - t
    A_sorted[seg + 1, cols] = t
    A = np.empty_like(A_sorted)
    A[order] = A_sorted
    return A


def _band_etr(wavelengths, distance_au):
    """ETR [W m⁻² nm⁻¹] averaged over each sample's interval (midpoints to neighbours)."""
    from .solar import extraterrestrial_irradiance, solar_spectrum_table  # noqa: PLC0415

    wl = np.asarray(wavelengths, dtype=float)
    tw, te = solar_spectrum_table()
    if wl.size == 1:
        return extraterrestrial_irradiance(wl, distance_au=distance_au)
    srt = np.sort(wl)
    edges = np.concatenate([[srt[0] - 0.5 * (srt[1] - srt[0])], 0.5 * (srt[1:] + srt[:-1]),
                            [srt[-1] + 0.5 * (srt[-1] - srt[-2])]])
    out = np.empty(srt.size)
    for i in range(srt.size):
        a, b = edges[i], edges[i + 1]
        inside = (tw > a) & (tw < b)
        x = np.concatenate([[a], tw[inside], [b]])
        y = np.interp(x, tw, te)
        out[i] = np.trapezoid(y, x) / (b - a)
    res = np.empty_like(out)
    res[np.searchsorted(srt, wl)] = out
    return res / distance_au**2


def _build_atmosphere(scene, wavelengths):
    from . import presets  # noqa: PLC0415

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


#: Exponent grid of the power-law integral tables (p in f ∝ λ^p, clipped to this range).
_P_GRID = np.linspace(-40.0, 40.0, 1601)


@lru_cache(maxsize=16)
def _power_law_tables(sample_wavelengths: tuple):
    """Integrals ``H_i(p) = K_m Σ_λ w(λ) E(λ) cmf(λ) (λ/λ_i)^p`` over segment i's range.

    With f(λ) = f_i (λ/λ_i)^{p_i} on segment i (the power-law expansion of
    :func:`rgb_sampling_matrix`), ``XYZ = Σ_i f_i H_i(p_i)`` exactly; H_i is
    tabulated against p (1 nm grid 380–780 nm, ETR band-averaged over 1 nm, at
    1 AU) and interpolated linearly (relative error ~1e-5).
    """
    from .colour import K_M, cmf_weights  # noqa: PLC0415

    lam = np.asarray(sample_wavelengths, dtype=float)
    order = np.argsort(lam)
    ls = lam[order]
    grid = np.arange(380.0, 780.0 + 0.5, 1.0)
    w = K_M * cmf_weights(grid) * _band_etr(grid, 1.0)[:, None]  # (n_grid, 3)
    seg = np.clip(np.searchsorted(ls, grid, side="right") - 1, 0, ls.size - 2)
    H = np.empty((ls.size - 1, _P_GRID.size, 3))
    for i in range(ls.size - 1):
        m = seg == i
        x = np.log(grid[m] / ls[i])  # (k,)
        H[i] = np.exp(np.outer(_P_GRID, x)) @ w[m]
    return order, ls, H


def _per_irradiance_converter(wavelengths, rgb_sampled, plan):
    """``convert(f)``: radiance per unit solar irradiance f (n, n_wl) [sr⁻¹] → plan's outputs.

    Multiplies by the band-averaged ASTM G-173 ETR at the scene's Earth–Sun
    distance and integrates with the CIE 1931 CMFs (K_m = 683 lm W⁻¹).  RGB
    samples are expanded to a 380–780 nm spectrum as a power law between the
    samples (:func:`rgb_sampling_matrix`); that integral is evaluated exactly
    per segment from tabulated ``H_i(p)`` (:func:`_power_law_tables`).  Only
    ȳ is used when ``plan.quantity == "Y"``.
    """
    from .colour import K_M, cmf_weights  # noqa: PLC0415

    wl = np.asarray(wavelengths, dtype=float)
    E = _band_etr(wl, plan.distance_au)
    channels = [1] if plan.quantity == "Y" else [0, 1, 2]
    if rgb_sampled:
        order, ls, H = _power_law_tables(tuple(float(w) for w in wl))
        H = H / plan.distance_au**2
        dlog = np.log(ls[1:] / ls[:-1])
    else:
        order = np.argsort(wl)
        W = np.empty((wl.size, 3))
        W[order] = cmf_weights(wl[order])
        W *= (K_M * E)[:, None]
        Wq = W[:, channels]

    def convert(f):
        f = np.maximum(np.asarray(f, dtype=float), 0.0)
        out = {}
        if rgb_sampled:
            fs = f[:, order]
            logf = np.log(np.maximum(fs, 1e-300))
            res = np.zeros((len(f), len(channels)))
            for i in range(ls.size - 1):
                p = np.clip((logf[:, i + 1] - logf[:, i]) / dlog[i], _P_GRID[0], _P_GRID[-1])
                for j, c in enumerate(channels):
                    res[:, j] += fs[:, i] * np.interp(p, _P_GRID, H[i, :, c])
        else:
            res = f @ Wq
        if plan.quantity == "spectral":
            out["spectral"] = f * E
        if plan.quantity == "Y":
            out["Y"] = res[..., 0]
        else:
            out["XYZ"] = res
        return out

    return convert


def _evaluated_directions(scene) -> int:
    """Lower estimate of the number of directions a render of ``scene`` evaluates: its
    pixels, halved for the ground an observer on the ground does not integrate and again
    for the mirror symmetry about the solar vertical."""
    n = scene.width * (scene.width * 6 if scene.projection == "cubemap" else scene.height)
    return n // 4


def _render_uses_table(scene, atm, sun) -> bool:
    """Whether ``single_scattering``'s default would use its table for the whole render."""
    from .sky import _quadrature as qd  # noqa: PLC0415
    from .sky import single  # noqa: PLC0415

    try:
        prepared = qd.prepare_atmosphere(atm)
    except (TypeError, ValueError, AttributeError):  # a duck-typed atmosphere: leave it be
        return False
    return single._table_allowed(prepared, float(scene.altitude), np.asarray(sun, float),
                                 _evaluated_directions(scene))


def _make_physical_prepare(function_name):
    def prepare(scene, plan):
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
        elif scene.method is not None:
            kwargs["method"] = scene.method
        elif function_name == "single_scattering" and _render_uses_table(scene, atm, sun):
            # the renderer calls the model once per batch: the default's choice of the
            # table must follow the whole sky's direction count, not the batch's (at
            # twilight the table pays off from 65 536 directions, more than a batch)
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
    """Measured default-grid errors of ``multiple_scattering`` per regime.

    Read (once, lazily) from ``atmoscatter/data/ms_accuracy.json``, written by
    ``benchmarks/ms_convergence.py`` (full run; see ``docs/convergence.md``).
    """
    if not _MS_ACCURACY:
        import json  # noqa: PLC0415
        from importlib import resources  # noqa: PLC0415

        text = resources.files("atmoscatter").joinpath("data/ms_accuracy.json").read_text("utf-8")
        _MS_ACCURACY.update(json.loads(text))
    return _MS_ACCURACY


def _ms_regimes(scene) -> tuple[str, str]:
    """(sun regime, observer regime) keys of :func:`ms_accuracy` for a scene."""
    from .scene import GROUND_OBSERVER_ALTITUDE  # noqa: PLC0415

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


def _ms_accuracy_current(acc: dict) -> bool:
    """The measurement is of the installed method (field version) and default grid."""
    import dataclasses  # noqa: PLC0415

    from .sky import multiple  # noqa: PLC0415

    grid = {**dataclasses.asdict(multiple.MULTIPLE_SCATTERING_GRID),
            "order_tolerance": multiple.DEFAULT_ORDER_TOLERANCE}
    return (acc.get("field_version") == multiple._FIELD_VERSION
            and acc.get("default_grid_fields") == grid)


def _pct(x: float) -> str:
    return f"{100.0 * float(x):.2g} %"


def _ms_error_estimate(scene) -> str:
    """The measured default-grid error of ``multiple_scattering`` for the scene's regime."""
    try:
        acc = ms_accuracy()
        sun, obs = _ms_regimes(scene)
        if obs == "ground":
            r = acc["sun_regimes_ground_observer"][sun]
            where = r["description"]
        else:
            r = acc["observer_regimes"][obs]
            sun_deg = ", ".join(f"{e:g}°" for e in r["sun_elevations_deg"])
            where = f"an {r['description']} (measured with the sun at {sun_deg})"
    except (OSError, KeyError, ValueError):
        return "multiple scattering on the default grid; measured accuracy not available"
    text = (f"multiple scattering, default grid: max {_pct(r['max_rel_total'])} of total "
            f"({_pct(r['max_rel_ms'])} of the MS part) for {where}, measured against a "
            "refined grid (docs/convergence.md)")
    if not _ms_accuracy_current(acc):
        text += ("; CAUTION: measured for another version of the method or default grid "
                 "(rerun benchmarks/ms_convergence.py)")
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


# ----------------------------------------------------------------------------
# CIE standard general skies and the Perez all-weather sky (daylighting)
# ----------------------------------------------------------------------------
def _prepare_cie_standard(scene, plan):
    from .sky.cie_standard import cie_standard_sky  # noqa: PLC0415

    sun = plan.sun_direction
    kw = {"zenith_luminance": scene.zenith_luminance,
          "diffuse_horizontal_illuminance": scene.diffuse_horizontal_illuminance}

    def evaluate(directions):
        y = np.asarray(cie_standard_sky(directions, sun, scene.cie_type, **kw), dtype=float)
        return _with_d65(y, plan.quantity)

    return evaluate


def _scene_extraterrestrial_irradiance(scene) -> float:
    """Solar constant 1367 W m⁻² scaled by 1/r² for the scene date (1 AU without a time)."""
    from .sky.perez_all_weather import SOLAR_CONSTANT  # noqa: PLC0415

    if not scene.time:
        return SOLAR_CONSTANT
    from .sun import earth_sun_distance  # noqa: PLC0415

    t = np.datetime64(scene.datetime().replace(tzinfo=None), "ns")
    return SOLAR_CONSTANT / float(earth_sun_distance(t)) ** 2


def _prepare_perez_all_weather(scene, plan):
    from .sky.perez_all_weather import perez_all_weather_sky  # noqa: PLC0415

    sun = plan.sun_direction
    kw = {"dew_point": scene.dew_point,
          "extraterrestrial_normal_irradiance": _scene_extraterrestrial_irradiance(scene)}
    dni, dhi = scene.direct_normal_irradiance, scene.diffuse_horizontal_irradiance
    perez_all_weather_sky(np.array([[0.0, 0.0, 1.0]]), sun, dni, dhi, **kw)  # errors up front

    def evaluate(directions):
        y = np.asarray(perez_all_weather_sky(directions, sun, dni, dhi, **kw), dtype=float)
        return _with_d65(y, plan.quantity)

    return evaluate


_CIE_STANDARD = ModelAdapter(
    name="cie_standard",
    description="CIE standard general sky, types 1-15 (ISO 15469 / CIE S 011), scaled by a "
    "zenith luminance or a diffuse horizontal illuminance; colour: D65 chromaticity",
    prepare=_prepare_cie_standard,
    cost_per_direction=2e-7,
    error_estimate="CIE S 011 relative distribution (exact to the standard's formulas); "
    "illuminance scaling by quadrature (< 1e-8 relative); chromaticity assumed D65",
)

_PEREZ_ALL_WEATHER = ModelAdapter(
    name="perez_all_weather",
    description="Perez, Seals & Michalsky (1993) all-weather sky from direct-normal and "
    "diffuse-horizontal irradiance, Perez et al. (1990) diffuse efficacy; colour: D65",
    prepare=_prepare_perez_all_weather,
    cost_per_direction=2e-7,
    error_estimate="Perez all-weather fit (published RMS errors of ~20-30 % per sky element); "
    "absolute level from the Perez 1990 diffuse efficacy (a few % RMS); chromaticity "
    "assumed D65",
)


def _register_available():
    if _lookup("preetham_sky") is not None:
        register_model(_PREETHAM, replace=True)
    if _lookup("cie_overcast_sky") is not None and _lookup("cie_zenith_luminance") is not None:
        register_model(_CIE_OVERCAST, replace=True)
    if _lookup("cie_clear_sky") is not None and _lookup("cie_zenith_luminance") is not None:
        register_model(_CIE_CLEAR, replace=True)
    register_model(_CIE_STANDARD, replace=True)
    register_model(_PEREZ_ALL_WEATHER, replace=True)
    if all(_lookup(n) is not None for n in ("hoffman_preetham_sky", "turbidity_haze",
                                             "hoffman_preetham_air_scattering",
                                             "HOFFMAN_PREETHAM_WAVELENGTHS")):
        register_model(_HOFFMAN_PREETHAM, replace=True)
    for name in ("single_scattering", "multiple_scattering"):
        if _lookup(name) is not None:
            register_model(physical_adapter(name), replace=True)


_register_available()

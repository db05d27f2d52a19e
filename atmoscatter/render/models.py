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

The built-in adapters live next to this module and register themselves when
:mod:`atmoscatter.render` is imported: :mod:`atmoscatter.render.analytic_adapters`
(Preetham, the CIE skies) and :mod:`atmoscatter.render.physical_adapters`
(Hoffman–Preetham, :func:`~atmoscatter.render.physical_adapters.physical_adapter` for
``single_scattering`` and ``multiple_scattering``), which convert radiance per unit
solar irradiance to absolute units with :mod:`atmoscatter.render.photometry`.

Units
-----
Every adapter returns **CIE XYZ in cd m⁻²** (``quantity = "XYZ"``), or the
luminance **Y in cd m⁻²** alone (``quantity = "Y"``), or additionally the
spectral radiance [W m⁻² sr⁻¹ nm⁻¹] (``quantity = "spectral"``), so that two
models of one scene can be compared pixel by pixel.

* Photometric models (Preetham, CIE) return luminance/XYZ directly.  The CIE
  overcast and clear skies are luminance distributions only: their colour is
  taken as CIE D65
  (:data:`~atmoscatter.render.analytic_adapters.CIE_SKY_CHROMATICITY`), so R = G = B in sRGB.
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
from collections.abc import Callable
from dataclasses import dataclass, field

__all__ = [
    "ModelAdapter",
    "MODELS",
    "get_model",
    "register_model",
    "unregister_model",
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
        Setup that does not depend on the directions happens once in ``prepare``.  A
        ``prepare`` with a keyword ``n_directions`` is passed the number of directions
        when the caller gives its own (``render(directions=...)``), so it can size
        direction-independent work (a whole-sky table) to them.
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
    driven_by : str
        For a model set by measured sky quantities rather than turbidity, what drives it
        (the plan then says so and that turbidity is not used); empty otherwise.
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
    driven_by: str = ""


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

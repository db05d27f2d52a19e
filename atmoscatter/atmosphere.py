"""Atmosphere description: density profiles, constituents and the planet.

Public objects
--------------
- Density profiles (relative density against altitude, 1 at the reference altitude):
  :class:`~atmoscatter.profiles.ExponentialProfile`,
  :class:`~atmoscatter.profiles.TabulatedProfile`, :class:`~atmoscatter.profiles.TentProfile`,
  defined in :mod:`atmoscatter.profiles` and re-exported here.
- :class:`Constituent`: one scattering/absorbing species (coefficients per wavelength at
  density 1, a profile and a phase function).
- :class:`Atmosphere`: planet radius, top-of-atmosphere radius, sample wavelengths and
  constituents.

All are frozen dataclasses validated on construction; per-wavelength sequences are stored as
tuples of floats (hashable, immutable) and exposed as NumPy arrays via ``*_array``
properties.  Presets live in :mod:`atmoscatter.presets`.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ._validate import as_float_array, check_positive
from .phase import CornetteShanksPhase, HenyeyGreensteinPhase, IsotropicPhase, RayleighPhase
from .profiles import ExponentialProfile, TabulatedProfile, TentProfile

__all__ = [
    "ExponentialProfile",
    "TabulatedProfile",
    "TentProfile",
    "Constituent",
    "Atmosphere",
    "atmosphere_to_dict",
    "atmosphere_from_dict",
    "load_atmosphere",
]

_PHASE_TYPES = (RayleighPhase, HenyeyGreensteinPhase, CornetteShanksPhase, IsotropicPhase)
_PROFILE_TYPES = (ExponentialProfile, TabulatedProfile, TentProfile)


def _per_wavelength(value, name: str, n: int | None) -> tuple[float, ...]:
    arr = check_positive(value, name, allow_zero=True, unit="m^-1").astype(float)
    if arr.ndim > 1:
        raise ValueError(f"{name} must be a scalar or a 1-D sequence (one per wavelength), got shape {arr.shape}")
    arr = np.atleast_1d(arr)
    if n is not None and arr.size == 1 and n > 1:
        arr = np.repeat(arr, n)
    return tuple(arr.tolist())


@dataclass(frozen=True)
class Constituent:
    """One species of the atmosphere (molecules, aerosols, an absorber such as ozone).

    Parameters
    ----------
    name : str
        Identifier (e.g. ``"rayleigh"``, ``"mie"``, ``"ozone"``).
    scattering : sequence of float
        Scattering coefficient at relative density 1, one per wavelength [m⁻¹], ≥ 0.
    absorption : sequence of float
        Absorption coefficient at relative density 1, one per wavelength [m⁻¹], ≥ 0.
        A scalar is broadcast to all wavelengths.
    profile : ExponentialProfile, TabulatedProfile or TentProfile
        Relative density against altitude.
    phase : RayleighPhase, HenyeyGreensteinPhase, CornetteShanksPhase or IsotropicPhase
        Scattering phase function (ignored where ``scattering`` is 0).
    """

    name: str
    scattering: Sequence[float]
    absorption: Sequence[float] = 0.0
    profile: Any = field(default_factory=lambda: ExponentialProfile(8000.0))
    phase: Any = field(default_factory=RayleighPhase)

    def __post_init__(self):
        if not isinstance(self.name, str) or not self.name:
            raise TypeError(f"name must be a non-empty string, got {self.name!r}")
        sca = _per_wavelength(self.scattering, f"{self.name}.scattering", None)
        ab = _per_wavelength(self.absorption, f"{self.name}.absorption", len(sca))
        if len(sca) == 1 and len(ab) > 1:
            sca = sca * len(ab)
        if len(ab) != len(sca):
            raise ValueError(
                f"{self.name}: scattering has {len(sca)} values but absorption has {len(ab)}"
            )
        if not isinstance(self.profile, _PROFILE_TYPES):
            raise TypeError(
                f"{self.name}.profile must be one of {[t.__name__ for t in _PROFILE_TYPES]}, "
                f"got {type(self.profile).__name__}"
            )
        if not isinstance(self.phase, _PHASE_TYPES):
            raise TypeError(
                f"{self.name}.phase must be one of {[t.__name__ for t in _PHASE_TYPES]}, "
                f"got {type(self.phase).__name__}"
            )
        object.__setattr__(self, "scattering", sca)
        object.__setattr__(self, "absorption", ab)

    @property
    def scattering_array(self) -> np.ndarray:
        """Scattering coefficients at density 1 [m⁻¹], shape (n_wavelengths,)."""
        return np.asarray(self.scattering, dtype=float)

    @property
    def absorption_array(self) -> np.ndarray:
        """Absorption coefficients at density 1 [m⁻¹], shape (n_wavelengths,)."""
        return np.asarray(self.absorption, dtype=float)

    @property
    def extinction_array(self) -> np.ndarray:
        """Extinction = scattering + absorption at density 1 [m⁻¹], shape (n_wavelengths,)."""
        return self.scattering_array + self.absorption_array

    @property
    def single_scattering_albedo(self) -> np.ndarray:
        """Scattering / extinction [-] (1 where the extinction is 0)."""
        ext = self.extinction_array
        return np.where(ext > 0, self.scattering_array / np.where(ext > 0, ext, 1.0), 1.0)

    @property
    def is_empty(self) -> bool:
        """True if the constituent neither scatters nor absorbs at any wavelength."""
        return not any(self.scattering) and not any(self.absorption)


@dataclass(frozen=True)
class Atmosphere:
    """A spherical planet with a layered atmosphere.

    Parameters
    ----------
    planet_radius : float
        Radius of the ground sphere [m], > 0 (Earth 6.36e6, Bruneton 2017).
    top_radius : float
        Radius of the top of the atmosphere [m], > ``planet_radius`` (Earth 6.42e6).
        Nothing scatters above it.
    wavelengths : sequence of float
        Sample wavelengths [nm], > 0, one per channel (the last axis of every result).
    constituents : sequence of Constituent
        Species; each must have one coefficient per wavelength.

    Examples
    --------
    >>> import atmoscatter as ac
    >>> atm = ac.Atmosphere(planet_radius=6.36e6, top_radius=6.42e6,
    ...     wavelengths=[680.0, 550.0, 440.0],
    ...     constituents=[ac.Constituent(name="rayleigh", scattering=[5.8e-6, 1.36e-5, 3.31e-5],
    ...         absorption=[0, 0, 0], profile=ac.ExponentialProfile(scale_height=8000.0),
    ...         phase=ac.RayleighPhase())])
    >>> atm.n_wavelengths
    3
    """

    planet_radius: float
    top_radius: float
    wavelengths: Sequence[float]
    constituents: Sequence[Constituent] = ()
    name: str = "custom"

    def __post_init__(self):
        check_positive(self.planet_radius, "planet_radius", unit="m")
        check_positive(self.top_radius, "top_radius", unit="m")
        if not float(self.top_radius) > float(self.planet_radius):
            raise ValueError(
                f"top_radius must be > planet_radius ({float(self.planet_radius)!r} m), "
                f"got {float(self.top_radius)!r}"
            )
        wl = check_positive(self.wavelengths, "wavelengths", unit="nm").astype(float)
        wl = np.atleast_1d(wl)
        if wl.ndim != 1:
            raise ValueError(f"wavelengths must be 1-D, got shape {wl.shape}")
        cons = tuple(self.constituents)
        for c in cons:
            if not isinstance(c, Constituent):
                raise TypeError(f"constituents must be Constituent objects, got {type(c).__name__}")
            if len(c.scattering) != wl.size:
                raise ValueError(
                    f"constituent {c.name!r} has {len(c.scattering)} coefficients but the "
                    f"atmosphere has {wl.size} wavelengths"
                )
        names = [c.name for c in cons]
        if len(set(names)) != len(names):
            raise ValueError(f"constituent names must be unique, got {names}")
        object.__setattr__(self, "planet_radius", float(self.planet_radius))
        object.__setattr__(self, "top_radius", float(self.top_radius))
        object.__setattr__(self, "wavelengths", tuple(wl.tolist()))
        object.__setattr__(self, "constituents", cons)

    # -- derived quantities -------------------------------------------------------------
    @property
    def wavelengths_array(self) -> np.ndarray:
        """Sample wavelengths [nm], shape (n_wavelengths,)."""
        return np.asarray(self.wavelengths, dtype=float)

    @property
    def n_wavelengths(self) -> int:
        """Number of spectral channels."""
        return len(self.wavelengths)

    @property
    def thickness(self) -> float:
        """Height of the atmosphere, ``top_radius − planet_radius`` [m]."""
        return self.top_radius - self.planet_radius

    def constituent(self, name: str) -> Constituent:
        """The constituent called ``name`` (``KeyError`` listing the names if absent)."""
        for c in self.constituents:
            if c.name == name:
                return c
        raise KeyError(f"no constituent {name!r}; have {[c.name for c in self.constituents]}")

    def without(self, *names: str) -> Atmosphere:
        """A copy without the named constituents (used by plans that skip a term)."""
        return Atmosphere(
            planet_radius=self.planet_radius,
            top_radius=self.top_radius,
            wavelengths=self.wavelengths,
            constituents=tuple(c for c in self.constituents if c.name not in names),
            name=self.name,
        )

    def active_constituents(self) -> tuple[Constituent, ...]:
        """Constituents that scatter or absorb at some wavelength (empty ones are skipped)."""
        return tuple(c for c in self.constituents if not c.is_empty)

    def _sum_at(self, altitude, coefficient: str) -> np.ndarray:
        """Σ over constituents of density(altitude) × ``coefficient`` array, (..., n_wl)."""
        h = as_float_array(altitude, "altitude")[..., None]
        out = np.zeros(h.shape[:-1] + (self.n_wavelengths,), dtype=np.result_type(h, float))
        for c in self.active_constituents():
            out += c.profile.density(h) * getattr(c, coefficient)
        return out

    def scattering_at(self, altitude) -> np.ndarray:
        """Total scattering coefficient [m⁻¹] at ``altitude`` [m], shape (..., n_wavelengths)."""
        return self._sum_at(altitude, "scattering_array")

    def extinction_at(self, altitude) -> np.ndarray:
        """Total extinction coefficient [m⁻¹] at ``altitude`` [m], shape (..., n_wavelengths)."""
        return self._sum_at(altitude, "extinction_array")

    def vertical_optical_depth(self) -> np.ndarray:
        """Optical depth [-] from the ground to the top along the zenith, per wavelength.

        Exact for every profile type (see :func:`atmoscatter.optical_length`).
        """
        from .optical_length import optical_length

        tau = np.zeros(self.n_wavelengths)
        for c in self.active_constituents():
            ol = optical_length(
                c.profile, 0.0, 1.0, planet_radius=self.planet_radius, top_radius=self.top_radius
            )
            tau = tau + float(ol) * c.extinction_array
        return tau


# ---------------------------------------------------------------------------------------
# plain-data form (TOML / JSON atmosphere files)
# ---------------------------------------------------------------------------------------
_PROFILE_KINDS = {
    "exponential": (ExponentialProfile, ("scale_height", "reference_altitude")),
    "tabulated": (TabulatedProfile, ("altitudes", "densities")),
    "tent": (TentProfile, ("center", "half_width")),
}
_PHASE_KINDS = {
    "rayleigh": (RayleighPhase, ()),
    "isotropic": (IsotropicPhase, ()),
    "henyey_greenstein": (HenyeyGreensteinPhase, ("g",)),
    "cornette_shanks": (CornetteShanksPhase, ("g",)),
}


def _typed(d, kinds, what: str):
    if isinstance(d, str):
        d = {"type": d}
    if not isinstance(d, dict) or "type" not in d:
        raise ValueError(f"{what} must be a table with a 'type' (one of {sorted(kinds)}), got {d!r}")
    kind = d["type"]
    if kind not in kinds:
        raise ValueError(f"{what} type {kind!r} is not valid; choose one of {sorted(kinds)}")
    cls, keys = kinds[kind]
    extra = set(d) - set(keys) - {"type"}
    if extra:
        raise ValueError(f"{what} of type {kind!r} has unknown keys {sorted(extra)}; valid: {list(keys)}")
    return cls(**{k: d[k] for k in keys if k in d})


def atmosphere_to_dict(atmosphere: Atmosphere) -> dict:
    """Plain-data form of an :class:`Atmosphere` (numbers, strings, lists; TOML/JSON ready).

    The inverse of :func:`atmosphere_from_dict`; every field round-trips exactly.

    Parameters
    ----------
    atmosphere : Atmosphere
        The atmosphere to convert.

    Returns
    -------
    dict
        Keys as in :func:`atmosphere_from_dict` (lengths [m], wavelengths [nm], coefficients
        [m⁻¹]).
    """
    def profile(p):
        kind = {v[0]: k for k, v in _PROFILE_KINDS.items()}[type(p)]
        return {"type": kind, **{k: (list(getattr(p, k)) if isinstance(getattr(p, k), tuple)
                                      else getattr(p, k)) for k in _PROFILE_KINDS[kind][1]}}

    def phase(p):
        kind = {v[0]: k for k, v in _PHASE_KINDS.items()}[type(p)]
        return {"type": kind, **{k: getattr(p, k) for k in _PHASE_KINDS[kind][1]}}

    return {
        "name": atmosphere.name,
        "planet_radius": atmosphere.planet_radius,
        "top_radius": atmosphere.top_radius,
        "wavelengths": list(atmosphere.wavelengths),
        "constituents": [
            {"name": c.name, "scattering": list(c.scattering), "absorption": list(c.absorption),
             "profile": profile(c.profile), "phase": phase(c.phase)}
            for c in atmosphere.constituents
        ],
    }


def atmosphere_from_dict(data: dict) -> Atmosphere:
    """Build an :class:`Atmosphere` from its plain-data form.

    Keys: ``planet_radius``, ``top_radius`` [m], ``wavelengths`` [nm], optional ``name`` and
    ``constituents``, a list of tables with ``name``, ``scattering`` and ``absorption``
    (per wavelength [m⁻¹] at density 1; a single number is broadcast), ``profile``
    (``{type = "exponential", scale_height = 8000}``, ``"tent"`` with ``center`` and
    ``half_width``, or ``"tabulated"`` with ``altitudes`` and ``densities``) and ``phase``
    (``"rayleigh"``, ``"isotropic"``, or ``{type = "henyey_greenstein", g = 0.8}`` /
    ``"cornette_shanks"``).  Unknown keys and bad values raise ``ValueError`` naming them.

    Parameters
    ----------
    data : mapping
        The plain-data form (keys above; lengths [m], wavelengths [nm], coefficients [m⁻¹]).

    Returns
    -------
    Atmosphere
        The validated atmosphere.

    Examples
    --------
    >>> atm = atmosphere_from_dict({"planet_radius": 6.36e6, "top_radius": 6.42e6,
    ...     "wavelengths": [680, 550, 440], "constituents": [{"name": "rayleigh",
    ...     "scattering": [5.8e-6, 1.36e-5, 3.31e-5], "absorption": 0,
    ...     "profile": {"type": "exponential", "scale_height": 8000}, "phase": "rayleigh"}]})
    >>> atm.constituents[0].profile.scale_height
    8000.0
    """
    if not isinstance(data, dict):
        raise TypeError(f"an atmosphere must be a table (dict), got {type(data).__name__}")
    allowed = {"name", "planet_radius", "top_radius", "wavelengths", "constituents"}
    extra = set(data) - allowed
    if extra:
        raise ValueError(f"unknown atmosphere keys {sorted(extra)}; valid: {sorted(allowed)}")
    for k in ("planet_radius", "top_radius", "wavelengths"):
        if k not in data:
            raise ValueError(f"atmosphere needs {k!r}")
    cons = []
    for i, c in enumerate(data.get("constituents", [])):
        if not isinstance(c, dict):
            raise ValueError(f"constituents[{i}] must be a table, got {c!r}")
        ckeys = {"name", "scattering", "absorption", "profile", "phase"}
        extra = set(c) - ckeys
        if extra:
            raise ValueError(f"constituents[{i}] has unknown keys {sorted(extra)}; valid: {sorted(ckeys)}")
        if "name" not in c or "scattering" not in c or "profile" not in c:
            raise ValueError(f"constituents[{i}] needs 'name', 'scattering' and 'profile'")
        cons.append(Constituent(
            name=c["name"], scattering=c["scattering"], absorption=c.get("absorption", 0.0),
            profile=_typed(c["profile"], _PROFILE_KINDS, f"constituents[{i}].profile"),
            phase=_typed(c.get("phase", "rayleigh"), _PHASE_KINDS, f"constituents[{i}].phase"),
        ))
    return Atmosphere(planet_radius=data["planet_radius"], top_radius=data["top_radius"],
                      wavelengths=data["wavelengths"], constituents=tuple(cons),
                      name=str(data.get("name", "custom")))


def load_atmosphere(path) -> Atmosphere:
    """Read an atmosphere from a TOML or JSON file (format: :func:`atmosphere_from_dict`).

    Parameters
    ----------
    path : str or path-like
        A ``.toml`` or ``.json`` file.

    Returns
    -------
    Atmosphere
        The atmosphere the file describes.
    """
    import json
    import os

    path = os.fspath(path)
    if not os.path.isfile(path):
        raise ValueError(f"atmosphere file {path!r} does not exist")
    try:
        if path.lower().endswith(".json"):
            with open(path, encoding="utf-8") as fh:
                data = json.load(fh)
        elif path.lower().endswith(".toml"):
            try:
                import tomllib
            except ModuleNotFoundError:  # pragma: no cover - Python 3.10
                import tomli as tomllib
            with open(path, "rb") as fh:
                data = tomllib.load(fh)
        else:
            raise ValueError(f"atmosphere file {path!r} must end in .toml or .json")
    except (json.JSONDecodeError, UnicodeDecodeError) as exc:
        raise ValueError(f"{path}: not a valid atmosphere file ({exc})") from None
    except Exception as exc:
        if type(exc).__name__ == "TOMLDecodeError":
            raise ValueError(f"{path}: not valid TOML ({exc})") from None
        raise
    data = data.get("atmosphere", data) if isinstance(data, dict) else data
    return atmosphere_from_dict(data)

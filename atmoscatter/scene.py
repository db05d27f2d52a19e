"""Scenes: what the user asks for — its fields, their validation, and loading from files.

Public objects
--------------
:class:`Scene`
    Frozen dataclass describing one sky: where and when (or a sun direction),
    which model, the atmosphere and turbidity, the observer altitude, spectral
    sampling, output geometry, resolution, colourspace and tone options.
:func:`load_scene`, :meth:`Scene.from_dict`, :meth:`Scene.replace_from_strings`
    Build scenes from TOML/JSON files, dictionaries and ``key=value`` strings
    (the CLI's ``--set``, batch CSV cells), with one clear error per bad field.
:func:`as_scene`, :func:`parse_time`, :func:`is_atmosphere_file`
    A scene from what a caller passes; the scene's time; whether an ``atmosphere``
    value names a file.

What the renderer does with a scene — the minimal work it needs — is decided by
:func:`atmoscatter.render.plan.plan` (:mod:`atmoscatter.render.plan`).

Units and frames: angles in the scene are in degrees with explicit names
(``sun_elevation_deg``, ``sun_azimuth_deg`` measured from north toward east),
latitude/longitude in degrees (east-positive), altitude in metres above the
ground, time in ISO 8601 (a time without a zone is UTC).  The array API
(:meth:`Scene.sun_direction`) uses the local frame x = east, y = north, z = up.
"""

from __future__ import annotations

import dataclasses
import datetime as _dt
import json
import math
import os
import typing
from dataclasses import dataclass, fields

import numpy as np

from ._scene_checks import (  # noqa: F401  (re-exported)
    ATMOSPHERES,
    GROUND_OBSERVER_ALTITUDE,
    MAX_ORDERS,
    OUTPUTS,
    PRECISIONS,
    PROJECTIONS,
    SAMPLINGS,
    SYMMETRY,
    TONES,
    _coerce_fields,
    _validate,
    is_atmosphere_file,
    parse_time,
)
from .sun import sun_position

__all__ = [
    "Scene",
    "load_scene",
    "PROJECTIONS",
    "OUTPUTS",
    "parse_time",
    "is_atmosphere_file",
    "as_scene",
]



@dataclass(frozen=True)
class Scene:
    """One sky to render.

    Every field has a default: ``Scene()`` is the documented default scene —
    a clear sky (Preetham, turbidity 2.5) seen from the Royal Observatory,
    Greenwich (51.4779° N, 0.0015° W) on 2024-06-21 at 09:00 UTC, as a
    1024 × 512 lat-long map.

    Parameters
    ----------
    name : str
        File stem used by batch runs and recorded in metadata.
    model : str
        Sky model, one of :data:`atmoscatter.render.models.MODELS` (``preetham``,
        ``cie_overcast``, ``cie_clear``, ``hoffman_preetham``,
        ``single_scattering``, ``multiple_scattering`` as they are available).
    turbidity : float
        Linke-type turbidity ``T = (τ_m + τ_h)/τ_m`` [1], ≥ 1 (1 = no haze).
    sun_elevation_deg, sun_azimuth_deg : float or None
        Sun direction [deg]; azimuth from north toward east.  When given they
        override the position computed from ``time``/``latitude``/``longitude``.
        If only the elevation is given the azimuth defaults to 180° (south).
    latitude, longitude : float
        Observer site [deg], east-positive longitude.
    time : str
        ISO 8601 date-time (UTC when no zone is given).  Sets the sun position
        (unless the sun angles are given) and the Earth–Sun distance.
    altitude : float
        Observer altitude above the ground [m].
    atmosphere : str
        Atmosphere of the physical models: a preset, one of ``earth``,
        ``earth_no_ozone``, ``mars``, ``keller_bohn``, or the path of a custom
        atmosphere file (``.toml``/``.json``, format of
        :func:`atmoscatter.atmosphere_from_dict`; a relative path in a scene file
        is relative to that file).
    ground_albedo : float
        Lambertian ground albedo in [0, 1]: used by multiple scattering and for
        the documented ground value below a ground observer's horizon.
    orders : int or None
        Scattering orders of ``multiple_scattering`` in [1, 1000] (1 = single
        scattering; ``None`` = that function's default).
    ms_grid : str or None
        Field grid of ``multiple_scattering``, a key of
        :data:`atmoscatter.MULTIPLE_SCATTERING_GRIDS`: ``default`` (``None`` means this)
        and ``accurate`` centre their solar-zenith nodes on the scene's sun (one field per
        sun; ``accurate`` is finer, for about twice the first call); ``table`` covers every
        sun with one field per atmosphere (for animations and batches over many suns,
        less accurate per sky).  The measured figures per regime are in
        ``docs/convergence.md``; the EXR header quotes the measured error of the grid
        used.  Any other model with a grid set is an error.
    sampling : str
        ``rgb`` (the atmosphere's three sample wavelengths 680/550/440 nm),
        ``spectral`` (380–780 nm every ``wavelength_step`` nm) or ``auto``
        (default: the plan chooses spectral sampling for the physical models
        when the sun is below the elevation where three wavelengths stop being
        enough, with the step measured for it — see :func:`~atmoscatter.render.plan.plan` and
        ``docs/numerical_scattering.md``; rgb otherwise and for the other models).
    wavelength_step : float
        Spectral step [nm] when ``sampling = "spectral"`` (and for
        ``output = "spectral"``); ``auto`` uses its measured step instead.
    output : str
        ``rgb``, ``xyz`` (XYZ and RGB), ``luminance`` (Y only) or ``spectral``.
    colourspace : str
        RGB colourspace name known to colour-science (default ``sRGB``, linear).
    projection : str
        ``latlong``, ``cubemap`` (``width`` = face size), ``fisheye`` (upper
        hemisphere, angular/equidistant) or ``dome`` (a sky-dome mesh).
    width, height : int
        Image size [pixels].  For ``dome``: azimuth segments and elevation rings.
        Each is at most 65536, and the estimated output arrays (float32 layers:
        e.g. 16 bytes per pixel for RGB) at most 4 GiB
        (:data:`atmoscatter._validate.MAX_OUTPUT_BYTES`, environment variable
        ``ATMOSCATTER_MAX_OUTPUT_GIB``), checked before anything is allocated.
    refinement : int
        Dome only: levels of adaptive subdivision around the sun (seed 002).
    precision : str
        EXR pixel type, ``half`` or ``float``.
    alpha : bool
        Write an alpha channel (1 = sky, 0 = ground or outside the map).
    sun_disc : bool
        Draw the sun disc (transmitted solar radiance, limb darkened).
    exposure : float or None
        Preview exposure [m² cd⁻¹]; ``None`` chooses one from the image.
    tone : str
        Preview tone curve: ``exponential`` (seed 002 ``1 − e^{−exposure·L}``),
        ``reinhard`` or ``clip`` (each RGB channel on its own), or ``luminance`` (the
        exponential curve of the luminance, chromaticity kept; see
        :func:`atmoscatter.preview.tone_map`).
    symmetry : str
        Mirror symmetry about the solar vertical: ``auto`` (use it where it
        saves work), ``on`` or ``off``.
    method : str or None
        Quadrature method of ``single_scattering`` (a key of
        :data:`atmoscatter.SINGLE_SCATTERING_METHODS`; ``None`` = its default); any
        other model with a method set is an error.
    gamut : str
        Out-of-gamut policy of the RGB output (colours with a negative channel in
        ``colourspace``; XYZ, luminance and spectral layers are never changed):
        ``map`` (default: desaturated toward the achromatic colour of the same luminance
        until the lowest channel is 0 — luminance Y and hue kept), ``clip`` (negative
        channels set to 0) or ``none`` (raw values, negative light included).  See
        :func:`atmoscatter.rgb_into_gamut`; the render's counts go into the EXR header.
    cie_type : int or None
        ``model = "cie_standard"`` only: CIE standard general sky type 1–15 (ISO 15469 /
        CIE S 011), scaled by ``zenith_luminance`` or ``diffuse_horizontal_illuminance``.
    zenith_luminance : float or None
        ``cie_standard``: zenith luminance ≥ 0 [cd m⁻²] (give this or the next).
    diffuse_horizontal_illuminance : float or None
        ``cie_standard``: diffuse horizontal illuminance ≥ 0 from the sky [lx].
    direct_normal_irradiance, diffuse_horizontal_irradiance : float or None
        ``model = "perez_all_weather"`` only (both required): measured direct normal and
        diffuse horizontal irradiance ≥ 0 [W m⁻²], as in a weather file.
    dew_point : float or None
        ``perez_all_weather``: surface dew point in [−100, 60] °C for the precipitable water
        of the luminous efficacy; ``None`` uses 2 cm of precipitable water.
    """

    name: str = "sky"
    model: str = "preetham"
    turbidity: float = 2.5
    sun_elevation_deg: float | None = None
    sun_azimuth_deg: float | None = None
    latitude: float = 51.4779
    longitude: float = -0.0015
    time: str = "2024-06-21T09:00:00Z"
    altitude: float = 0.0
    atmosphere: str = "earth"
    ground_albedo: float = 0.0
    orders: int | None = None
    ms_grid: str | None = None
    sampling: str = "auto"
    wavelength_step: float = 10.0
    output: str = "rgb"
    colourspace: str = "sRGB"
    projection: str = "latlong"
    width: int = 1024
    height: int = 512
    refinement: int = 2
    precision: str = "float"
    alpha: bool = False
    sun_disc: bool = False
    exposure: float | None = None
    tone: str = "exponential"
    symmetry: str = "auto"
    method: str | None = None
    gamut: str = "map"
    cie_type: int | None = None
    zenith_luminance: float | None = None
    diffuse_horizontal_illuminance: float | None = None
    direct_normal_irradiance: float | None = None
    diffuse_horizontal_irradiance: float | None = None
    dew_point: float | None = None

    # ------------------------------------------------------------------
    def __post_init__(self):
        _coerce_fields(self)
        _validate(self)

    # ------------------------------------------------------------------
    @classmethod
    def field_names(cls) -> tuple[str, ...]:
        """Names of all scene fields (the valid keys of files and ``--set``)."""
        return tuple(f.name for f in fields(cls))

    @classmethod
    def from_dict(cls, data: typing.Mapping, *, base: Scene | None = None) -> Scene:
        """Build a scene from a mapping (values may be strings, as in CSV).

        Unknown keys raise :class:`ValueError` listing the valid ones.  Empty
        strings leave the field at its default (or the value in ``base``).
        """
        names = cls.field_names()
        unknown = [k for k in data if k not in names]
        if unknown:
            raise ValueError(
                f"unknown scene field {unknown[0]!r}; valid fields are: {', '.join(names)}"
            )
        values = {}
        for k, v in data.items():
            if isinstance(v, str) and v.strip() == "":
                continue
            values[k] = v
        if base is None:
            return cls(**values)
        return dataclasses.replace(base, **values)

    def replace_from_strings(self, assignments) -> Scene:
        """Apply ``key=value`` strings (the CLI's ``--set``) and return a new scene."""
        return Scene.from_dict(_parse_assignments(assignments), base=self)

    def to_dict(self) -> dict:
        """The scene as a plain dictionary (``None`` kept)."""
        return {f.name: getattr(self, f.name) for f in fields(self)}

    def to_strings(self) -> dict[str, str]:
        """Every field as a string (for EXR header attributes); ``None`` → ``""``."""
        out = {}
        for k, v in self.to_dict().items():
            if v is None:
                out[k] = ""
            elif isinstance(v, bool):
                out[k] = "true" if v else "false"
            else:
                out[k] = str(v)
        return out

    # ------------------------------------------------------------------
    def datetime(self) -> _dt.datetime | None:
        """The scene time as an aware UTC :class:`datetime.datetime` (or None)."""
        return parse_time(self.time) if self.time else None

    def sun_angles(self) -> tuple[float, float, str]:
        """Sun (zenith, azimuth) [rad] and how they were obtained.

        Uses ``sun_elevation_deg``/``sun_azimuth_deg`` when given, otherwise
        :func:`atmoscatter.sun_position` (apparent position, with refraction)
        for ``time``, ``latitude`` and ``longitude``.
        """
        if self.sun_elevation_deg is not None:
            az = 180.0 if self.sun_azimuth_deg is None else self.sun_azimuth_deg
            return (
                math.radians(90.0 - self.sun_elevation_deg),
                math.radians(az % 360.0),
                "given (sun_elevation_deg, sun_azimuth_deg)",
            )
        t = np.datetime64(self.datetime().replace(tzinfo=None), "ns")
        pos = sun_position(t, self.latitude, self.longitude, elevation=0.0)
        zen = float(np.asarray(pos.zenith))
        azi = float(np.asarray(pos.azimuth)) % (2 * math.pi)
        return zen, azi, "sun_position(time, latitude, longitude)"

    def sun_direction(self) -> np.ndarray:
        """Unit vector toward the sun, local frame (x = east, y = north, z = up)."""
        zen, azi, _ = self.sun_angles()
        return np.array(
            [math.sin(zen) * math.sin(azi), math.sin(zen) * math.cos(azi), math.cos(zen)]
        )



def as_scene(scene) -> Scene:
    """A :class:`Scene` from a scene, a mapping of fields, a scene file path or None.

    ``None`` is the default scene, a mapping goes through :meth:`Scene.from_dict`, a
    ``str``/path-like through :func:`load_scene`.  Anything else raises :class:`TypeError`.

    Parameters
    ----------
    scene : Scene, mapping, str, path-like or None
        What to turn into a scene.

    Returns
    -------
    Scene
        ``scene`` itself if it is already a :class:`Scene`.
    """
    if scene is None:
        return Scene()
    if isinstance(scene, Scene):
        return scene
    if isinstance(scene, typing.Mapping):
        return Scene.from_dict(scene)
    if isinstance(scene, (str, os.PathLike)):
        return load_scene(scene)
    raise TypeError(f"scene must be a Scene, a dict of scene fields, a scene file path or None, "
                    f"got {type(scene).__name__}")




# ----------------------------------------------------------------------------
# loading
# ----------------------------------------------------------------------------
def _load_toml(path):
    try:
        import tomllib  # noqa: PLC0415
    except ModuleNotFoundError:  # pragma: no cover - Python 3.10
        import tomli as tomllib  # noqa: PLC0415
    with open(path, "rb") as fh:
        try:
            return tomllib.load(fh)
        except tomllib.TOMLDecodeError as exc:
            raise ValueError(f"{path}: not valid TOML: {exc}") from None
        except UnicodeDecodeError as exc:
            raise ValueError(f"{path}: not UTF-8 text ({exc.reason} at byte {exc.start})") from None


def _load_json(path):
    with open(path, encoding="utf-8-sig") as fh:
        try:
            return json.load(fh)
        except json.JSONDecodeError as exc:
            raise ValueError(f"{path}: not valid JSON: {exc}") from None
        except UnicodeDecodeError as exc:
            raise ValueError(f"{path}: not UTF-8 text ({exc.reason} at byte {exc.start})") from None


def _parse_assignments(assignments) -> dict:
    data = {}
    for item in assignments or ():
        if "=" not in item:
            raise ValueError(f"--set expects key=value, got {item!r}")
        key, value = item.split("=", 1)
        if not value.strip():
            raise ValueError(f"--set {item!r}: the value of {key.strip()!r} is empty; give a "
                             "value (optional fields also take 'none')")
        data[key.strip()] = value.strip()
    return data


def _read_scene_file(path) -> dict:
    path = os.fspath(path)
    if not os.path.exists(path):
        raise ValueError(f"scene file {path!r} does not exist")
    ext = os.path.splitext(path)[1].lower()
    if ext == ".toml":
        data = _load_toml(path)
    elif ext == ".json":
        data = _load_json(path)
    else:
        raise ValueError(f"scene file {path!r}: expected a .toml or .json file")
    if not isinstance(data, dict):
        raise ValueError(f"{path}: a scene file must hold a table/object of scene fields")
    if "scene" in data and isinstance(data["scene"], dict):
        data = data["scene"]
    return dict(data)


def load_scene(path: str | os.PathLike | None = None, *, overrides=None) -> Scene:
    """Load a scene from a TOML (``.toml``) or JSON (``.json``) file.

    The file holds the scene fields at top level or inside a ``[scene]`` table
    (TOML) / ``"scene"`` object (JSON).  ``overrides`` — a mapping or
    ``key=value`` strings (the CLI's ``--set``) — are applied on top; with
    ``path=None`` they apply to the defaults.  Unknown fields and invalid
    values raise :class:`ValueError` naming the file and the field.

    Parameters
    ----------
    path : str or path-like, optional
        Scene file (``.toml`` or ``.json``); None for the default scene.
    overrides : mapping or iterable of str, optional
        Field values (or ``"key=value"`` strings) applied on top of the file.

    Returns
    -------
    Scene
        The validated scene (angles in the file in degrees, as the field names say).
    """
    data = _read_scene_file(path) if path is not None else {}
    atm = data.get("atmosphere")
    if path is not None and isinstance(atm, str) and is_atmosphere_file(atm) and not os.path.isabs(atm):
        data["atmosphere"] = os.path.join(os.path.dirname(os.path.abspath(os.fspath(path))), atm)
    if overrides:
        if isinstance(overrides, dict):
            data.update(overrides)
        else:
            data.update(_parse_assignments(overrides))
    try:
        return Scene.from_dict(data)
    except ValueError as exc:
        if path is None:
            raise
        raise ValueError(f"{os.fspath(path)}: {exc}") from None

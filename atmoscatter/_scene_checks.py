"""Checks of a :class:`~atmoscatter.scene.Scene`: the option tuples of its fields, the
coercion of strings (``--set``, CSV cells) to field types, the validation of every field with
a one-line error naming the field, its value and the valid range, and the parsing of its time.

Private to :mod:`atmoscatter.scene`, which re-exports the public names.
"""

from __future__ import annotations

import datetime as _dt
import math
import os
import typing
from dataclasses import fields

import numpy as np

from .colour import GAMUT_POLICIES

if typing.TYPE_CHECKING:  # annotations only: scene.py imports this module
    from .scene import Scene

#: Output geometries (see :mod:`atmoscatter.render.directions`).
PROJECTIONS = ("latlong", "cubemap", "fisheye", "dome")
#: What is computed and written: linear RGB, CIE XYZ (+RGB), luminance Y only,
#: or spectral radiance (+RGB).
OUTPUTS = ("rgb", "xyz", "luminance", "spectral")
SAMPLINGS = ("auto", "rgb", "spectral")
PRECISIONS = ("half", "float")
TONES = ("exponential", "reinhard", "clip", "luminance")
SYMMETRY = ("auto", "on", "off")
ATMOSPHERES = ("earth", "earth_no_ozone", "mars", "keller_bohn")

#: Altitude [m] below which the observer counts as standing on the ground: the
#: view rays below the horizon then have zero length and are not integrated.
GROUND_OBSERVER_ALTITUDE = 1.0

#: Largest number of scattering orders a scene may ask for (each order is a full pass).
MAX_ORDERS = 1000



def _field_kind(f) -> tuple[type, bool]:
    """(base type, optional) of a dataclass field annotation string."""
    ann = f.type if isinstance(f.type, str) else getattr(f.type, "__name__", str(f.type))
    optional = "None" in ann
    base = ann.replace("| None", "").replace("None |", "").strip()
    return {"str": str, "float": float, "int": int, "bool": bool}[base], optional


_TRUE = {"1", "true", "yes", "on"}
_FALSE = {"0", "false", "no", "off"}


def _coerce(name, kind, optional, value):
    if value is None:
        if optional:
            return None
        raise ValueError(f"scene field {name} must not be empty")
    if isinstance(value, str) and optional and value.strip().lower() in ("", "none", "null"):
        return None
    try:
        if kind is bool:
            if isinstance(value, (bool, np.bool_)):
                return bool(value)
            if isinstance(value, str) and value.strip().lower() in _TRUE | _FALSE:
                return value.strip().lower() in _TRUE
            if isinstance(value, (int, np.integer)) and value in (0, 1):
                return bool(value)
            raise ValueError
        if kind is int:
            if isinstance(value, (bool, np.bool_)):
                raise ValueError
            fv = float(value)
            if not fv.is_integer():
                raise ValueError
            return int(fv)
        if kind is float:
            if isinstance(value, (bool, np.bool_)):
                raise ValueError
            return float(value)
        if kind is str:
            if isinstance(value, (_dt.datetime, _dt.date)):
                return value.isoformat()
            if not isinstance(value, str):
                raise ValueError
            return value
    except (TypeError, ValueError):
        expected = {bool: "true/false", int: "an integer", float: "a number", str: "a string"}
        raise ValueError(
            f"scene field {name} must be {expected[kind]}, got {value!r}"
        ) from None
    raise AssertionError(kind)  # pragma: no cover


def _coerce_fields(scene: Scene) -> None:
    for f in fields(scene):
        kind, optional = _field_kind(f)
        value = _coerce(f.name, kind, optional, getattr(scene, f.name))
        object.__setattr__(scene, f.name, value)


def _check(cond, msg):
    if not cond:
        raise ValueError(msg)


def _finite(scene, name):
    v = getattr(scene, name)
    _check(v is None or math.isfinite(v), f"scene field {name} must be finite, got {v!r}")


def _model_option(s: Scene, name: str, model: str, what: str, options) -> None:
    """Scene field ``name`` (``None``: unset) is valid only for ``model`` and one of
    ``options``."""
    v = getattr(s, name)
    if v is None:
        return
    _check(s.model == model,
           f"{name}={v!r} only applies to model={model!r} ({what}), not to model={s.model!r}")
    _check(v in options, f"{name}={v!r} is not valid; choose one of {sorted(options)}")


def _validate(s: Scene) -> None:
    from .render.models import MODELS  # noqa: PLC0415 - models import nothing from here

    for name in ("turbidity", "latitude", "longitude", "altitude", "ground_albedo",
                 "wavelength_step", "sun_elevation_deg", "sun_azimuth_deg", "exposure"):
        _finite(s, name)
    if s.model not in MODELS:
        raise ValueError(f"model={s.model!r} is not valid; choose one of {sorted(MODELS)}")
    _check(s.turbidity >= 1.0, f"turbidity must be in [1, inf) (1 = no haze), got {s.turbidity!r}")
    _check(-90.0 <= s.latitude <= 90.0, f"latitude must be in [-90, 90] deg, got {s.latitude!r}")
    _check(-360.0 <= s.longitude <= 360.0,
           f"longitude must be in [-360, 360] deg, got {s.longitude!r}")
    if s.sun_elevation_deg is not None:
        _check(-90.0 <= s.sun_elevation_deg <= 90.0,
               f"sun_elevation_deg must be in [-90, 90] deg, got {s.sun_elevation_deg!r}")
    if s.sun_azimuth_deg is not None:
        _check(s.sun_elevation_deg is not None,
               "sun_azimuth_deg was given without sun_elevation_deg; give both (or neither and a time)")
    if s.time:
        _check_time_range(parse_time(s.time))
    else:
        _check(s.sun_elevation_deg is not None,
               "the scene needs either a time (with latitude/longitude) or sun_elevation_deg")
    _check(s.altitude >= 0.0, f"altitude must be in [0, inf) m, got {s.altitude!r}")
    _check(0.0 <= s.ground_albedo <= 1.0, f"ground_albedo must be in [0, 1], got {s.ground_albedo!r}")
    if s.orders is not None:
        _check(1 <= s.orders <= MAX_ORDERS, f"orders must be in [1, {MAX_ORDERS}], got {s.orders!r}")
    # model-specific options: accepted only where they have an effect (the method used to
    # be ignored silently elsewhere)
    from .sky.multiple import MULTIPLE_SCATTERING_GRIDS  # noqa: PLC0415 - kernels load later
    from .sky.single import SINGLE_SCATTERING_METHODS  # noqa: PLC0415 - light module

    _model_option(s, "ms_grid", "multiple_scattering", "the grid of its radiance field",
                  MULTIPLE_SCATTERING_GRIDS)
    _model_option(s, "method", "single_scattering", "the quadrature of its view-path integral",
                  SINGLE_SCATTERING_METHODS)
    _validate_daylight(s)
    _check(1.0 <= s.wavelength_step <= 100.0,
           f"wavelength_step must be in [1, 100] nm, got {s.wavelength_step!r}")
    for name, options in (("projection", PROJECTIONS), ("output", OUTPUTS),
                          ("sampling", SAMPLINGS), ("precision", PRECISIONS), ("tone", TONES),
                          ("symmetry", SYMMETRY), ("gamut", GAMUT_POLICIES)):
        v = getattr(s, name)
        _check(v in options, f"{name}={v!r} is not valid; choose one of {sorted(options)}")
    if is_atmosphere_file(s.atmosphere):
        _check(os.path.isfile(s.atmosphere),
               f"atmosphere file {s.atmosphere!r} does not exist")
    else:
        _check(s.atmosphere in ATMOSPHERES,
               f"atmosphere={s.atmosphere!r} is not valid; choose one of {sorted(ATMOSPHERES)} "
               "or give a .toml/.json atmosphere file")
    _check(1 <= s.width <= 65536, f"width must be in [1, 65536] pixels, got {s.width!r}")
    _check(1 <= s.height <= 65536, f"height must be in [1, 65536] pixels, got {s.height!r}")
    if s.projection == "dome":
        _check(s.width >= 3 and s.height >= 1,
               f"dome needs width >= 3 azimuth segments and height >= 1 rings, got {s.width}x{s.height}")
    _check(0 <= s.refinement <= 8, f"refinement must be in [0, 8], got {s.refinement!r}")
    _check_size(s)
    if s.exposure is not None:
        _check(s.exposure > 0, f"exposure must be in (0, inf) m^2/cd, got {s.exposure!r}")
    from .colour import _resolve_colourspace  # noqa: PLC0415  (shipped table: no colour-science)

    if _resolve_colourspace(s.colourspace) is None:
        raise ValueError(
            f"colourspace={s.colourspace!r} is not valid; choose an RGB colourspace known "
            "to colour-science, e.g. 'sRGB', 'ITU-R BT.2020', 'ACEScg'"
        )


#: Scene fields of the daylighting models, and the model each belongs to.
DAYLIGHT_FIELDS = {
    "cie_type": "cie_standard",
    "zenith_luminance": "cie_standard",
    "diffuse_horizontal_illuminance": "cie_standard",
    "direct_normal_irradiance": "perez_all_weather",
    "diffuse_horizontal_irradiance": "perez_all_weather",
    "dew_point": "perez_all_weather",
}


def _validate_daylight(s: Scene) -> None:
    """Fields of ``cie_standard`` / ``perez_all_weather``: present where needed, nowhere else."""
    for name, model in DAYLIGHT_FIELDS.items():
        v = getattr(s, name)
        if v is None:
            continue
        _check(s.model == model, f"{name}={v!r} only applies to model={model!r}, not to "
               f"model={s.model!r}")
        _check(math.isfinite(v), f"scene field {name} must be finite, got {v!r}")
    if s.model == "cie_standard":
        _check(s.cie_type is not None, "model='cie_standard' needs cie_type (an integer 1-15)")
        _check(1 <= s.cie_type <= 15, f"cie_type must be in [1, 15], got {s.cie_type!r}")
        given = [n for n in ("zenith_luminance", "diffuse_horizontal_illuminance")
                 if getattr(s, n) is not None]
        _check(len(given) == 1, "model='cie_standard' needs exactly one of zenith_luminance "
               f"[cd m^-2] and diffuse_horizontal_illuminance [lx], got {given or 'neither'}")
        _check(getattr(s, given[0]) >= 0,
               f"{given[0]} must be in [0, inf), got {getattr(s, given[0])!r}")
    if s.model == "perez_all_weather":
        for name in ("direct_normal_irradiance", "diffuse_horizontal_irradiance"):
            v = getattr(s, name)
            _check(v is not None, f"model='perez_all_weather' needs {name} [W m^-2]")
            _check(v >= 0, f"{name} must be in [0, inf) W m^-2, got {v!r}")
        _check(s.direct_normal_irradiance <= 1500.0, "direct_normal_irradiance must be in "
               f"[0, 1500] W m^-2, got {s.direct_normal_irradiance!r}")
        if s.dew_point is not None:
            _check(-100.0 <= s.dew_point <= 60.0,
                   f"dew_point must be in [-100, 60] degC, got {s.dew_point!r}")


def _check_size(s: Scene) -> None:
    """Refuse images whose output arrays would not fit (see :data:`MAX_OUTPUT_BYTES`)."""
    from ._validate import check_image_size  # noqa: PLC0415

    per = {"rgb": 4, "xyz": 7, "luminance": 2}.get(s.output)
    if per is None:  # spectral: RGB + alpha + one layer per wavelength of 380-780 nm
        per = 4 + int(400.0 / s.wavelength_step) + 1
    check_image_size(s.projection, s.width, s.height, per)


def _check_time_range(t: _dt.datetime) -> None:
    from .sun import SPA_YEARS  # noqa: PLC0415

    _check(SPA_YEARS[0] <= t.year <= SPA_YEARS[1],
           f"time must be within the years {SPA_YEARS[0]}..{SPA_YEARS[1]} (validity of the "
           f"solar position algorithm), got {t.isoformat()!r}")



# ----------------------------------------------------------------------------
# time and Earth–Sun distance
# ----------------------------------------------------------------------------
def parse_time(value: str) -> _dt.datetime:
    """Parse an ISO 8601 date-time; a time without a zone is taken as UTC.

    Returns an aware :class:`datetime.datetime` in UTC.  ``Z`` is accepted as
    the UTC designator.  Raises :class:`ValueError` naming the value.

    Parameters
    ----------
    value : str
        ISO 8601 date-time, e.g. ``"2024-06-21T09:00:00Z"``.

    Returns
    -------
    datetime.datetime
        Timezone-aware, in UTC.
    """
    if isinstance(value, _dt.datetime):
        t = value
    else:
        text = str(value).strip()
        if text.endswith(("Z", "z")):
            text = text[:-1] + "+00:00"
        try:
            t = _dt.datetime.fromisoformat(text)
        except ValueError:
            raise ValueError(
                f"time must be an ISO 8601 date-time such as 2024-06-21T09:00:00Z, got {value!r}"
            ) from None
    if t.tzinfo is None:
        t = t.replace(tzinfo=_dt.timezone.utc)
    return t.astimezone(_dt.timezone.utc)




def is_atmosphere_file(value) -> bool:
    """True if a scene's ``atmosphere`` value names a custom atmosphere file.

    Parameters
    ----------
    value : object
        The ``atmosphere`` field.

    Returns
    -------
    bool
        True for a string ending in ``.toml`` or ``.json`` (any case).
    """
    return isinstance(value, str) and value.lower().endswith((".toml", ".json"))

"""Density profiles: relative density against altitude, 1 at the reference altitude.

Public objects
--------------
- :class:`ExponentialProfile`: ``exp(−(h − h₀)/H)``, the usual model of air and aerosols.
- :class:`TabulatedProfile`: a table of densities, log-linear between the nodes (US Standard
  Atmosphere 1976).
- :class:`TentProfile`: the piecewise-linear ozone layer of Bruneton (2017).

Every profile is a frozen dataclass validated on construction, with ``density(altitude)``
(broadcasts), ``breakpoints`` (altitudes [m] where it is not smooth) and ``scale`` (the length
[m] over which it changes), which is all :func:`atmoscatter.optical_length` and the
integrators use.  The profiles sit below :mod:`atmoscatter.atmosphere` (a
:class:`~atmoscatter.Constituent` has one) and :mod:`atmoscatter.optical_length`, which both
import them from here; ``atmoscatter.atmosphere`` re-exports them.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ._validate import as_float_array, check_finite, check_positive

__all__ = [
    "ExponentialProfile",
    "TabulatedProfile",
    "TentProfile",
]


@dataclass(frozen=True)
class ExponentialProfile:
    """Exponential relative density ``ρ(h) = exp(−(h − h₀)/H)``.

    Parameters
    ----------
    scale_height : float
        Scale height ``H`` [m], > 0.  Earth: 8000 m (air), 1200 m (aerosols) — Bruneton
        (2017); seed 002 uses the same values.
    reference_altitude : float
        Altitude ``h₀`` [m] where the relative density is 1 (default 0, sea level).
    """

    scale_height: float
    reference_altitude: float = 0.0

    def __post_init__(self):
        check_positive(self.scale_height, "scale_height", unit="m")
        check_finite(self.reference_altitude, "reference_altitude")
        object.__setattr__(self, "scale_height", float(self.scale_height))
        object.__setattr__(self, "reference_altitude", float(self.reference_altitude))

    def density(self, altitude):
        """Relative density [-] at ``altitude`` [m] (broadcasts; any altitude is allowed)."""
        h = as_float_array(altitude, "altitude")
        # Clip the exponent: far below the reference altitude (inside a planet, never
        # sampled by the integrators) the density would overflow.
        x = np.minimum(-(h - self.reference_altitude) / self.scale_height, 700.0)
        return np.exp(x)

    @property
    def breakpoints(self) -> tuple[float, ...]:
        """Altitudes [m] where the profile is not smooth (none)."""
        return ()

    @property
    def scale(self) -> float:
        """Characteristic length [m] over which the density changes (the scale height)."""
        return self.scale_height


@dataclass(frozen=True)
class TabulatedProfile:
    """Relative density tabulated against altitude, interpolated log-linearly.

    Between nodes the density is exponential (linear in ``log ρ``), which is exact for an
    isothermal layer and is how the US Standard Atmosphere 1976 density is usually
    interpolated.  Below the first node the first layer's exponential is extended; above the
    last node the density is 0.  Zero densities are allowed (interpolated linearly).

    Parameters
    ----------
    altitudes : sequence of float
        Strictly increasing altitudes [m].
    densities : sequence of float
        Relative densities [-] (≥ 0) at those altitudes.
    """

    altitudes: tuple[float, ...]
    densities: tuple[float, ...]

    def __post_init__(self):
        alt = check_finite(self.altitudes, "altitudes").astype(float).ravel()
        den = check_positive(self.densities, "densities", allow_zero=True).astype(float).ravel()
        if alt.size < 2 or alt.size != den.size:
            raise ValueError(
                f"altitudes and densities must have the same length >= 2, got {alt.size} and {den.size}"
            )
        if np.any(np.diff(alt) <= 0):
            raise ValueError("altitudes must be strictly increasing")
        object.__setattr__(self, "altitudes", tuple(alt.tolist()))
        object.__setattr__(self, "densities", tuple(den.tolist()))

    def density(self, altitude):
        """Relative density [-] at ``altitude`` [m], log-linear between nodes."""
        h = as_float_array(altitude, "altitude")
        alt = np.asarray(self.altitudes)
        den = np.asarray(self.densities)
        positive = den > 0
        if np.all(positive):
            logd = np.log(den)
            # linear extrapolation of log ρ below the first node
            slope0 = (logd[1] - logd[0]) / (alt[1] - alt[0])
            out = np.exp(np.interp(h, alt, logd))
            below = h < alt[0]
            out = np.where(below, np.exp(np.minimum(logd[0] + slope0 * (h - alt[0]), 700.0)), out)
        else:
            out = np.interp(h, alt, den)
        return np.where(h > alt[-1], 0.0, out).astype(h.dtype if h.dtype.kind == "f" else float)

    @property
    def breakpoints(self) -> tuple[float, ...]:
        """The tabulation altitudes [m] (the profile's slope changes there)."""
        return self.altitudes

    @property
    def scale(self) -> float:
        """Smallest local scale height [m] of the table (for truncation and sampling)."""
        alt = np.asarray(self.altitudes)
        den = np.asarray(self.densities)
        ok = (den[1:] > 0) & (den[:-1] > 0)
        if not np.any(ok):
            return float(np.min(np.diff(alt)))
        dlog = np.abs(np.diff(np.log(np.where(den > 0, den, 1.0))))[ok]
        dz = np.diff(alt)[ok]
        with np.errstate(divide="ignore"):
            h = np.where(dlog > 0, dz / np.where(dlog > 0, dlog, 1.0), np.inf)
        return float(min(np.min(h), np.min(np.diff(alt)) * 10))


@dataclass(frozen=True)
class TentProfile:
    """Piecewise-linear "tent" density, 1 at ``center`` and 0 at ``center ± half_width``.

    The ozone layer model of Bruneton (2017): density rising linearly from 10 km to a peak at
    25 km and falling linearly to 0 at 40 km (``center=25e3, half_width=15e3``).

    Parameters
    ----------
    center : float
        Altitude of the peak [m].
    half_width : float
        Distance [m] from the peak to the altitudes where the density reaches 0, > 0.
    """

    center: float = 25e3
    half_width: float = 15e3

    def __post_init__(self):
        check_finite(self.center, "center")
        check_positive(self.half_width, "half_width", unit="m")
        object.__setattr__(self, "center", float(self.center))
        object.__setattr__(self, "half_width", float(self.half_width))

    def density(self, altitude):
        """Relative density [-] at ``altitude`` [m]."""
        h = as_float_array(altitude, "altitude")
        return np.maximum(1.0 - np.abs(h - self.center) / self.half_width, 0.0)

    @property
    def breakpoints(self) -> tuple[float, ...]:
        """Altitudes [m] of the kinks: the two feet and the peak."""
        return (self.center - self.half_width, self.center, self.center + self.half_width)

    @property
    def scale(self) -> float:
        """Characteristic length [m]: the half width."""
        return self.half_width

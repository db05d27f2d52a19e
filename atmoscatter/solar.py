"""Extraterrestrial solar spectral irradiance (package data).

Public objects
--------------
- :func:`extraterrestrial_irradiance`: ASTM G-173 ETR spectrum [W m⁻² nm⁻¹], optionally
  scaled to an Earth–Sun distance.
- :data:`SOLAR_CONSTANT`: the integral of the shipped ETR spectrum [W m⁻²].
- :data:`SUN_ANGULAR_RADIUS`: mean angular radius of the solar disc [rad].

The data file ``atmoscatter/data/astm_g173_etr.csv`` is the ETR column of ASTM G173-03
(NREL, derived from SMARTS 2.9.2), 280–4000 nm; its header states source and licence.
"""

from __future__ import annotations

from functools import lru_cache
from importlib import resources

import numpy as np

from ._validate import as_float_array, check_positive

__all__ = [
    "extraterrestrial_irradiance",
    "solar_spectrum_table",
    "SOLAR_CONSTANT",
    "SUN_ANGULAR_RADIUS",
]

#: Mean angular radius of the Sun seen from 1 AU [rad] (959.63 arcsec; IAU 2015 nominal
#: solar radius 695 700 km over 1 AU = 149 597 870.7 km).
SUN_ANGULAR_RADIUS: float = 695700.0 / 149597870.7


@lru_cache(maxsize=1)
def solar_spectrum_table() -> tuple[np.ndarray, np.ndarray]:
    """The shipped ASTM G-173 ETR table: ``(wavelength [nm], irradiance [W m⁻² nm⁻¹])``.

    Returns
    -------
    wavelength : ndarray
        Wavelengths [nm] (read-only).
    irradiance : ndarray
        Extraterrestrial spectral irradiance at 1 AU [W m⁻² nm⁻¹] (read-only).
    """
    path = resources.files("atmoscatter") / "data" / "astm_g173_etr.csv"
    data = np.loadtxt(str(path), delimiter=",", comments="#")
    wl, e = data[:, 0], data[:, 1]
    wl.setflags(write=False)
    e.setflags(write=False)
    return wl, e


def extraterrestrial_irradiance(wavelength, *, distance_au=1.0):
    """Extraterrestrial solar spectral irradiance [W m⁻² nm⁻¹].

    Parameters
    ----------
    wavelength : array_like
        Wavelength [nm], 280–4000 (ValueError outside the table).
    distance_au : array_like
        Earth–Sun distance [AU], > 0; the irradiance scales as ``1/d²``.  Broadcasts
        against ``wavelength`` (e.g. distances of shape (n, 1) against wavelengths (m,)).

    Returns
    -------
    ndarray or float
        Irradiance on a surface normal to the sun at the top of the atmosphere.

    Notes
    -----
    Linear interpolation of the ASTM G173-03 ETR column (tabulated every 0.5 nm from 280 to
    400 nm, every 1 nm to 1700 nm, then every 5 nm).  The table is a high-resolution
    spectrum with Fraunhofer lines; users who sample coarsely (e.g. three RGB wavelengths)
    may prefer a band average (``solar_spectrum_table`` gives the raw data).

    Examples
    --------
    >>> round(float(extraterrestrial_irradiance(550.0)), 3)
    1.863
    """
    lam = check_positive(as_float_array(wavelength, "wavelength"), "wavelength", unit="nm")
    wl, e = solar_spectrum_table()
    if np.any(lam < wl[0]) or np.any(lam > wl[-1]):
        bad = lam[(lam < wl[0]) | (lam > wl[-1])].flat[0]
        raise ValueError(f"wavelength must be in [{wl[0]}, {wl[-1]}] nm, got {bad!r}")
    d = check_positive(distance_au, "distance_au", unit="AU")
    return np.interp(lam, wl, e) / d**2


#: Integral of the shipped ETR spectrum over 280–4000 nm [W m⁻²] (≈1348; the total solar
#: irradiance of 1361 W m⁻² includes the spectrum outside this range).
SOLAR_CONSTANT: float = float(np.trapezoid(solar_spectrum_table()[1], solar_spectrum_table()[0]))

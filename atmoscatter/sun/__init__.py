"""Sun position, sunrise/sunset/solar noon and the solar geometry the sky models need.

Public objects
--------------
- :func:`sun_position`: topocentric zenith and azimuth (true and refracted), unit direction
  vector, declination, equation of time and Earth–Sun distance, vectorised over times and sites.
  ``method="spa"`` (default) is the NREL Solar Position Algorithm (Reda & Andreas 2004);
  ``method="iqbal"`` is the seed 003 / Preetham 1999 formula (errata 003.1–2).
- :data:`SUN_POSITION_METHODS`: registry of the methods above.
- :class:`SunPosition`: the result of :func:`sun_position`.
- :func:`sunrise_sunset`: sunrise, sunset and solar noon (UTC ``datetime64``) per local date,
  with flags for polar day and polar night.
- :class:`SunriseSunset`: the result of :func:`sunrise_sunset`.
- :func:`earth_sun_distance`: Earth–Sun distance [AU] at given times.
- :func:`default_delta_t`: the default TT − UT [s] (Espenak & Meeus polynomials).
- :func:`sun_direction`: zenith/azimuth → unit vector in the local frame (x east, y north, z up).
- :func:`sky_sun`: a :class:`SunPosition` → :class:`SkySun`, what sky models consume
  (direction, zenith, azimuth, extraterrestrial irradiance scale).
- :data:`HORIZON_APPARENT`, :data:`TOTAL_SOLAR_IRRADIANCE`.

Times
-----
``numpy.datetime64`` values (and ISO-8601 strings without offset) are **UTC**. Timezone-aware
:class:`datetime.datetime` objects and pandas ``Timestamp``/``DatetimeIndex``/``Series`` are
converted to UTC. *Naive* ``datetime``/pandas objects raise ``ValueError`` — a naive Python
datetime is most often local time, and silently reading it as UTC is a classic bug; pass
``np.datetime64`` (UTC) or attach a timezone.

Layout
------
The modules, from low to high: each imports only from the ones above it.

- ``_common``: shared constants (2π, the degree, the block size), Horner's rule, numeric
  input checks.
- :mod:`~atmoscatter.sun.time`: times and dates → ``datetime64`` (UTC) → days since J2000.0;
  :data:`SPA_YEARS`.
- :mod:`~atmoscatter.sun.delta_t`: ΔT, the Espenak & Meeus (2006) polynomials
  (:func:`default_delta_t`).
- ``_spa_tables``: the SPA periodic terms (Reda & Andreas 2004, Tables A4.2–A4.3).
- ``spa``: the time-only SPA: heliocentric Earth, nutation, obliquity, aberration →
  apparent declination, hour-angle offset, distance, equation of time.
- ``nodes``: those terms by cubic interpolation between nodes every 2 days; the shipped
  node table ``atmoscatter/data/spa_nodes.npz`` and the per-process node cache.
- ``iqbal``: the time-only part of the seed 003 / Preetham / Iqbal formula.
- ``topocentric``: per-site geometry (parallax, refraction, local frame), in blocks.
- :mod:`~atmoscatter.sun.position`: :func:`sun_position`, :func:`earth_sun_distance`,
  :func:`sky_sun` and the result types.
- :mod:`~atmoscatter.sun.riseset`: :func:`sunrise_sunset`.

This package only re-exports the public names.  ``import atmoscatter.sun`` loads NumPy and
the standard library only (pandas only when a pandas object is passed).

References
----------
- I. Reda, A. Andreas (2004), "Solar position algorithm for solar radiation applications",
  Solar Energy 76, 577–589; NREL/TP-560-34302 (rev. 2008). Periodic terms: Tables A4.2–A4.3
  (shipped in :mod:`atmoscatter.sun._spa_tables`); worked example: Table A5.1–2.
- F. Espenak, J. Meeus (2006), *Five Millennium Canon of Solar Eclipses*, NASA/TP-2006-214141,
  "Polynomial expressions for Delta T" (also eclipse.gsfc.nasa.gov/SEcat5/deltatpoly.html).
- M. Iqbal (1983), *An Introduction to Solar Radiation*, Academic Press (Eq. 1.2.1, Spencer's
  Earth–Sun distance series); A. J. Preetham, P. Shirley, B. Smits (1999), "A practical
  analytic model for daylight", SIGGRAPH, Appendix A.6; seed 003 (Kolivand & Sunar), Sec. 3.
- J. Meeus (1998), *Astronomical Algorithms*, 2nd ed., Ch. 15 (rising, transit, setting).
"""


from .delta_t import default_delta_t
from .position import (
    SUN_POSITION_METHODS,
    TOTAL_SOLAR_IRRADIANCE,
    SkySun,
    SunPosition,
    earth_sun_distance,
    sky_sun,
    sun_direction,
    sun_position,
)
from .riseset import HORIZON_APPARENT, SunriseSunset, sunrise_sunset
from .time import SPA_YEARS

__all__ = [
    "HORIZON_APPARENT",
    "TOTAL_SOLAR_IRRADIANCE",
    "SUN_POSITION_METHODS",
    "SunPosition",
    "SunriseSunset",
    "SkySun",
    "sun_position",
    "sunrise_sunset",
    "earth_sun_distance",
    "default_delta_t",
    "sun_direction",
    "sky_sun",
    "SPA_YEARS",
]

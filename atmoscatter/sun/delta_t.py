"""ΔT = TT − UT [s]: the Espenak & Meeus (2006) polynomials.

The SPA needs Terrestrial Time for the ephemeris (the Earth's orbit, nutation) and Universal
Time for the Earth's rotation; their difference ΔT grows irregularly with the slowing of the
rotation and is only known from observation.  :func:`default_delta_t` evaluates the piecewise
polynomials of F. Espenak and J. Meeus, *Five Millennium Canon of Solar Eclipses*
(NASA/TP-2006-214141), "Polynomial expressions for Delta T", at the decimal year
``y = 2000 + d/365.25``, ``d`` in days since J2000.0: one polynomial in ``t = y − ref`` per
interval from 1800 to 2050 (``_DELTA_T_PIECES``), ``−20 + 32 u² − 0.5628 (2150 − y)`` for
2050–2150, and the long-term parabola ``−20 + 32 u²``, ``u = (y − 1820)/100``, outside.
Times are read as :func:`sun_position` reads them (UTC; see :mod:`atmoscatter.sun.time`).
"""

from __future__ import annotations

import numpy as np

from ._common import _horner
from .time import _as_datetime64, _days_since_j2000

__all__ = ["default_delta_t"]


#: Espenak & Meeus (2006) ΔT pieces: (start year, reference year, coefficients in t = y − ref).
_DELTA_T_PIECES = (
    (1800.0, 1800.0, (13.72, -0.332447, 0.0068612, 0.0041116, -0.00037436, 0.0000121272,
                      -0.0000001699, 0.000000000875)),
    (1860.0, 1860.0, (7.62, 0.5737, -0.251754, 0.01680668, -0.0004473624, 1.0 / 233174.0)),
    (1900.0, 1900.0, (-2.79, 1.494119, -0.0598939, 0.0061966, -0.000197)),
    (1920.0, 1920.0, (21.20, 0.84493, -0.076100, 0.0020936)),
    (1941.0, 1950.0, (29.07, 0.407, -1.0 / 233.0, 1.0 / 2547.0)),
    (1961.0, 1975.0, (45.45, 1.067, -1.0 / 260.0, -1.0 / 718.0)),
    (1986.0, 2000.0, (63.86, 0.3345, -0.060374, 0.0017275, 0.000651814, 0.00002373599)),
    (2005.0, 2000.0, (62.92, 0.32217, 0.005589)),
    (2050.0, None, None),  # −20 + 32 u² − 0.5628 (2150 − y)
    (2150.0, None, None),  # long-term parabola −20 + 32 u², u = (y − 1820)/100
)
_DELTA_T_EDGES = np.array([p[0] for p in _DELTA_T_PIECES])


def _delta_t_piece(k: int, y: np.ndarray) -> np.ndarray:
    u = (y - 1820.0) / 100.0
    if k == 0 or k == len(_DELTA_T_PIECES):  # before 1800 / from 2150: long-term parabola
        return -20.0 + 32.0 * u * u
    _, ref, coeffs = _DELTA_T_PIECES[k - 1]
    if coeffs is None:  # 2050–2150
        return -20.0 + 32.0 * u * u - 0.5628 * (2150.0 - y)
    return _horner(y - ref, coeffs)


def _delta_t_of_year(y: np.ndarray) -> np.ndarray:
    """Espenak & Meeus (2006) ΔT polynomials [s] for decimal year ``y`` (any year)."""
    y = np.asarray(y, dtype=np.float64)
    piece = np.searchsorted(_DELTA_T_EDGES, y, side="right")  # NaN → last piece (NaN out)
    present = np.unique(piece)
    if present.size == 1:
        return _delta_t_piece(int(present[0]), y)
    out = np.empty_like(y)
    for k in present:
        sel = piece == k
        out[sel] = _delta_t_piece(int(k), y[sel])
    return out


def default_delta_t(time):
    """Default ΔT = TT − UT [s] used by :func:`sun_position` when ``delta_t=None``.

    Parameters
    ----------
    time : datetime-like or array of them
        UTC times (see the module docstring for accepted types).

    Returns
    -------
    ndarray or float
        ΔT [s] from the Espenak & Meeus (2006) polynomials, evaluated at the decimal year
        ``2000 + (JD − 2451545)/365.25``.

    Notes
    -----
    The polynomials fit observed ΔT to about a second over 1900–2005.  Their 2005–2050 piece is
    an extrapolation published in 2006 that overestimates the observed ΔT (IERS) by about 2 s in
    2015 and 5 s in 2025.  ΔT only shifts the ephemeris time (Earth's rotation uses UT), so a
    ΔT error of 1 s moves the Sun by about 1.2e-5° (its orbital motion in 1 s; measured: 5 s →
    5.9e-5°).  Pass ``delta_t=`` explicitly (e.g. from IERS Bulletin A) for the best absolute
    accuracy.

    Examples
    --------
    >>> round(float(default_delta_t(np.datetime64("2000-01-01T12:00"))), 2)
    63.86
    """
    d = _days_since_j2000(_as_datetime64(time), "time")
    out = _delta_t_of_year(2000.0 + d / 365.25)
    return out[()] if out.ndim == 0 else out

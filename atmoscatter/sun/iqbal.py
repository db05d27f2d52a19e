"""The time-only part of the seed 003 / Preetham 1999 / Iqbal 1983 sun-position formula.

Seed 003 (Kolivand & Sunar) Sec. 3 with errata 003.1, the formula of Preetham, Shirley &
Smits (1999), Appendix A.6, for day of year ``J`` (UTC, so the standard meridian SM = 0):

- declination ``δ = 0.4093 sin(2π(J − 81)/368)``;
- equation of time ``0.170 sin(4π(J − 80)/373) − 0.129 sin(2π(J − 8)/355)`` [h];
- Earth–Sun distance from Spencer's (1971) series for ``E0 = (r0/r)²`` in Iqbal (1983)
  Eq. 1.2.1, day angle ``Γ = 2π(J − 1)/365``.

``_iqbal_columns`` returns the same columns as the SPA (:mod:`atmoscatter.sun.spa`) so
that :func:`sun_position` treats both methods alike (``method="iqbal"``).
"""

from __future__ import annotations

import numpy as np

from ._common import _TWO_PI

__all__: list[str] = []


def _day_of_year(t_us: np.ndarray) -> np.ndarray:
    """Day of year J = 1…366 (UTC) as float; NaT → NaN."""
    nat = np.isnat(t_us)
    days = t_us.astype("datetime64[D]")
    years = t_us.astype("datetime64[Y]").astype("datetime64[D]")
    j = (days - years).astype(np.float64) + 1.0
    return np.where(nat, np.nan, j)


def _iqbal_columns(d: np.ndarray, t_us: np.ndarray) -> dict[str, np.ndarray]:
    """Seed 003 Sec. 3 with errata 003.1 (SM = 0 because the input is UTC)."""
    j = _day_of_year(t_us)
    eot_h = 0.170 * np.sin(4.0 * np.pi * (j - 80.0) / 373.0) - 0.129 * np.sin(
        _TWO_PI * (j - 8.0) / 355.0
    )
    dec = 0.4093 * np.sin(_TWO_PI * (j - 81.0) / 368.0)
    # Spencer (1971) in Iqbal (1983) Eq. 1.2.1: E0 = (r0/r)², day angle Γ = 2π(J − 1)/365
    g = _TWO_PI * (j - 1.0) / 365.0
    e0 = (
        1.000110
        + 0.034221 * np.cos(g)
        + 0.001280 * np.sin(g)
        + 0.000719 * np.cos(2 * g)
        + 0.000077 * np.sin(2 * g)
    )
    # solar time t = UTC hours + EoT + 12 L/π  ⇒  hour angle H = π t/12 − π = 2π frac(d) + L − q
    return {
        "q": -eot_h * (np.pi / 12.0),
        "dec": dec,
        "sin_dec": np.sin(dec),
        "dist": 1.0 / np.sqrt(e0),
        "eot": 60.0 * eot_h,
    }

"""The time-only part of the NREL Solar Position Algorithm: Earth → geocentric apparent Sun.

Reda & Andreas (2004), "Solar position algorithm for solar radiation applications", Solar
Energy 76, 577–589 (NREL/TP-560-34302, rev. 2008).  For days ``d`` since J2000.0 (UT) and
ΔT [s], ``_spa_time_terms`` follows the paper's equations in order:

1. Julian ephemeris century/millennium ``JCE``, ``JME`` (Eq. 5–8).
2. Heliocentric longitude, latitude and radius ``L, B, R`` as the periodic series
   ``Σ_i JME^i Σ_k A cos(B + C·JME)`` of Tables A4.2 (Eq. 9–11; ``_earth_series``, terms in
   :mod:`atmoscatter.sun._spa_tables`).
3. Geocentric longitude and latitude (Eq. 13–14).
4. Nutation Δψ, Δε from the five fundamental arguments and the 63 terms of Table A4.3
   (Eq. 15–23; ``_nutation``).
5. True obliquity (Eq. 24–25), aberration and apparent longitude (Eq. 26–27), geocentric
   right ascension and declination (Eq. 30–31).
6. The slow part ``q`` of the local hour angle (Eq. 28–29, 32: ``H = 2π frac(d) + σ − q``),
   and the equation of time (Eq. A.1–A.2).

It returns the columns ``_COLUMNS = (q, dec, sin_dec, dist, eot)``, which depend on the time
only and are shared by every site.  ``_spa_direct`` evaluates them at every element;
``_earth_series_runs`` and ``_nutation_runs`` evaluate them on runs of ``_RUN`` equally spaced
nodes with one complex rotation per term (the fast path of :mod:`atmoscatter.sun.nodes`).
The per-site part (parallax, refraction) is in :mod:`atmoscatter.sun.topocentric`.
"""

from __future__ import annotations

import numpy as np

from . import _spa_tables as _tab
from ._common import _DEG, _TWO_PI, _horner

__all__: list[str] = []


def _table(rows) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    a = np.asarray(rows, dtype=np.float64)
    return a[:, 0], a[:, 1], a[:, 2]


_L = [_table(getattr(_tab, f"L{i}")) for i in range(6)]
_B = [_table(getattr(_tab, f"B{i}")) for i in range(2)]
_R = [_table(getattr(_tab, f"R{i}")) for i in range(5)]
_NUT_ARGS_INT = np.asarray(_tab.NUTATION_ARGS, dtype=np.int64)
_NUT_COEFFS = np.asarray(_tab.NUTATION_COEFFS, dtype=np.float64)  # (63, 4) in 1e-4 arcsec
_NUT_PSI = np.ascontiguousarray(_NUT_COEFFS[:, :2].T)  # (2, 63): a, b
_NUT_EPS = np.ascontiguousarray(_NUT_COEFFS[:, 2:].T)  # (2, 63): c, d


def _earth_series(series, jme: np.ndarray) -> np.ndarray:
    """Σ_i JME^i Σ_k A cos(B + C·JME) (Reda & Andreas Eq. 9–10), divided by 1e8."""
    total = np.zeros_like(jme)
    for a, b, c in reversed(series):  # Horner in JME (x**p is slow for negative x)
        term = np.cos(b[:, None] + c[:, None] * jme[None, :])
        # einsum, not a BLAS gemv: gemv goes multithreaded at this size and stalls under load
        total = total * jme + np.einsum("k,kn->n", a, term)
    return total * 1e-8


#: Nodes per run for :func:`_earth_series_runs`.
_RUN = 32
_ROTATIONS: dict[tuple[int, float], list] = {}


def _earth_series_runs(series, jme: np.ndarray, step: float) -> np.ndarray:
    """:func:`_earth_series` for runs of ``_RUN`` nodes nominally ``step`` [millennia] apart.

    Within a run starting at JME₀, ``e^{i(B + C·JME_k)} = e^{i(B + C·JME₀)} · e^{iC·k·step} ·
    e^{iC·ε_k}`` with ``ε_k = JME_k − JME₀ − k·step`` (the change of ΔT along the run,
    |C·ε| < 1e-6, kept to first order: error < 1e-12).  The sum over terms then becomes a
    complex matrix product, so a run costs one cos/sin per term instead of ``_RUN``.
    """
    n_runs = jme.size // _RUN
    runs = jme.reshape(n_runs, _RUN)
    start = runs[:, 0]
    eps = runs - start[:, None] - np.arange(_RUN) * step
    key = (id(series), float(step))
    if key not in _ROTATIONS:
        k = np.arange(_RUN) * step
        _ROTATIONS[key] = [np.exp(1j * c[:, None] * k[None, :]) for _, _, c in series]
        if len(_ROTATIONS) > 8:  # pragma: no cover - only a few steps are ever used
            _ROTATIONS.pop(next(iter(_ROTATIONS)))
    rot = _ROTATIONS[key]
    total = np.zeros_like(runs)
    for power in range(len(series) - 1, -1, -1):  # Horner in JME (x**p is slow for x < 0)
        a, b, c = series[power]
        e0 = np.exp(1j * (b[:, None] + c[:, None] * start[None, :]))  # (terms, n_runs)
        s_cos = (a[:, None] * e0).T @ rot[power]  # Σ A e^{i·angle}: real part = Σ A cos
        s_sin = ((a * c)[:, None] * e0).T @ rot[power]  # imaginary part = Σ A C sin
        total = total * runs + (s_cos.real - eps * s_sin.imag)
    return total.ravel() * 1e-8


def _nutation_args(jce: np.ndarray) -> np.ndarray:
    """Fundamental arguments D, M, M′, F, Ω [deg] (Reda & Andreas Eq. 15–19), shape (5, n)."""
    return np.stack([_horner(jce, coeffs) for coeffs in _NUT_POLYS])


_NUT_POLYS = (
    (297.85036, 445267.111480, -0.0019142, 1.0 / 189474.0),
    (357.52772, 35999.050340, -0.0001603, -1.0 / 300000.0),
    (134.96298, 477198.867398, 0.0086972, 1.0 / 56250.0),
    (93.27191, 483202.017538, -0.0036825, 1.0 / 327270.0),
    (125.04452, -1934.136261, 0.0020708, 1.0 / 450000.0),
)

#: Linear rates of the fundamental arguments [deg per Julian century].
_NUT_RATES = np.array([445267.111480, 35999.050340, 477198.867398, 483202.017538, -1934.136261])


def _nutation(jce: np.ndarray):
    """Δψ, Δε [0.0001″] (Eq. 20–22) at every ``jce``.

    ``e^{i·arg_k} = Π_j (e^{i X_j})^{Y_kj}``: 5 sin/cos pairs and complex products instead of
    63 sin/cos pairs (same values to ~1e-15).
    """
    z = np.exp(1j * (_nutation_args(jce) * _DEG))  # (5, n)
    z2 = z * z
    zc = np.conj(z)
    powers = np.stack([np.conj(z2), zc, np.ones_like(z), z, z2, z2 * z])  # Y = −2 … 3
    rot = powers[_NUT_ARGS_INT[:, 0] + 2, 0]
    for j in range(1, 5):
        rot = rot * powers[_NUT_ARGS_INT[:, j] + 2, j]
    # real matrix products on the real/imaginary parts: a complex matrix-vector product with a
    # real vector goes through a multithreaded zgemv that stalls badly on a busy machine
    sums_psi = _NUT_PSI @ rot.imag  # (2, n): Σ a sin, Σ b sin
    sums_eps = _NUT_EPS @ rot.real  # (2, n): Σ c cos, Σ d cos
    return sums_psi[0] + jce * sums_psi[1], sums_eps[0] + jce * sums_eps[1]


_NUT_ROTATIONS: dict[float, np.ndarray] = {}


def _nutation_runs(jce: np.ndarray, step: float):
    """:func:`_nutation` for runs of ``_RUN`` times nominally ``step`` [centuries] apart.

    Each term's phase advances by its linear rate × ``step`` from one node to the next, so a run
    is its start phasors times a fixed rotation: one complex matrix product per block.  Left
    out: the quadratic/cubic parts of the arguments and the change of ΔT within a run (phase
    < 1e-5 rad, i.e. < 1e-6″ in Δψ/Δε; tested against :func:`_nutation`).
    """
    n_runs = jce.size // _RUN
    runs = jce.reshape(n_runs, _RUN)
    key = float(step)
    if key not in _NUT_ROTATIONS:
        rate = (_NUT_ARGS_INT @ _NUT_RATES) * _DEG  # (63,) [rad per century]
        _NUT_ROTATIONS.clear()
        _NUT_ROTATIONS[key] = np.exp(1j * rate[:, None] * (np.arange(_RUN) * step)[None, :])
    rot = _NUT_ROTATIONS[key]  # (63, RUN)
    start = np.exp(1j * ((_NUT_ARGS_INT @ _nutation_args(runs[:, 0])) * _DEG))  # (63, n_runs)
    # one product per coefficient column: (n_runs × 63)·(63 × RUN) stays below OpenBLAS's
    # threading threshold (a threaded zgemm stalls badly on a busy machine)
    sums = [(w[None, :] * start.T) @ rot for w in _NUT_COEFFS.T]  # 4 × (n_runs, RUN)
    dpsi = sums[0].imag + runs * sums[1].imag
    deps = sums[2].real + runs * sums[3].real
    return dpsi.ravel(), deps.ravel()


def _spa_time_terms(d: np.ndarray, dt_s: np.ndarray, *, run_step=None) -> dict[str, np.ndarray]:
    """Time-only SPA quantities for 1-D float ``d`` (days since J2000 UT, finite).

    Returns a dict of 1-D arrays: ``q`` [rad] such that the geocentric local hour angle is
    ``H = 2π·frac(d) + longitude − q``; ``dec`` (geocentric apparent declination) [rad],
    ``sin_dec``; ``dist`` [AU]; ``eot`` (equation of time) [min].  With ``run_step`` [days],
    ``d`` is made of runs of ``_RUN`` times that far apart (see :func:`_earth_series_runs`).
    """
    jc = d / 36525.0
    jde = d + dt_s / 86400.0
    jce = jde / 36525.0
    jme = jce / 10.0
    # heliocentric longitude, latitude, radius (Eq. 9–11) [rad, rad, AU]
    if run_step is None:
        lon_h = _earth_series(_L, jme)
        lat_h = _earth_series(_B, jme)
        radius = _earth_series(_R, jme)
    else:
        step = run_step / 365250.0
        lon_h = _earth_series_runs(_L, jme, step)
        lat_h = _earth_series_runs(_B, jme, step)
        radius = _earth_series_runs(_R, jme, step)
    # geocentric (Eq. 13–14)
    theta = lon_h + np.pi
    beta = -lat_h
    # nutation (Eq. 15–23)
    if run_step is None:
        dpsi, deps = _nutation(jce)
    else:
        dpsi, deps = _nutation_runs(jce, run_step / 36525.0)
    dpsi = dpsi * (_DEG / 36e6)  # 0.0001″ → rad
    deps = deps * (_DEG / 36e6)
    # obliquity (Eq. 24–25)
    u = jme / 10.0
    eps0 = _horner(
        u, (84381.448, -4680.93, -1.55, 1999.25, -51.38, -249.67, -39.05, 7.12, 27.87, 5.79, 2.45)
    )
    eps = eps0 * (_DEG / 3600.0) + deps
    # aberration and apparent longitude (Eq. 26–27)
    lam = theta + dpsi - (20.4898 / 3600.0) * _DEG / radius
    # geocentric right ascension and declination (Eq. 30–31)
    sl, ce, se = np.sin(lam), np.cos(eps), np.sin(eps)
    alpha = np.arctan2(sl * ce - np.tan(beta) * se, np.cos(lam))
    sin_dec = np.sin(beta) * ce + np.cos(beta) * se * sl
    dec = np.arcsin(sin_dec)
    # hour-angle offset: ν = 280.46061837 + 360.98564736629 d + 0.000387933 T² − T³/38710000
    # (+ Δψ cos ε); 360·d ≡ 360·frac(d), so H = 2π frac(d) + σ − q with the slow part q:
    gm_slow = 280.46061837 + 0.98564736629 * d + jc * jc * (0.000387933 - jc / 38710000.0)
    q = alpha - dpsi * ce - gm_slow * _DEG
    q = (q + np.pi) % _TWO_PI - np.pi
    # equation of time (Eq. A.1–A.2) [min]
    m = _horner(
        jme, (280.4664567, 360007.6982779, 0.03032028, 1 / 49931.0, -1 / 15300.0, -1 / 2.0e6)
    )
    e_deg = (m - 0.0057183 - alpha / _DEG + dpsi * ce / _DEG + 180.0) % 360.0 - 180.0
    return {"q": q, "dec": dec, "sin_dec": sin_dec, "dist": radius, "eot": 4.0 * e_deg}


_COLUMNS = ("q", "dec", "sin_dec", "dist", "eot")


def _spa_direct(d: np.ndarray, dt_s: np.ndarray) -> dict[str, np.ndarray]:
    """Full SPA time terms at every element (NaN-safe, any shape), in blocks."""
    shape = d.shape
    d = d.ravel()
    dt_s = np.broadcast_to(dt_s, shape).ravel()
    ok = np.isfinite(d) & np.isfinite(dt_s)
    out = {k: np.full(d.shape, np.nan) for k in _COLUMNS}
    idx = np.flatnonzero(ok)
    step = 512  # (terms × block) temporaries stay in cache
    for s in range(0, idx.size, step):
        sel = idx[s : s + step]
        res = _spa_time_terms(d[sel], dt_s[sel])
        for k in _COLUMNS:
            out[k][sel] = res[k]
    return {k: v.reshape(shape) for k, v in out.items()}

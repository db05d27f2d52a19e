"""Published plane-parallel benchmarks for :func:`atmoscatter.multiple_scattering` (issue 10).

Reference values: the "correct answers" of the DISORT test suite, file ``DISOTEST.f``
v2.1 (K. Stamnes, S.-C. Tsay, W. Wiscombe, I. Laszlo; RCS header ``DISOTEST.f,v 2.1
2000/04/03``), ``BLOCK DATA CHEKDO`` — "Correct answers to test problems (as produced by
DISORT running entirely in double precision (14 significant digits))" — in the copy
``prowe12/rundisort:rundisort/code.f`` (commit de75b97), lines 1919–2038:

* Test problem 1, isotropic scattering (checked there against van de Hulst 1980, Table 12),
  ``UMU0 = 0.1``, ``FBEAM = π/UMU0``; cases 1A (τ = 0.03125, ω = 0.2), 1B (τ = 0.03125,
  ω = 1), 1D (τ = 32, ω = 0.2).  Lines 1919–1967.
* Test problem 2, **scalar** Rayleigh scattering, beam source (checked against Sweigart
  1970, ApJS 22, 1, Table 1), ``UMU0 = 0.080442`` (sun 4.6° above the horizon),
  ``FBEAM = π``; cases 2A–2D: τ = 0.2 / 5.0, ω = 0.5 / 1.0.  Lines 1980–2016.
  ``GETMOM(2, …)`` sets the Legendre moment ``PMOM(2) = 0.1``, i.e. the scalar phase
  function ``3/4 (1 + cos²Θ)`` — the same problem atmoscatter solves.
* Test problem 3, Henyey–Greenstein g = 0.75, ω = 1 (checked against van de Hulst 1980,
  Table 37), ``UMU0 = 1``, ``FBEAM = π``; cases 3A (τ = 1) and 3B (τ = 8).  Lines 2021–2038.

All with a black (``ALBEDO = 0``) Lambertian ground and output azimuth ``PHI = PHI0 = 0``.
Intensities ``UU`` are at the user polar cosines ``UMU`` and optical depths ``UTAU = 0``
(top) and ``UTAU = τ`` (bottom); they are diffuse (direct beam excluded) and per beam flux
``FBEAM`` (normal to the beam), so ``UU / FBEAM`` is atmoscatter's radiance per unit
extraterrestrial irradiance [sr⁻¹].

Geometry mapping (DISORT → atmoscatter).  ``UMU`` is the cosine of the polar angle of the
*propagation* direction, > 0 upward.  Upwelling intensity at the top (``UMU > 0``,
``UTAU = 0``) is what an observer at the top of the layer sees looking *down* with view
zenith cosine ``−UMU``; downwelling intensity at the bottom (``UMU < 0``, ``UTAU = τ``) is
what an observer on the ground sees looking *up*, view zenith cosine ``−UMU``.  The beam
propagates toward azimuth ``PHI0``, so the sun is at ``PHI0 + 180°``, and radiance
propagating toward ``PHI`` is seen looking toward ``PHI + 180°``: the view azimuth relative
to the sun's azimuth is ``PHI − PHI0`` (0 here: views in the sun's vertical, on the sun's
side).  Check: the scattering angle is then ``cos Θ = −UMU·UMU0 + sin θ sin θ0 cos(PHI−PHI0)``
for both (the DISORT definition), and :func:`test_single_scattering_matches_the_slab_formula`
verifies the whole mapping against the exact plane-parallel single-scattering formula.

Plane-parallel slab.  A homogeneous layer of height ``H = 10 km`` (a ``TabulatedProfile``
of constant density 1 on [0, H], zero above — ``optical_length`` integrates it exactly) on a
planet of radius ``1e12 m``.  The slant path through a shell differs from ``H/μ`` by the
factor ``1 − H/(2Rμ²) + …``: at the most grazing direction used (μ = 0.018014) that is
1.5e-5, measured in :func:`test_slab_is_plane_parallel` — negligible against the 0.5 %
tolerance even for the τ/μ ≈ 11 path of case 2A/2B.

Tolerances (issue 10): Rayleigh ≤ 0.5 % of the total radiance; Henyey–Greenstein and
isotropic ≤ 1 % of the total and ≤ 3 % of the multiple-scattering part (total − orders=1;
orders=1 is verified exact against the slab formula).  The DISORT answers are quoted to 6
significant digits (rounding 5e-6 relative), far inside these tolerances.

What is *not* here, and why.  Coulson, Dave & Sekera (1960) / Natraj, Li & Yung (2009,
ApJ 691, 1909) tabulate the *vector* (polarised) Rayleigh problem; the scalar intensity
differs from the vector one by several per cent (this error is the subject of Mishchenko,
Lacis & Travis 1994, JQSRT 51, 491), with a sign and size that depend on τ, μ, μ0 and φ,
and no published table found gives the scalar values at their nodes — so those tables
cannot check a scalar code to 0.5 % and are not used.  A published scalar case with a
reflecting ground was not found either: the DISOTEST problems with stored answers and
``ALBEDO > 0`` (6, 7D, 9C) are non-scattering or include thermal emission; the albedo
coupling is checked by the Monte Carlo tests instead (``tests/test_montecarlo.py``).
"""

from __future__ import annotations

import numpy as np
import pytest

import atmoscatter as ac

R_PP = 1.0e12  # [m] planet radius: curvature negligible (see module docstring)
H_PP = 1.0e4  # [m] slab thickness


def _slab(tau, omega, phase):
    ext = tau / H_PP
    prof = ac.TabulatedProfile((0.0, H_PP), (1.0, 1.0))
    return ac.Atmosphere(R_PP, R_PP + H_PP, (550.0,), (
        ac.Constituent("slab", omega * ext, (1.0 - omega) * ext, prof, phase),))


def _dir(mu, phi_deg):
    s = np.sqrt(max(1.0 - mu * mu, 0.0))
    p = np.radians(phi_deg)
    return np.array([s * np.cos(p), s * np.sin(p), mu])


def _sun(umu0):
    return _dir(umu0, 0.0)


def _view(umu, dphi_deg=0.0):
    """View direction that sees DISORT's intensity propagating along (UMU, PHI−PHI0)."""
    return _dir(-umu, dphi_deg)


# (case id, regime, tau, omega, phase, UMU0, FBEAM, UMU list, UU at top (UTAU=0) for
#  UMU>0, UU at bottom (UTAU=tau) for UMU<0)  -- DISOTEST.f v2.1, BLOCK DATA CHEKDO
_UMU2 = (-0.981986, -0.538263, -0.018014, 0.018014, 0.538263, 0.981986)
_UMU13 = (-1.0, -0.5, -0.1, 0.1, 0.5, 1.0)
_CASES = {
    # line 1923-1925: Test Case 1A
    "1A": ("isotropic, tau=0.03125, w=0.2, mu0=0.1", 0.03125, 0.2, "iso", 0.1, np.pi / 0.1, _UMU13,
           (1.17771e-01, 2.64170e-02, 1.34041e-02), (1.33826e-02, 2.63324e-02, 1.15898e-01)),
    # line 1933-1935: Test Case 1B
    "1B": ("isotropic, tau=0.03125, w=1, mu0=0.1", 0.03125, 1.0, "iso", 0.1, np.pi / 0.1, _UMU13,
           (6.22884e-01, 1.39763e-01, 7.09192e-02), (7.08109e-02, 1.39337e-01, 6.13458e-01)),
    # line 1953-1955: Test Case 1D (bottom values ~1e-15: transmitted light below rounding)
    "1D": ("isotropic, tau=32, w=0.2, mu0=0.1 (reflection only)", 32.0, 0.2, "iso", 0.1,
           np.pi / 0.1, _UMU13, (2.62972e-01, 9.06967e-02, 5.02853e-02), None),
    # line 1984-1986: Test Case 2A
    "2A": ("Rayleigh, tau=0.2, w=0.5, sun 4.6 deg", 0.2, 0.5, "rayleigh", 0.080442, np.pi, _UMU2,
           (1.61796e-01, 2.11501e-02, 7.86713e-03), (7.71897e-03, 2.00778e-02, 2.57685e-02)),
    # line 1994-1996: Test Case 2B
    "2B": ("Rayleigh, tau=0.2, w=1, sun 4.6 deg", 0.2, 1.0, "rayleigh", 0.080442, np.pi, _UMU2,
           (3.47678e-01, 4.87120e-02, 1.89387e-02), (1.86027e-02, 4.64061e-02, 6.77603e-02)),
    # line 2004-2006: Test Case 2C
    "2C": ("Rayleigh, tau=5, w=0.5, sun 4.6 deg", 5.0, 0.5, "rayleigh", 0.080442, np.pi, _UMU2,
           (1.62566e-01, 2.45786e-02, 1.01498e-02), (1.70004e-04, 3.97168e-05, 1.32472e-05)),
    # line 2014-2016: Test Case 2D
    "2D": ("Rayleigh, tau=5, w=1, sun 4.6 deg (thick, conservative)", 5.0, 1.0, "rayleigh",
           0.080442, np.pi, _UMU2,
           (3.64010e-01, 8.26993e-02, 4.92370e-02), (1.05950e-02, 7.69337e-03, 3.79276e-03)),
    # line 2025-2027: Test Case 3A
    "3A": ("HG g=0.75, tau=1, w=1, sun at zenith", 1.0, 1.0, "hg", 1.0, np.pi, _UMU13,
           (1.51159e-01, 1.01103e-01, 3.95460e-02), (3.05855e+00, 2.66648e-01, 2.13750e-01)),
    # line 2035-2037: Test Case 3B
    "3B": ("HG g=0.75, tau=8, w=1, sun at zenith (thick)", 8.0, 1.0, "hg", 1.0, np.pi, _UMU13,
           (3.79740e-01, 5.19598e-01, 4.93302e-01), (6.69581e-01, 4.22350e-01, 2.36362e-01)),
}
# 2D (Rayleigh, tau=5, w=1): a conservative thick layer, many orders, ~2.5 min on 2 cores;
# its regime is covered in CI by 2C (the same layer with w=0.5) and 2B (w=1, tau=0.2)
_SLOW = {"2D"}
# 1D, 3A: ~10-30 s; 3B (HG, tau=8, w=1): ~2.5 min, kept in CI as the one thick
# Henyey-Greenstein case (3A is the known deviation, xfail): CI's extended step
_EXTENDED = {"1D", "3A", "3B"}


def _phase(kind):
    return {"iso": ac.IsotropicPhase(), "rayleigh": ac.RayleighPhase(),
            "hg": ac.HenyeyGreensteinPhase(0.75)}[kind]


def _phase_value(kind, c):
    """Normalised phase function [sr⁻¹], written out here (not the package's)."""
    if kind == "iso":
        return np.full_like(c, 1.0 / (4 * np.pi))
    if kind == "rayleigh":
        return 3.0 / (16 * np.pi) * (1.0 + c * c)
    g = 0.75
    return (1 - g * g) / (4 * np.pi * (1 + g * g - 2 * g * c) ** 1.5)


def _points(case):
    """Views, altitudes and reference radiances [sr⁻¹] of one case (top and bottom)."""
    _, tau, omega, kind, umu0, fbeam, umu, top, bottom = _CASES[case]
    out = []
    ups = [u for u in umu if u > 0]
    downs = [u for u in umu if u < 0]
    for u, val in zip(ups, top, strict=True):
        out.append((H_PP, _view(u), val / fbeam, u))
    if bottom is not None:
        for u, val in zip(downs, bottom, strict=True):
            out.append((0.0, _view(u), val / fbeam, u))
    return out


def _single_slab(tau, omega, kind, umu0, umu):
    """Exact plane-parallel single scattering per unit irradiance [sr⁻¹] (diffuse, μ≠μ0)."""
    mu = abs(umu)
    c = -umu * umu0 + np.sqrt(1 - umu * umu) * np.sqrt(1 - umu0 * umu0)  # PHI−PHI0 = 0
    p = _phase_value(kind, np.asarray(c))
    if umu > 0:  # up at the top: ∫0^τ e^{−t/μ0} e^{−t/μ} dt/μ
        b = 1 / umu0 + 1 / mu
        return omega * p * (-np.expm1(-tau * b)) / (b * mu)
    a = 1 / umu0 - 1 / mu  # down at the bottom: e^{−τ/μ} ∫0^τ e^{−t(1/μ0−1/μ)} dt/μ
    if abs(a) < 1e-12:
        return omega * p * tau * np.exp(-tau / mu) / mu
    return omega * p * np.exp(-tau / mu) * (-np.expm1(-tau * a)) / (a * mu)


def test_slab_is_plane_parallel():
    """Curvature of the 1e12 m planet: slant optical paths equal H/μ within 2e-5."""
    prof = ac.TabulatedProfile((0.0, H_PP), (1.0, 1.0))
    mus = np.array([0.018014, 0.080442, 0.1, 0.5, 1.0])
    up = ac.optical_length(prof, 0.0, mus, planet_radius=R_PP, top_radius=R_PP + H_PP)
    down = ac.optical_length(prof, H_PP, -mus, planet_radius=R_PP, top_radius=R_PP + H_PP)
    for length in (up, down):
        np.testing.assert_allclose(length * mus / H_PP, 1.0, rtol=2e-5)


@pytest.mark.parametrize("case", list(_CASES))
def test_single_scattering_matches_the_slab_formula(case):
    """orders=1 against the closed-form slab single scattering: validates the geometry map.

    Independent check (formula written here, and confirmed to 2e-7 by brute-force
    quadrature with ``ac.optical_length`` while writing this test).  Tolerance 1e-3: the
    stated accuracy of the default single-scattering method (``single_scattering`` docs).
    """
    _, tau, omega, kind, umu0, _, umu, _, _ = _CASES[case]
    atm = _slab(tau, omega, _phase(kind))
    for alt, v, _, u in _points(case):
        if abs(abs(u) - umu0) < 1e-9:
            continue  # the view along the beam: ours excludes nothing there, skip
        ours = ac.multiple_scattering(atm, v, _sun(umu0), altitude=alt, orders=1)[0]
        ref = _single_slab(tau, omega, kind, umu0, u)
        assert ours == pytest.approx(ref, rel=1e-3, abs=1e-12), (case, alt, u)


def _tol(kind):
    # issue 10: Rayleigh 0.5 % of the total; HG (and isotropic) 1 % of the total, 3 % of MS
    return (0.005, None) if kind == "rayleigh" else (0.01, 0.03)


def _benchmark(case):
    label, tau, omega, kind, umu0, _, _, _, _ = _CASES[case]
    atm = _slab(tau, omega, _phase(kind))
    tol_total, tol_ms = _tol(kind)
    rows = []
    for alt, v, ref, u in _points(case):
        total = float(ac.multiple_scattering(atm, v, _sun(umu0), altitude=alt)[0])
        single = float(ac.multiple_scattering(atm, v, _sun(umu0), altitude=alt, orders=1)[0])
        rows.append((alt, u, ref, total, single))
    return label, tol_total, tol_ms, rows


def benchmark_table(cases=None):
    """(case, regime, level, UMU, reference, ours, ratio) rows for scripts/ms_reference_check.py."""
    out = []
    for case in cases or _CASES:
        label, _, _, rows = _benchmark(case)
        for alt, u, ref, total, _ in rows:
            out.append((f"DISORT {case}", label, "top" if alt > 0 else "bottom", u, ref, total,
                        total / ref))
    return out


@pytest.mark.parametrize(
    "case",
    [pytest.param(c, id=f"{c}: {_CASES[c][0]}",
                  marks=[pytest.mark.slow] if c in _SLOW
                  else [pytest.mark.extended] if c in _EXTENDED else []) for c in _CASES],
)
def test_disort_benchmark(case):
    """Total radiance (orders=None) against the DISOTEST.f correct answers, top and bottom.

    Each failing point is listed with ratio ours/reference; the multiple-scattering part
    (reference − orders=1) is checked too where the requirement states one.  Points in
    ``_KNOWN_DEVIATIONS`` are known to miss the requirement (measured, stated there and in
    the docs): the test then xfails naming them, and fails if such a point starts to pass
    (so the list cannot go stale) or if any other point fails.
    """
    label, tol_total, tol_ms, rows = _benchmark(case)
    bad, known_bad = [], []
    for alt, u, ref, total, single in rows:
        err = abs(total - ref)
        lim = tol_total * ref
        ms_ref = ref - single
        if tol_ms is not None and ms_ref > 0:
            lim = min(lim, tol_ms * ms_ref)
        key = (case, "top" if alt > 0 else "bottom", u)
        msg = (f"{key[1]} UMU={u:+.6f}: ours/ref={total / ref:.4f} (allowed ±{lim / ref:.4f}), "
               f"MS part ours/ref={(total - single) / ms_ref if ms_ref > 0 else np.nan:.4f}")
        if err > lim:
            (known_bad if key in _KNOWN_DEVIATIONS else bad).append(msg)
        elif key in _KNOWN_DEVIATIONS:
            bad.append(f"{msg} now passes: remove it from _KNOWN_DEVIATIONS")
    assert not bad, f"DISORT case {case} ({label}):\n" + "\n".join(bad)
    if known_bad:
        pytest.xfail("known deviation (issue 10): " + "; ".join(known_bad))


#: (case, level, UMU) points known to miss the requirement with the default grid, and why
_KNOWN_DEVIATIONS = {
    # HG g = 0.75, τ = 1, sun at the zenith, looking straight down at the top: the
    # multiple-scattering part is low by 1.1 % of the total (1.5 % before the altitude
    # refinement of the source table), above the 1 % asked; not removed by finer
    # altitude, μ, φ or panel-order grids (docs/convergence.md) — open.
    ("3A", "top", 1.0),
}

"""Numerical single scattering on a spherical planet (Nishita 1993, seeds 002 and 004).

Public objects
--------------
single_scattering
    Radiance per unit extraterrestrial solar irradiance [sr⁻¹] scattered once into
    arbitrary view directions, for an observer anywhere (ground, inside, top, space).
SINGLE_SCATTERING_METHODS
    Registry of the quadrature methods (drives validation and the docs).
DEFAULT_SINGLE_SCATTERING_METHOD, DEFAULT_SINGLE_SCATTERING_SAMPLES, TABLE_THRESHOLD
    The default method, its sample count (chosen from the convergence study in
    ``docs/convergence.md``) and the batch size from which the default may use the
    symmetric table path.
TABLE_FLOOR
    Brightness floor (relative to the sky maximum) of the table path's 1e-3 claim.
ConvergenceWarning
    Emitted when ``method="reference"`` cannot reach the requested ``rtol``.

The integral (seed 004, ``I¹(ω)``; seed 002 Eq. 5.1 with Eq. 5.3 for the in-scattering)
for a view ray from the observer P to the end S of its path inside the atmosphere is

.. math::

    I^1 = \\int_P^S \\Big[\\sum_i \\beta_{s,i}\\, \\rho_i(h(x))\\, p_i(\\theta)\\Big]
          \\, e^{-\\tau(P, x)}\\, e^{-\\tau(x, \\text{sun})}\\, V(x)\\, dx,
    \\qquad \\tau = \\sum_j \\beta_{e,j} \\int \\rho_j\\, dl

with ``V(x) = 0`` where the planet hides the sun.  The result is per unit
extraterrestrial solar irradiance; multiply by ``E_sun(λ)`` [W m⁻² nm⁻¹] for radiance
[W m⁻² sr⁻¹ nm⁻¹].

References
----------
* Keller, C., Bohn, C.-A. A GPU-based real time method for simulating atmospheric light
  scattering (seed 002), §5–6.
* Preetham, A. J. Modeling skylight and aerial perspective, SIGGRAPH 2003 course (seed 004).
* Nishita, T. et al. Display of the Earth taking into account atmospheric scattering,
  SIGGRAPH 1993.
* Bruneton, E. A qualitative and quantitative evaluation of 8 clear sky models, IEEE TVCG
  2017 (numerical guards, Earth constants).
"""

from __future__ import annotations

import warnings

import numpy as np

from .._validate import as_float_array, check_option, check_positive, check_range
from . import _quadrature as qd
from ._single_rules import _KERNELS, _evaluate_J, _graded, _graded_cost, _radiance_from_J
from ._single_table import TABLE_FLOOR, _table_radiance

__all__ = [
    "single_scattering",
    "SINGLE_SCATTERING_METHODS",
    "DEFAULT_SINGLE_SCATTERING_METHOD",
    "DEFAULT_SINGLE_SCATTERING_SAMPLES",
    "TABLE_THRESHOLD",
    "TWILIGHT_TABLE_THRESHOLD",
    "TABLE_FLOOR",
    "ConvergenceWarning",
]


class ConvergenceWarning(UserWarning):
    """A reference computation stopped before reaching its requested tolerance."""


DEFAULT_SINGLE_SCATTERING_METHOD: str = "graded"
"""Default method of :func:`single_scattering` (see ``docs/convergence.md``).  With
``method=None`` large batches (≥ :data:`TABLE_THRESHOLD` directions) seen by an observer
inside the atmosphere with no profile breakpoint (e.g. the ozone layer's lower edge)
below the observer use ``"table"`` instead: a self-checked log-space table whose cells
that fail the check (and their neighbours) are integrated directly, so a direction's
radiance agrees with the small-batch result to 1e-3 for every value above
:data:`TABLE_FLOOR` of the sky maximum (tests over turbidity 1.5–10 and sun elevations
90° … −18°).  With the sun low (``sin(elevation) < √(1 − (R/r)²)``, the depression of
the observer's ground horizon: sun below the horizon for an observer on the ground) the
table has :data:`_TWILIGHT_PHI_NODES` azimuths and is used from
:data:`TWILIGHT_TABLE_THRESHOLD` directions (its build costs as much as 12 000–30 000
direct directions: measured at turbidity 2.5, 3 wavelengths, 3–15 s for the table against
0.1–1 ms per direct direction from sun −10° to −3°, the direct path dearest in civil
twilight; 2-core machine, 2026-12-02).  Elsewhere (breakpoints below the observer, observers in space) large
batches use ``"graded"`` like small ones."""

TABLE_THRESHOLD: int = 4096
"""Number of directions from which ``method=None`` may switch to the ``"table"`` path."""

TWILIGHT_TABLE_THRESHOLD: int = 32768
"""Number of directions from which ``method=None`` switches to the ``"table"`` path when
the sun is below the observer's ground horizon."""

DEFAULT_SINGLE_SCATTERING_SAMPLES: dict[str, int] = {
    "keller_bohn": 32,
    "midpoint": 32,
    "gauss_legendre": 32,
    "graded": 4,
    "table": 129,
}
"""Default ``samples`` per method.  For ``"graded"`` it is the Gauss–Legendre order per
panel; for the others the number of view-path (and optical-depth) samples."""

#: (panels per doubling, GL order) of the successive refinement levels of "reference"
_REFERENCE_LEVELS: tuple[tuple[int, int], ...] = (
    (1, 4),
    (1, 6),
    (1, 8),
    (2, 8),
    (2, 12),
    (3, 14),
    (4, 16),
    (6, 20),
)


SINGLE_SCATTERING_METHODS: dict[str, str] = {
    "keller_bohn": (
        "Seed 002 non-equidistant midpoint rule as published: view-path cells "
        "[(i/n)^3, ((i+1)/n)^3], optical-depth cells [(i/m)^2, ((i+1)/m)^2], nested."
    ),
    "midpoint": "Uniform midpoint rule on the view path and on each optical-depth path.",
    "gauss_legendre": "One n-point Gauss–Legendre rule on the view path and on each optical-depth path.",
    "graded": (
        "This package's method: composite Gauss–Legendre on panels that grow geometrically "
        "away from the ray's lowest point (first panel = local density scale), split at the "
        "planet's shadow and at profile breakpoints; cumulative view optical depth from the "
        "same nodes by spectral integration; sun optical depth by the same graded rule."
    ),
    "table": (
        "Observer inside the atmosphere only: 'graded' (order 4) on a uniform grid in a "
        "horizon-stretched asin(sqrt(mu - mu_horizon)) variable × relative azimuth "
        "(samples = nodes in that variable, default 129, × 17), bicubic interpolation of "
        "log J; every cell is checked at its centre against 'graded' and directions in "
        "cells that fail are integrated directly; exact phase functions per direction.  "
        "1e-3 above TABLE_FLOOR (1e-6) of the sky maximum where the default uses it."
    ),
    "reference": (
        "'graded' refined level by level (more panels, higher order) until successive levels "
        "agree to rtol for every direction and wavelength."
    ),
}
"""Registry of :func:`single_scattering` methods → one-line description."""


# ----------------------------------------------------------------------------------------
# input handling and the dispatcher
# ----------------------------------------------------------------------------------------
def _table_allowed(atm: qd.PreparedAtmosphere, alt: float, s: np.ndarray, n: int) -> bool:
    """Whether the default (``method=None``) uses the table for ``n`` directions seen from
    altitude ``alt`` [m] with the unit sun vector ``s`` (see
    :data:`DEFAULT_SINGLE_SCATTERING_METHOD`).  A renderer that evaluates one sky in many
    batches asks with its total count (the table is built once and shared by the batches)."""
    r0 = atm.planet_radius + alt
    if n < TABLE_THRESHOLD or r0 > atm.top_radius:
        return False
    # a profile breakpoint below the observer puts kinks into J(μ) (view rays whose
    # perigee crosses it); the polynomial table is then not accurate enough
    if any(np.any(b < alt) for b in atm.breakpoints):
        return False
    dip = np.sqrt(max(0.0, 1.0 - (atm.planet_radius / r0) ** 2))
    return bool(s[2] >= dip or n >= TWILIGHT_TABLE_THRESHOLD)


def _unit_vectors(value, name: str) -> tuple[np.ndarray, np.ndarray]:
    arr = as_float_array(value, name)
    if arr.ndim < 1 or arr.shape[-1] != 3:
        raise ValueError(f"{name} must have shape (..., 3), got shape {arr.shape}")
    a = arr.astype(float)  # the one copy of the input (normalised in place)
    norm = np.atleast_1d(np.sqrt(np.einsum("...i,...i->...", a, a)))
    finite = np.isfinite(norm)
    if np.any(finite & (norm == 0)):
        raise ValueError(f"{name} must be non-zero vectors (unit vectors are expected)")
    norm[~finite | (norm == 0)] = 1.0
    a /= norm.reshape(a.shape[:-1] + (1,))
    return a, finite.reshape(a.shape[:-1])


def _prepare_inputs(atmosphere, view_directions, sun_direction, altitude):
    atm = qd.prepare_atmosphere(atmosphere)
    v, finite = _unit_vectors(view_directions, "view_directions")
    s, sfin = _unit_vectors(sun_direction, "sun_direction")
    if s.shape != (3,):
        raise ValueError(f"sun_direction must have shape (3,), got shape {s.shape}")
    if not sfin:
        raise ValueError("sun_direction must be finite")
    alt = check_positive(altitude, "altitude", allow_zero=True, unit="m")
    if alt.ndim != 0:
        raise ValueError(f"altitude must be a scalar [m], got shape {alt.shape}")
    out_dtype = (
        np.float32
        if as_float_array(view_directions, "view_directions").dtype == np.float32
        else np.float64
    )
    return atm, v, finite, s, float(alt), out_dtype



def _reference(atm, r0, v, s, rtol):
    levels = _REFERENCE_LEVELS

    def run(level, idx):
        m, q = levels[level]
        J = _evaluate_J(atm, r0, v[idx], s, lambda b: _graded(b, q, m), _graded_cost(q, m))
        return _radiance_from_J(atm, J, v[idx], s)

    idx = np.arange(v.shape[0])
    prev = run(0, idx)
    result = prev.copy()
    for level in range(1, len(levels)):
        if idx.size == 0:
            break
        cur = run(level, idx)
        scale = np.maximum(np.abs(cur), 1e-300)
        ok = np.all(np.abs(cur - prev) <= rtol * scale, axis=-1)
        result[idx] = cur
        idx = idx[~ok]
        prev = cur[~ok]
    if idx.size:
        warnings.warn(
            f"single_scattering(method='reference'): {idx.size} direction(s) did not reach "
            f"rtol={rtol:g} after {len(levels)} refinement levels; returning the finest level",
            ConvergenceWarning,
            stacklevel=3,
        )
    return result


def _select_wavelengths(atmosphere, wavelengths):
    """The atmosphere restricted to ``wavelengths`` (each must be one of its own)."""
    import dataclasses

    own = np.asarray(atmosphere.wavelengths_array, dtype=float)
    want = np.atleast_1d(as_float_array(wavelengths, "wavelengths")).astype(float).ravel()
    idx = []
    for w in want:
        hit = np.nonzero(np.isclose(own, w, rtol=0.0, atol=1e-6))[0]
        if hit.size == 0:
            raise ValueError(
                f"wavelengths must be among the atmosphere's wavelengths {own.tolist()} nm "
                f"(build the atmosphere for others), got {w!r}"
            )
        idx.append(int(hit[0]))
    cons = tuple(
        dataclasses.replace(
            c,
            scattering=tuple(np.asarray(c.scattering_array)[idx].tolist()),
            absorption=tuple(np.asarray(c.absorption_array)[idx].tolist()),
        )
        for c in atmosphere.constituents
    )
    return dataclasses.replace(
        atmosphere, wavelengths=tuple(own[idx].tolist()), constituents=cons
    )


def single_scattering(
    atmosphere,
    view_directions,
    sun_direction,
    *,
    altitude=0.0,
    wavelengths=None,
    method: str | None = None,
    rtol: float | None = None,
    samples: int | None = None,
    optical_depth_samples: int | None = None,
    batch_size: int | None = None,
):
    """Singly scattered sky radiance per unit extraterrestrial solar irradiance [sr⁻¹].

    Integrates seed 004's ``I¹(ω)`` (seed 002 Eq. 5.1 with in-scattering Eq. 5.3,
    generalised to any number of constituents and phase functions) along each view ray
    inside the atmosphere of a spherical planet: sun transmittance × ``Σ_i β_s,i ρ_i(h)
    p_i(θ)`` × view transmittance, zero where the planet shadows the sun.

    Parameters
    ----------
    atmosphere : Atmosphere
        Planet, atmosphere top and constituents (coefficients [m⁻¹], profiles, phases).
    view_directions : array_like, shape (..., 3)
        Unit view directions in the observer's local frame (x east, y north, z up).
        Non-unit vectors are normalised; rows containing NaN give NaN.
    sun_direction : array_like, shape (3,)
        Unit vector toward the sun in the same frame (any elevation, also below the
        horizon for twilight).
    altitude : float
        Observer altitude above the surface [m], ≥ 0.  Above ``top_radius −
        planet_radius`` the observer is in space: rays missing the atmosphere give 0,
        others are integrated from where they enter.
    wavelengths : array_like, optional
        Subset of the atmosphere's wavelengths [nm] to compute (default: all of them,
        e.g. the RGB sample wavelengths of the presets).  Coefficients exist only at the
        atmosphere's own wavelengths; build the atmosphere for others.
    method : str, optional
        One of :data:`SINGLE_SCATTERING_METHODS`; ``None`` selects
        :data:`DEFAULT_SINGLE_SCATTERING_METHOD` with its default samples, measured to
        stay within 1e-3 maximum relative error on the canonical scenes of
        ``docs/convergence.md``.
    rtol : float, optional
        Relative tolerance of ``method="reference"`` (default 1e-6; 1e-8 is reachable
        for smooth atmospheres).  Ignored (must be ``None``) for the other methods.
    samples : int, optional
        Samples of the chosen method: view-path samples for ``"keller_bohn"``,
        ``"midpoint"`` and ``"gauss_legendre"``; Gauss–Legendre order per panel for
        ``"graded"``.
    optical_depth_samples : int, optional
        Samples of each optical-depth integral for the three nested methods (default:
        ``samples``).
    batch_size : int, optional
        Directions per batch (default: chosen so that peak memory stays ~100 MB).

    Returns
    -------
    ndarray, shape (..., n_wavelengths)
        Radiance per unit extraterrestrial irradiance [sr⁻¹], ≥ 0; float32 if
        ``view_directions`` is float32, else float64.

    Notes
    -----
    Rays that hit the planet stop at the ground (no ground reflection here; see
    :func:`atmoscatter.multiple_scattering`).  Refraction is ignored.  Accuracy: the
    default is within 1e-3 (measured max relative error; see ``docs/convergence.md``);
    ``"reference"`` converges to ``rtol``.
    """
    if wavelengths is not None:
        atmosphere = _select_wavelengths(atmosphere, wavelengths)
    auto = method is None
    if auto:
        method = DEFAULT_SINGLE_SCATTERING_METHOD
    check_option(method, "method", SINGLE_SCATTERING_METHODS)
    atm, v, finite, s, alt, out_dtype = _prepare_inputs(
        atmosphere, view_directions, sun_direction, altitude
    )
    lead = v.shape[:-1]
    vf = v.reshape(-1, 3)
    fin = finite.reshape(-1)
    if not np.all(fin):
        vf[~fin] = (0.0, 0.0, 1.0)  # placeholder, NaN is restored below
    r0 = atm.planet_radius + alt
    if auto and samples is None and _table_allowed(atm, alt, s, vf.shape[0]):
        method = "table"
    if method == "reference":
        tol = 1e-6 if rtol is None else float(check_range(rtol, "rtol", 1e-12, 0.1))
        out = _reference(atm, r0, vf, s, tol)
    else:
        if rtol is not None:
            raise ValueError(f"rtol is only used by method='reference', got rtol={rtol!r}")
        n = DEFAULT_SINGLE_SCATTERING_SAMPLES[method] if samples is None else samples
        n = int(check_range(n, "samples", 1, 4096))
        if method == "table":
            if r0 > atm.top_radius:
                raise ValueError(
                    "method='table' needs an observer inside the atmosphere "
                    f"(altitude <= {atm.top_radius - atm.planet_radius} m), got altitude={alt}"
                )
            out = _table_radiance(atmosphere, atm, r0, vf, s, n)
        elif method == "graded":
            J = _evaluate_J(atm, r0, vf, s, lambda b: _graded(b, n), _graded_cost(n), batch_size)
        else:
            m = n if optical_depth_samples is None else optical_depth_samples
            m = int(check_range(m, "optical_depth_samples", 1, 4096))
            kern = _KERNELS[method]
            J = _evaluate_J(
                atm, r0, vf, s, lambda b: kern(b, n, m), n * m * 2 + n, batch_size
            )
        if method != "table":
            out = _radiance_from_J(atm, J, vf, s)
    np.maximum(out, 0.0, out=out)
    if not np.all(fin):
        out[~fin] = np.nan
    return out.reshape(lead + (atm.n_wavelengths,)).astype(out_dtype, copy=False)

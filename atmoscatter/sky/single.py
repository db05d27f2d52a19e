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

import os
import threading
import warnings
from collections import OrderedDict
from concurrent.futures import ThreadPoolExecutor

import numpy as np

from .._validate import as_float_array, check_option, check_positive, check_range
from . import _quadrature as qd

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
:data:`TWILIGHT_TABLE_THRESHOLD` directions (its build costs as much as ~30 000 direct
directions).  Elsewhere (breakpoints below the observer, observers in space) large
batches use ``"graded"`` like small ones."""

TABLE_THRESHOLD: int = 4096
"""Number of directions from which ``method=None`` may switch to the ``"table"`` path."""

TWILIGHT_TABLE_THRESHOLD: int = 65536
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

_N_THREADS = max(1, min(4, os.cpu_count() or 1))

# budget of nested (view × sun) quadrature nodes per batch: bounds peak memory
_NODE_BUDGET = 3_000_000


# ----------------------------------------------------------------------------------------
# shared geometry of one batch
# ----------------------------------------------------------------------------------------
class _Batch:
    """Geometry shared by every method for a batch of view directions."""

    def __init__(self, atm: qd.PreparedAtmosphere, r0: float, v: np.ndarray, s: np.ndarray):
        self.atm = atm
        self.r0 = r0
        self.v = v
        self.s = s
        self.nu = np.clip(v @ s, -1.0, 1.0)
        self.p2, self.s0, self.sa, self.sb = qd.view_segments(
            r0, v, atm.planet_radius, atm.top_radius
        )
        zxs = np.array([-s[1], s[0], 0.0])
        vxs = np.cross(v, s)
        self._a = r0 * r0 * float(zxs @ zxs)
        self._b = r0 * (vxs @ zxs)
        self._c = np.einsum("ij,ij->i", vxs, vxs)

    def sun_geometry(self, sigma: np.ndarray):
        """Sun-ray impact parameter², perigee coordinate and lit mask at view nodes."""
        t = sigma - self.s0[:, None]
        sig_s = self.r0 * self.s[2] + t * self.nu[:, None]
        p2_s = self._a + 2.0 * t * self._b[:, None] + t * t * self._c[:, None]
        p2_s = np.maximum(p2_s, 0.0)
        R = self.atm.planet_radius
        lit = ~((sig_s < 0.0) & (p2_s < R * R))
        top = self.atm.top_radius
        # shadowed nodes: an empty sun path (never integrates inside the planet)
        p2_s = np.where(lit, p2_s, 0.0)
        sig_s = np.where(lit, sig_s, top)
        return p2_s, sig_s, lit

    def altitude(self, sigma: np.ndarray) -> np.ndarray:
        return np.sqrt(self.p2[:, None] + sigma * sigma) - self.atm.planet_radius


def _combine(atm, rho, weights, lview, lsun, lit):
    """``J_g = Σ_nodes w ρ_g T lit`` with ``T = exp(−Σ_j β_e,j (L_view + L_sun))``."""
    if not rho:  # no constituents: nothing scatters
        return np.zeros((0, weights.shape[0], atm.n_wavelengths))
    tau = np.zeros(weights.shape + (atm.n_wavelengths,))
    for g in range(len(rho)):
        tau += (lview[g] + lsun[g])[..., None] * atm.extinction[g]
    trans = np.exp(-tau) * lit[..., None]
    return np.stack(
        [np.einsum("nm,nmw->nw", weights * rho[g], trans) for g in range(len(rho))], axis=0
    )


# ----------------------------------------------------------------------------------------
# published rules: nested view / optical-depth quadrature
# ----------------------------------------------------------------------------------------
def _nested_rule(batch: _Batch, xv, wv, xo, wo) -> np.ndarray:
    atm = batch.atm
    length = (batch.sb - batch.sa)[:, None]
    sigma = batch.sa[:, None] + length * xv
    weights = length * wv
    h = batch.altitude(sigma)
    p2_s, sig_s, lit = batch.sun_geometry(sigma)
    hi_s = np.sqrt(np.maximum(atm.top_radius**2 - p2_s, 0.0))
    hi_s = np.maximum(hi_s, sig_s)
    p2v = np.broadcast_to(batch.p2[:, None], sigma.shape)
    sav = np.broadcast_to(batch.sa[:, None], sigma.shape)
    rho, lview, lsun = [], [], []
    for g in range(len(atm.profiles)):
        rho.append(atm.density(g, h))
        lview.append(qd.optical_length_rule(atm, g, p2v, sav, sigma, xo, wo))
        lsun.append(qd.optical_length_rule(atm, g, p2_s, sig_s, hi_s, xo, wo))
    return _combine(atm, rho, weights, lview, lsun, lit)


def _keller_bohn(batch: _Batch, samples: int, od_samples: int) -> np.ndarray:
    xv, wv = qd.power_midpoint_unit(samples, 3.0)
    xo, wo = qd.power_midpoint_unit(od_samples, 2.0)
    return _nested_rule(batch, xv, wv, xo, wo)


def _midpoint(batch: _Batch, samples: int, od_samples: int) -> np.ndarray:
    xv, wv = qd.power_midpoint_unit(samples, 1.0)
    xo, wo = qd.power_midpoint_unit(od_samples, 1.0)
    return _nested_rule(batch, xv, wv, xo, wo)


def _gauss_legendre(batch: _Batch, samples: int, od_samples: int) -> np.ndarray:
    xv, wv = qd.gauss_legendre_unit(samples)
    xo, wo = qd.gauss_legendre_unit(od_samples)
    return _nested_rule(batch, xv, wv, xo, wo)


# ----------------------------------------------------------------------------------------
# graded composite Gauss–Legendre (this package's method)
# ----------------------------------------------------------------------------------------
def _extinction_scale(atm: qd.PreparedAtmosphere, p2: np.ndarray, sigma: np.ndarray) -> np.ndarray:
    """``1 / max_λ β_e(h)`` [m] at perigee coordinate ``sigma`` (inf in vacuum)."""
    h = np.sqrt(p2 + sigma * sigma) - atm.planet_radius
    k = np.zeros(np.shape(sigma))
    for g in range(len(atm.profiles)):
        k = k + atm.density(g, h) * float(np.max(atm.extinction[g]))
    with np.errstate(divide="ignore"):
        return np.where(k > 0, 1.0 / np.where(k > 0, k, 1.0), np.inf)


def _graded_view_bounds(batch: _Batch, m: int) -> np.ndarray:
    """Panel boundaries along the view ray (perigee coordinates), sorted.

    Geometric gradings are merged: from the ray's lowest point (both ways), from the start
    of the path (the observer or the entry point), forward from the exit of the planet's
    shadow and backward from its entry.  Each starts with a panel no longer than the local
    density scale and the local extinction length ``1/β_e``.  Shadow edges, profile
    breakpoints and the optical-depth levels of the atmosphere are panel boundaries too.
    """
    atm = batch.atm
    sa, sb, p2 = batch.sa, batch.sb, batch.p2
    c = np.clip(0.0, sa, sb)
    hmin = float(np.min(atm.scales)) if atm.scales.size else atm.top_radius - atm.planet_radius
    lo_t, hi_t = qd.shadow_interval(batch.r0, batch.v, batch.s, atm.planet_radius)
    sh_lo = lo_t + batch.s0
    sh_hi = hi_t + batch.s0
    has_exit = np.isfinite(sh_hi) & (sh_hi > sa) & (sh_hi < sb) & (sh_lo < sh_hi)
    e = np.where(has_exit, sh_hi, sb)
    has_entry = np.isfinite(sh_lo) & (sh_lo > sa) & (sh_lo < sb) & (sh_lo < sh_hi)
    f = np.where(has_entry, sh_lo, sa)

    def scale(x):
        return np.minimum(qd.local_scale(hmin, x, p2), _extinction_scale(atm, p2, x))

    ell_c, ell_a, ell_e, ell_f = scale(c), scale(sa), scale(e), scale(f)
    ratios = [
        np.maximum(sb - c, c - sa) / ell_c,
        (sb - sa) / ell_a,
        (sb - e) / ell_e,
        (f - sa) / ell_f,
    ]
    span = max(float(np.max(r)) for r in ratios) if sa.size else 0.0
    k = qd.n_geometric_panels(span, m)
    d = qd.geometric_offsets(m, k)[1:]
    cuts = [
        c[:, None] + ell_c[:, None] * d,
        c[:, None] - ell_c[:, None] * d,
        sa[:, None] + ell_a[:, None] * d,
        e[:, None] + ell_e[:, None] * d,
        f[:, None] - ell_f[:, None] * d,
        np.stack([sh_lo, sh_hi], axis=-1),
    ]
    bps = np.unique(np.concatenate([b for b in atm.breakpoints] + [np.zeros(0)]))
    if bps.size:
        rb = atm.planet_radius + bps
        sq = np.sqrt(np.maximum(rb * rb - p2[:, None], 0.0))
        cuts += [sq, -sq]
        # where the sun ray's perigee crosses a breakpoint altitude the sun optical length
        # has a derivative singularity: make those points panel boundaries as well
        for radius in rb:
            lo_b, hi_b = qd.shadow_interval(batch.r0, batch.v, batch.s, float(radius))
            cuts.append(np.stack([lo_b + batch.s0, hi_b + batch.s0], axis=-1))
    if atm.tau_levels is not None and atm.tau_levels.size:
        rl = atm.planet_radius + atm.tau_levels
        sq = np.sqrt(np.maximum(rl * rl - p2[:, None], 0.0))
        cuts += [sq, -sq]
    if atm.grazing_levels is not None and atm.grazing_levels.size and np.any(
        has_exit | has_entry
    ):
        # near the shadow the sun's transmittance changes as fast as the optical depth of
        # the sun ray grazing at its perigee: split where the perigee crosses those levels
        for h in atm.grazing_levels:
            lo_b, hi_b = qd.shadow_interval(batch.r0, batch.v, batch.s, atm.planet_radius + h)
            cuts.append(np.stack([lo_b + batch.s0, hi_b + batch.s0], axis=-1))
    bounds = np.concatenate(cuts, axis=-1)
    bounds = np.where(np.isfinite(bounds), bounds, sa[:, None])
    bounds = np.sort(np.clip(bounds, sa[:, None], sb[:, None]), axis=-1)
    return qd.compact_bounds(np.concatenate([sa[:, None], bounds, sb[:, None]], axis=-1))


def _graded(batch: _Batch, samples: int, panels_per_octave: int = 1) -> np.ndarray:
    atm = batch.atm
    q, m = int(samples), int(panels_per_octave)
    bounds = _graded_view_bounds(batch, m)
    sigma, weights, plen = qd.panel_rule(bounds, q)
    n, npan = plen.shape
    h = batch.altitude(sigma)
    p2_s, sig_s, lit = batch.sun_geometry(sigma)
    rho, lview, lsun = [], [], []
    for g in range(len(atm.profiles)):
        r = atm.density(g, h)
        rho.append(r)
        lview.append(qd.cumulative_panel_integral(plen, r.reshape(n, npan, q), q)[0])
        lsun.append(qd.optical_length_to_top(atm, g, p2_s, sig_s, q, m))
    return _combine(atm, rho, weights, lview, lsun, lit)


def _graded_cost(samples: int, panels_per_octave: int = 1) -> int:
    per_path = int(samples) * (20 * int(panels_per_octave) + 10)
    return 2 * per_path * per_path


# ----------------------------------------------------------------------------------------
# tabulate-and-interpolate path (horizontally uniform atmosphere, observer inside it)
# ----------------------------------------------------------------------------------------
def _cheb_nodes01(n: int) -> np.ndarray:
    """Chebyshev points of the first kind on [0, 1] (increasing)."""
    k = np.arange(n)
    return np.sort(0.5 * (1.0 - np.cos((2 * k + 1) * np.pi / (2 * n))))


def _bary_weights_cheb1(n: int) -> np.ndarray:
    k = np.arange(n)
    w = (-1.0) ** k * np.sin((2 * k + 1) * np.pi / (2 * n))
    # nodes were sorted increasing = reversed order of k
    return w[::-1]


def _bary_matrix(nodes: np.ndarray, weights: np.ndarray, x: np.ndarray) -> np.ndarray:
    """Matrix ``M`` with ``M @ f(nodes) = p(x)``, ``p`` the polynomial interpolant."""
    diff = x[:, None] - nodes[None, :]
    exact = diff == 0
    with np.errstate(divide="ignore", invalid="ignore"):
        c = weights / diff
        m = c / np.sum(c, axis=1, keepdims=True)
    rows = np.any(exact, axis=1)
    m[rows] = exact[rows].astype(float)
    return m


_TWO_OVER_PI = 2.0 / np.pi


class _SkyTable:
    """``J_g(μ, φ)`` of an observer inside a horizontally uniform atmosphere.

    (Used by :func:`atmoscatter.multiple_scattering` for its smooth multiple-scattering
    part; single scattering uses :class:`_LogSkyTable`.  ``values``, if given, replaces ``J_g`` by any smooth function of the direction with
    the same symmetry, returning (n_values, N, n_wl); multiple scattering uses it.)

    The phase-free integrals ``J_g`` depend only on the view zenith cosine ``μ`` and the
    azimuth ``φ`` relative to the sun, and are even in ``φ`` (the sky is symmetric about
    the solar vertical).  They are computed with the graded rule at Chebyshev nodes in
    ``x = (2/π) asin(sqrt((μ − μ_h)/(1 − μ_h)))`` (above the horizon ``μ_h`` of the
    ground; ``x`` is linear in the distance from the horizon's square root *and* in the
    angle from the zenith, so both the near-horizon behaviour ``J ≈ J₀ − c|μ − μ_h|`` and
    the pole of the (μ, φ) coordinates are smooth in ``x``), the mirrored variable for
    rays hitting the ground, and at Chebyshev–Lobatto nodes in ``cos φ`` (a cosine series
    in ``φ``).  The interpolating polynomials are resampled on a fine uniform grid that
    queries read bilinearly.
    """

    def __init__(
        self, atm, r0, s, n_mu, n_phi, q, fine=None, values=None, n_values=None, linear=False
    ):
        R = atm.planet_radius
        self.atm, self.r0 = atm, r0
        if values is None:
            # only profile groups that scatter contribute (absorbers enter through J of
            # the others)
            self.groups = sorted({g for g, _, _ in atm.scatterers})

            def values(v):
                J = _evaluate_J(atm, r0, v, s, lambda b: _graded(b, q), _graded_cost(q))
                return J[self.groups]

            n_values = len(self.groups)
        else:
            self.groups = list(range(int(n_values)))
        self._values = values
        self.mu_h = -np.sqrt(max(0.0, 1.0 - (R / r0) ** 2)) if r0 > R else 0.0
        sh = np.hypot(s[0], s[1])
        self.sun_az = np.arctan2(s[0], s[1]) if sh > 0 else 0.0
        self.has_ground = r0 > R * (1.0 + 1e-12)
        channels = len(self.groups) * atm.n_wavelengths
        if fine is None:
            # ~64 MB at most for the resampled table (spectral runs have many channels)
            fine = (1025, 257) if channels <= 16 else (513, 129)
        self.dtype = np.float64 if channels <= 16 else np.float32
        if linear:
            # values with kinks (e.g. multilinearly interpolated fields): sample the
            # uniform grid directly and interpolate bilinearly, no polynomial resampling
            fine = (n_mu, n_phi)
        cphi = np.cos(np.pi * np.arange(n_phi) / (n_phi - 1))[::-1]  # Lobatto, increasing
        wphi = (-1.0) ** np.arange(n_phi) * 1.0
        wphi[[0, -1]] *= 0.5
        nu_f, nc_f = fine
        self.nu_f, self.nc_f = nu_f, nc_f
        uf = np.linspace(0.0, 1.0, nu_f)
        cf = np.linspace(-1.0, 1.0, nc_f)
        mphi = _bary_matrix(cphi, wphi, cf)
        un = _cheb_nodes01(n_mu)
        mu_nodes = _bary_matrix(un, _bary_weights_cheb1(n_mu), uf)
        self.linear = linear
        if linear:
            # nodes uniform in φ (w = 1 − 2φ/π), which the lookup then uses
            cphi, un = np.cos(0.5 * np.pi * (1.0 - cf)), uf
            mphi, mu_nodes = np.eye(nc_f), np.eye(nu_f)
        self.fine_sky = self._build(
            self.mu_h + (1.0 - self.mu_h) * np.sin(0.5 * np.pi * un) ** 2, cphi, s, q, mu_nodes, mphi
        )
        if self.has_ground:
            ng = max(8, n_mu // 2)
            ug = _cheb_nodes01(ng)
            mg = _bary_matrix(ug, _bary_weights_cheb1(ng), uf)
            if linear:
                ug, mg = uf, np.eye(nu_f)
            self.fine_ground = self._build(
                self.mu_h - (1.0 + self.mu_h) * np.sin(0.5 * np.pi * ug) ** 2, cphi, s, q, mg, mphi
            )

    def _build(self, mus, cphi, s, q, mmu, mphi):
        phi = np.arccos(np.clip(cphi, -1.0, 1.0))
        mm, pp = np.meshgrid(mus, phi, indexing="ij")
        sin_t = np.sqrt(np.maximum(1.0 - mm * mm, 0.0))
        az = self.sun_az + pp
        v = np.stack([sin_t * np.sin(az), sin_t * np.cos(az), mm], axis=-1).reshape(-1, 3)
        J = self._values(v)
        G, nwl = J.shape[0], J.shape[-1]
        J = J.reshape(G, len(mus), len(cphi), nwl)
        # fine[g, i, j, w] = Σ_a Σ_b mmu[i, a] J[g, a, b, w] mphi[j, b]
        fine = np.einsum("ia,gabw,jb->ijgw", mmu, J, mphi, optimize=True)
        fine = np.maximum(fine, 0.0).reshape(len(mmu), len(mphi), G * nwl)
        return np.ascontiguousarray(fine, dtype=self.dtype)

    def _lookup(self, fine, u, c):
        """Bilinear interpolation; ``fine`` is (nu_f, nc_f, K) with all channels last."""
        x = u * (self.nu_f - 1)
        y = (c + 1.0) * 0.5 * (self.nc_f - 1)
        i = np.clip(x.astype(np.intp), 0, self.nu_f - 2)
        j = np.clip(y.astype(np.intp), 0, self.nc_f - 2)
        fx = (x - i)[:, None]
        fy = (y - j)[:, None]
        flat = fine.reshape(-1, fine.shape[-1])
        k = i * self.nc_f + j
        a = np.take(flat, k, axis=0).astype(float)
        a += (np.take(flat, k + self.nc_f, axis=0) - a) * fx
        b = np.take(flat, k + 1, axis=0).astype(float)
        b += (np.take(flat, k + self.nc_f + 1, axis=0) - b) * fx
        a += (b - a) * fy
        return a

    def J(self, v: np.ndarray) -> np.ndarray:
        """Interpolated ``J_g`` (G, N, n_wl) for unit view directions ``v`` (N, 3)."""
        mu = np.clip(v[:, 2], -1.0, 1.0)
        h = np.hypot(v[:, 0], v[:, 1])
        ca, sa = np.cos(self.sun_az), np.sin(self.sun_az)
        c = np.where(h > 0, (v[:, 0] * sa + v[:, 1] * ca) / np.where(h > 0, h, 1.0), 1.0)
        c = np.clip(c, -1.0, 1.0)
        if self.linear:
            c = 1.0 - 2.0 / np.pi * np.arccos(c)
        G, nwl = len(self.groups), self.atm.n_wavelengths
        out = np.zeros((v.shape[0], G * nwl))
        sky = mu >= self.mu_h
        u = _TWO_OVER_PI * np.arcsin(np.sqrt(np.clip((mu - self.mu_h) / (1.0 - self.mu_h), 0.0, 1.0)))
        if self.has_ground:
            idx = np.nonzero(sky)[0]
            out[idx] = self._lookup(self.fine_sky, u[idx], c[idx])
            idx = np.nonzero(~sky)[0]
            ug = _TWO_OVER_PI * np.arcsin(
                np.sqrt(np.clip((self.mu_h - mu[idx]) / (1.0 + self.mu_h), 0.0, 1.0))
            )
            out[idx] = self._lookup(self.fine_ground, ug, c[idx])
        else:
            out = np.where(sky[:, None], self._lookup(self.fine_sky, u, c), 0.0)
        return np.moveaxis(out.reshape(-1, G, nwl), 1, 0)


# ----------------------------------------------------------------------------------------
# checked log-space table (the default for large batches, and method="table")
# ----------------------------------------------------------------------------------------
TABLE_FLOOR: float = 1e-6
"""Brightness floor of the table path's accuracy claim, relative to the sky maximum.

The ``"table"`` path (and therefore the default for batches of ≥ :data:`TABLE_THRESHOLD`
directions) agrees with the direct ``"graded"`` rule, and with ``method="reference"``,
to 1e-3 maximum relative error for every direction and wavelength whose radiance is at
least ``TABLE_FLOOR`` times the largest radiance of the sky at that wavelength (over all
view directions, sun aureole included).  Darker directions (e.g. the blue horizon under
a 1° sun in a turbidity-10 haze, 1e-26 of the maximum) are positive but only within a
factor of a few."""

TABLE_CHECK_TOL: float = 3e-4
"""Relative error (against ``"graded"``) above which a table cell fails its self-check."""

#: (nodes in the horizon/zenith variable x, nodes in the relative azimuth φ) by default
_TABLE_NODES = (129, 17)

#: nodes in φ of the table when the sun is below the observer's ground horizon: the
#: shadow's edge crosses the sky along φ, and with 17 nodes ~40 % of the cells fail their
#: self-check at sun −6°; with 65, 5–7 % (and 2–3 % more as their neighbours)
_TWILIGHT_PHI_NODES = 65

#: slope of the node map at the horizon (``u = x (a + (1 − a) x)``; 1 = uniform in u)
_TABLE_STRETCH = 0.25

#: log range kept in the table: values below ``exp(-_LOG_RANGE)`` × the channel's maximum
#: are clamped there (and returned as 0)
_LOG_RANGE = 69.0  # 1e-30


def _dilate(mask: np.ndarray) -> np.ndarray:
    """``mask`` (2-D) or any of its eight neighbours (no wrap-around)."""
    out = mask.copy()
    for axis in (0, 1):
        grown = out.copy()
        sl = [slice(None)] * 2
        sl[axis] = slice(1, None)
        lo = tuple(sl)
        sl[axis] = slice(None, -1)
        hi = tuple(sl)
        grown[lo] |= out[hi]
        grown[hi] |= out[lo]
        out = grown
    return out


def _cubic_weights(t: np.ndarray) -> np.ndarray:
    """Lagrange weights (N, 4) of nodes 0, 1, 2, 3 at position ``t`` (in node spacings)."""
    t0, t1, t2, t3 = t, t - 1.0, t - 2.0, t - 3.0
    return np.stack(
        [-t1 * t2 * t3 / 6.0, t0 * t2 * t3 / 2.0, -t0 * t1 * t3 / 2.0, t0 * t1 * t2 / 6.0],
        axis=-1,
    )


class _LogSkyTable:
    """``log J_g(u, φ)`` on a uniform grid, bicubic interpolation, self-checked.

    The phase-free integrals ``J_g`` of an observer inside a horizontally uniform
    atmosphere depend only on the view zenith cosine ``μ`` and the azimuth ``φ`` from the
    sun, and are even in ``φ``.  They are computed with the graded rule (order ``q``) at
    the nodes of a uniform grid in ``u = (2/π) asin(sqrt((μ − μ_h)/(1 − μ_h)))`` (above
    the ground horizon ``μ_h``; ``u`` stretches the horizon, where low-sun and hazy skies
    change fastest, and is linear in the zenith angle near the zenith) × ``φ ∈ [0, π]``,
    with the mirrored variable for rays that hit the ground.  Their logarithm (clamped at
    ``exp(−69)`` ≈ 1e-30 of the channel's maximum) is interpolated by 4 × 4-point
    Lagrange polynomials (even reflection at ``φ = 0, π``; one-sided at the ends of
    ``u``): the result is positive, relative errors are uniform over the many orders of
    magnitude a low-sun sky spans, and a kink (the planet's shadow in twilight, a profile
    breakpoint) only spoils the cells around it.

    **Self-check.**  The graded rule is also evaluated at the centre of every cell and
    compared with the interpolant; cells where it differs by more than
    :data:`TABLE_CHECK_TOL` for a value above 0.1 × :data:`TABLE_FLOOR` of the channel's
    maximum are marked, together with their eight neighbours (a 4 × 4 stencil reaches
    one cell beyond its own, so a kink inside a marked cell also spoils the neighbours'
    interpolants, where the centre check can pass by chance: measured at twilight, every
    direction off by more than 1e-3 lay in such a neighbour), and directions falling into
    a marked cell are integrated directly (:meth:`J`).
    """

    def __init__(self, atm, r0, s, n_u, n_phi, q, tol=None, floor=None, stretch=None):
        R = atm.planet_radius
        self.stretch = _TABLE_STRETCH if stretch is None else float(stretch)
        self.atm, self.r0, self.s, self.q = atm, r0, s, q
        self.tol = TABLE_CHECK_TOL if tol is None else float(tol)
        self.floor = TABLE_FLOOR if floor is None else float(floor)
        self.groups = sorted({g for g, _, _ in atm.scatterers})
        self.mu_h = -np.sqrt(max(0.0, 1.0 - (R / r0) ** 2)) if r0 > R else 0.0
        sh = np.hypot(s[0], s[1])
        self.sun_az = np.arctan2(s[0], s[1]) if sh > 0 else 0.0
        self.has_ground = r0 > R * (1.0 + 1e-12)
        n_u, n_phi = max(4, int(n_u)), max(4, int(n_phi))
        parts = [("sky", n_u)]
        if self.has_ground:
            parts.append(("ground", max(8, n_u // 2 + 1)))
        # one batch of graded integrations for nodes and cell centres of every part
        pts, layout = [], []
        for name, n in parts:
            un, pn = np.linspace(0.0, 1.0, n), np.linspace(0.0, 1.0, n_phi)
            uc, pc = 0.5 * (un[1:] + un[:-1]), 0.5 * (pn[1:] + pn[:-1])
            for uu, pp in ((un, pn), (uc, pc)):
                uu2, pp2 = np.meshgrid(uu, pp, indexing="ij")
                pts.append(self._directions(name, uu2.ravel(), pp2.ravel()))
                layout.append(uu2.shape)
        v = np.concatenate(pts, axis=0)
        J = self._direct(v)  # (G, N, nwl)
        G, nwl = J.shape[0], J.shape[2]
        K = G * nwl
        J = np.moveaxis(J, 0, 1).reshape(-1, K)  # (N, K), channels last
        self.jmax = np.maximum(np.max(J, axis=0), 1e-300)  # (K,)
        self.log_min = np.log(self.jmax) - _LOG_RANGE
        self.tables, self.bad_cells = {}, {}
        start = 0
        blocks = []
        for shape in layout:
            n = shape[0] * shape[1]
            blocks.append(J[start : start + n].reshape(shape + (K,)))
            start += n
        self.n_bad = 0
        for k, (name, n) in enumerate(parts):
            nodes, centres = blocks[2 * k], blocks[2 * k + 1]
            self.tables[name] = np.ascontiguousarray(self._log(nodes))
            cu, cp = centres.shape[0], centres.shape[1]
            uu, pp = np.meshgrid(
                (np.arange(cu) + 0.5) / (n - 1), (np.arange(cp) + 0.5) / (n_phi - 1), indexing="ij"
            )
            got = self._interp(self.tables[name], uu.ravel(), pp.ravel())
            true = centres.reshape(-1, K)
            err = np.abs(got - true)
            dark = np.maximum(got, true) < 0.1 * self.floor * self.jmax
            bad = np.any((err > self.tol * true) & ~dark, axis=1)
            self.bad_cells[name] = _dilate(bad.reshape(cu, cp))
            self.n_bad += int(np.count_nonzero(bad))
        self.n_cells = sum(b.size for b in self.bad_cells.values())
        self.n_direct = v.shape[0]

    # -- geometry --------------------------------------------------------------------------
    def _mu(self, name, x):
        a = self.stretch
        u = x * (a + (1.0 - a) * x)
        w = np.sin(0.5 * np.pi * u) ** 2
        if name == "sky":
            return self.mu_h + (1.0 - self.mu_h) * w
        return self.mu_h - (1.0 + self.mu_h) * w

    def _directions(self, name, u, p):
        mu = np.clip(self._mu(name, u), -1.0, 1.0)
        sin_t = np.sqrt(np.maximum(1.0 - mu * mu, 0.0))
        az = self.sun_az + np.pi * p
        return np.stack([sin_t * np.sin(az), sin_t * np.cos(az), mu], axis=-1)

    def _coords(self, v):
        """(part is sky, u, φ/π) of unit view directions ``v`` (N, 3)."""
        mu = np.clip(v[:, 2], -1.0, 1.0)
        h = np.hypot(v[:, 0], v[:, 1])
        ca, sa = np.cos(self.sun_az), np.sin(self.sun_az)
        c = np.where(h > 0, (v[:, 0] * sa + v[:, 1] * ca) / np.where(h > 0, h, 1.0), 1.0)
        p = np.arccos(np.clip(c, -1.0, 1.0)) / np.pi
        sky = mu >= self.mu_h
        a = np.where(sky, (mu - self.mu_h) / (1.0 - self.mu_h), (self.mu_h - mu) / (1.0 + self.mu_h))
        u = _TWO_OVER_PI * np.arcsin(np.sqrt(np.clip(a, 0.0, 1.0)))
        b = self.stretch
        x = 2.0 * u / (b + np.sqrt(b * b + 4.0 * (1.0 - b) * u))
        return sky, np.clip(x, 0.0, 1.0), p

    # -- values ----------------------------------------------------------------------------
    def _direct(self, v):
        q = self.q
        J = _evaluate_J(self.atm, self.r0, v, self.s, lambda b: _graded(b, q), _graded_cost(q))
        return J[self.groups]

    def _log(self, J):
        with np.errstate(divide="ignore"):
            return np.maximum(np.log(J), self.log_min)

    def _interp(self, table, u, p):
        """Interpolated ``J`` (N, K) at ``u``, ``p = φ/π`` in [0, 1]."""
        n, m, K = table.shape
        x = u * (n - 1)
        i = np.clip(x.astype(np.intp), 0, n - 2)
        a0 = np.clip(i - 1, 0, n - 4)
        wu = _cubic_weights(x - a0)
        y = p * (m - 1)
        j = np.clip(y.astype(np.intp), 0, m - 2)
        wp = _cubic_weights(y - (j - 1))
        flat = table.reshape(-1, K)
        out = np.zeros((u.shape[0], K))
        for b in range(4):
            jj = j - 1 + b
            jj = np.where(jj < 0, -jj, jj)
            jj = np.where(jj > m - 1, 2 * (m - 1) - jj, jj)
            col = np.zeros((u.shape[0], K))
            for a in range(4):
                col += wu[:, a, None] * np.take(flat, (a0 + a) * m + jj, axis=0)
            out += wp[:, b, None] * col
        dark = out <= self.log_min + 1.0
        np.exp(out, out=out)
        out[dark] = 0.0
        return out

    def _cells(self, name, u, p):
        n = self.tables[name].shape[0]
        m = self.tables[name].shape[1]
        i = np.clip((u * (n - 1)).astype(np.intp), 0, n - 2)
        j = np.clip((p * (m - 1)).astype(np.intp), 0, m - 2)
        return self.bad_cells[name][i, j]

    def J(self, v: np.ndarray) -> np.ndarray:
        """``J_g`` (G, N, n_wl) for unit view directions ``v`` (N, 3); directions in cells
        that failed the self-check are integrated directly."""
        G, nwl = len(self.groups), self.atm.n_wavelengths
        sky, u, p = self._coords(v)
        out = np.zeros((v.shape[0], G * nwl))
        bad = np.zeros(v.shape[0], dtype=bool)
        for name, sel in (("sky", sky), ("ground", ~sky)):
            idx = np.nonzero(sel)[0]
            if idx.size == 0 or name not in self.tables:
                continue
            out[idx] = self._interp(self.tables[name], u[idx], p[idx])
            bad[idx] = self._cells(name, u[idx], p[idx])
        if np.any(bad):
            idx = np.nonzero(bad)[0]
            out[idx] = np.moveaxis(self._direct(v[idx]), 0, 1).reshape(idx.size, -1)
        return np.moveaxis(out.reshape(-1, G, nwl), 1, 0)


def _table_size(samples: int, twilight: bool = False) -> tuple[int, int]:
    """(nodes in u, nodes in φ) of the table for ``samples`` nodes in u (``twilight``: the
    sun is below the observer's ground horizon)."""
    return int(samples), (_TWILIGHT_PHI_NODES if twilight else _TABLE_NODES[1])


_TABLE_CACHE: OrderedDict = OrderedDict()
_TABLE_CACHE_MAX = 4
_TABLE_LOCK = threading.Lock()


def _cached_table(atmosphere, atm, r0, s, n_mu, n_phi, q):
    """Tables are reused across calls with the same atmosphere, observer and sun (a renderer
    evaluating one sky in many batches, possibly from several threads, builds it once)."""
    try:
        key = (atmosphere, float(r0), tuple(float(x) for x in s), n_mu, n_phi, q)
        hash(key)
    except TypeError:
        return _LogSkyTable(atm, r0, s, n_mu, n_phi, q)
    with _TABLE_LOCK:
        table = _TABLE_CACHE.get(key)
        if table is None:
            table = _LogSkyTable(atm, r0, s, n_mu, n_phi, q)
            _TABLE_CACHE[key] = table
            while len(_TABLE_CACHE) > _TABLE_CACHE_MAX:
                _TABLE_CACHE.popitem(last=False)
        else:
            _TABLE_CACHE.move_to_end(key)
    return table


def _table_radiance(atmosphere, atm, r0, v, s, samples, q=4, chunk=1 << 15):
    """Radiance through :class:`_SkyTable`, in chunks spread over a small thread pool
    (NumPy releases the GIL in the gathers and arithmetic)."""
    R = atm.planet_radius
    dip = np.sqrt(max(0.0, 1.0 - (R / max(r0, R)) ** 2))
    n_mu, n_phi = _table_size(samples, twilight=bool(s[2] < dip))
    table = _cached_table(atmosphere, atm, r0, s, n_mu, n_phi, q)
    out = np.empty((v.shape[0], atm.n_wavelengths))
    sub = atm.scatterers

    def work(i):
        vv = v[i : i + chunk]
        J = table.J(vv)
        nu = np.clip(vv @ s, -1.0, 1.0)
        acc = np.zeros((vv.shape[0], atm.n_wavelengths))
        for g, beta, phase in sub:
            k = table.groups.index(g)
            acc += J[k] * (np.asarray(phase(nu), dtype=float)[:, None] * beta)
        out[i : i + chunk] = acc

    starts = range(0, v.shape[0], chunk)
    if v.shape[0] > 2 * chunk:
        with ThreadPoolExecutor(max_workers=_N_THREADS) as pool:
            list(pool.map(work, starts))
    else:
        for i in starts:
            work(i)
    return out


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

_KERNELS = {
    "keller_bohn": _keller_bohn,
    "midpoint": _midpoint,
    "gauss_legendre": _gauss_legendre,
}


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


def _evaluate_J(atm, r0, v, s, fn, cost, batch_size=None):
    """Phase-free integrals ``J_g`` (G, N, n_wl) over bounded-memory batches."""
    n = v.shape[0]
    out = np.zeros((len(atm.profiles), n, atm.n_wavelengths))
    if batch_size is None:
        # the per-node temporaries carry one value per wavelength
        scale = max(1.0, atm.n_wavelengths / 3.0)
        batch_size = max(8, int(_NODE_BUDGET // max(cost * scale, 1)))
    for i in range(0, n, batch_size):
        b = _Batch(atm, r0, v[i : i + batch_size], s)
        active = b.sb > b.sa
        if s[2] < 0.0 or r0 > atm.top_radius:
            # paths lying wholly in the planet's shadow scatter nothing (exactly 0)
            lo_t, hi_t = qd.shadow_interval(r0, b.v, s, atm.planet_radius)
            dark = (lo_t < hi_t) & (lo_t + b.s0 <= b.sa) & (hi_t + b.s0 >= b.sb)
            active &= ~dark
        if not np.any(active):
            continue
        if not np.all(active):
            idx = np.nonzero(active)[0]
            b = _Batch(atm, r0, v[i : i + batch_size][idx], s)
            out[:, i + idx] = fn(b)
        else:
            out[:, i : i + batch_size] = fn(b)
    return out


def _radiance_from_J(atm, J, v, s):
    B = atm.scattering_weights(np.clip(v @ s, -1.0, 1.0))
    return np.sum(B * J, axis=0)


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

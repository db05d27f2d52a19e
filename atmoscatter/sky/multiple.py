"""Multiple scattering on a spherical planet with a Lambertian ground (seed 004).

Public objects
--------------
multiple_scattering
    Sky radiance per unit extraterrestrial solar irradiance [sr⁻¹] including ``orders``
    orders of scattering (``orders=1`` is :func:`atmoscatter.single_scattering`).
MULTIPLE_SCATTERING_GRID
    The default grid of the precomputed radiance field (documents its resolution).

Method (successive orders, seed 004's recursion)::

    I¹(ω)    = ∫ e^{−τ(P,x)} [Σ β_s ρ p(ω·ω_s) e^{−τ(x,sun)}] dx       (exact: single.py)
    S^i(x,ω) = ∫_{4π} I^i(x, ω′) p(ω·ω′) dω′                          (per species)
    I^{i+1}  = ∫ e^{−τ(P,x)} Σ β_s ρ(x) S^i(x, ω) dx  +  e^{−τ(P,G)} (a/π) E^i(G)

``E^i`` is the irradiance of order ``i`` on the ground ``G`` where a ray ends (``E⁰`` is
the direct sun).  The radiance field ``I^i`` of each order is kept on a grid over
altitude × solar zenith angle × view zenith (double Gauss) × relative azimuth (0–π,
the field is symmetric about the solar vertical) — the horizontally uniform atmosphere
and parallel sun make these four variables sufficient (Bruneton & Neyret 2008 use the
same reduction).  ``S^i`` is obtained with a discrete phase matrix whose rows are
normalised (energy is conserved exactly on the grid); it is interpolated multilinearly
along every ray, weighted by the exact density, and integrated with the same graded
Gauss–Legendre rule as single scattering.

The returned radiance is the light scattered by the atmosphere into the view ray (path
radiance).  For rays that end on the ground the ground's own reflected radiance is *not*
included (so ``orders=1`` equals single scattering for every direction); the ground
albedo acts through light reflected by the ground and scattered again.

Accuracy: orders ≥ 2 are computed on a coarse grid; against the Monte Carlo tracer of
``tests/test_montecarlo.py`` the total radiance agrees within about 1 % (at most ~3 % of
the multiple-scattering part) in a thin (τ ≈ 0.3) and a thick (τ ≈ 3) atmosphere, with
and without a bright ground (``docs/numerical_scattering.md``).

References
----------
* Preetham, A. J. Modeling skylight and aerial perspective (seed 004), ``I^{i+1}(ω)``.
* Keller & Bohn (seed 002) Eq. 5.5 (second order).
* Bruneton, E., Neyret, F. Precomputed atmospheric scattering, EGSR 2008.
"""

from __future__ import annotations

import threading
import warnings
from dataclasses import dataclass

import numpy as np

from .._validate import check_range
from . import _quadrature as qd
from .single import (
    TABLE_THRESHOLD,
    _Batch,
    _graded_view_bounds,
    _prepare_inputs,
    _SkyTable,
    single_scattering,
)

__all__ = ["multiple_scattering", "MULTIPLE_SCATTERING_GRID", "MultipleScatteringGrid"]


@dataclass(frozen=True)
class MultipleScatteringGrid:
    """Resolution of the radiance-field grid of :func:`multiple_scattering`.

    Parameters
    ----------
    n_altitude : int
        Altitude levels (quadratically clustered toward the ground).
    n_sun : int
        Solar zenith angles, uniform in 0–``max_sun_zenith`` [deg].
    n_mu : int
        View zenith cosines (double Gauss: half on each side of the horizontal).
    n_phi : int
        Relative azimuths, uniform in 0–π inclusive.
    order : int
        Gauss–Legendre order per panel of the ray integrals.
    max_sun_zenith : float
        Largest solar zenith angle on the grid [deg] (beyond: deep night, clamped).
    """

    n_altitude: int = 16
    n_sun: int = 14
    n_mu: int = 16
    n_phi: int = 9
    order: int = 3
    max_sun_zenith: float = 120.0


MULTIPLE_SCATTERING_GRID = MultipleScatteringGrid()
"""Default grid."""

#: (view-zenith, azimuth) nodes of the table used for the multiple-scattering part of large
#: batches (≥ TABLE_THRESHOLD directions, observer inside the atmosphere)
_MS_TABLE_NODES = (129, 33)

_CACHE: dict = {}
_CACHE_LOCK = threading.Lock()
_CACHE_MAX = 4


# ----------------------------------------------------------------------------------------
# ray marching shared by grid nodes and user rays
# ----------------------------------------------------------------------------------------
@dataclass
class _March:
    wt: np.ndarray  # (N, M, n_sc, nwl) weight × transmittance × β_s,i ρ_i
    h: np.ndarray  # (N, M) altitude of samples
    mu: np.ndarray  # (N, M) local view zenith cosine
    mus: np.ndarray  # (N, M) local sun zenith cosine
    cphi: np.ndarray  # (N, M) cos relative azimuth
    ground: np.ndarray  # (N,) ray ends on the ground
    t_end: np.ndarray  # (N, nwl) transmittance to the end
    mus_end: np.ndarray  # (N,) sun zenith cosine at the end point
    loc: tuple | None = None  # cached interpolation coordinates on the field grid


def _march(atm: qd.PreparedAtmosphere, r0: float, v: np.ndarray, s: np.ndarray, q: int) -> _March:
    b = _Batch(atm, r0, v, s)
    n = v.shape[0]
    nwl = atm.n_wavelengths
    nsc = len(atm.scatterers)
    R = atm.planet_radius
    bounds = _graded_view_bounds(b, 1)
    sigma, weights, plen = qd.panel_rule(bounds, q)
    npan = plen.shape[1]
    h = b.altitude(sigma)
    tau = np.zeros(sigma.shape + (nwl,))
    tau_end = np.zeros((n, nwl))
    rho = []
    for g in range(len(atm.profiles)):
        r = atm.density(g, h)
        rho.append(r)
        cum, total = qd.cumulative_panel_integral(plen, r.reshape(n, npan, q), q)
        tau += cum[..., None] * atm.extinction[g]
        tau_end += total[:, None] * atm.extinction[g]
    trans = np.exp(-tau)
    wt = np.empty((n, sigma.shape[1], nsc, nwl))
    for i, (g, beta, _) in enumerate(atm.scatterers):
        wt[:, :, i, :] = (weights * rho[g])[..., None] * trans * beta
    rr = np.sqrt(b.p2[:, None] + sigma * sigma)
    mu = np.clip(sigma / rr, -1.0, 1.0)
    t = sigma - b.s0[:, None]
    mus = np.clip((r0 * s[2] + t * b.nu[:, None]) / rr, -1.0, 1.0)
    den = np.sqrt(np.maximum((1.0 - mu * mu) * (1.0 - mus * mus), 0.0))
    with np.errstate(divide="ignore", invalid="ignore"):
        cphi = np.where(den > 1e-12, (b.nu[:, None] - mu * mus) / np.where(den > 1e-12, den, 1.0), 1.0)
    cphi = np.clip(cphi, -1.0, 1.0)
    # end of the ray on the ground?
    mu0 = v[:, 2]
    if r0 <= R * (1.0 + 1e-12):
        ground = mu0 < 0.0  # on the ground looking down: the ground itself, no path
    else:
        ground = (b.sb > b.sa) & (mu0 < 0.0) & (b.p2 < R * R) & np.isclose(
            np.sqrt(b.p2 + b.sb * b.sb), R, rtol=1e-9, atol=1e-3
        )
    r_end = np.sqrt(b.p2 + b.sb * b.sb)
    t_e = b.sb - b.s0
    mus_end = np.clip((r0 * s[2] + t_e * b.nu) / np.maximum(r_end, 1.0), -1.0, 1.0)
    return _March(wt, h, mu, mus, cphi, ground, np.exp(-tau_end), mus_end)


# ----------------------------------------------------------------------------------------
# the grid
# ----------------------------------------------------------------------------------------
class _Field:
    def __init__(self, atm: qd.PreparedAtmosphere, grid: MultipleScatteringGrid):
        self.atm, self.grid = atm, grid
        thick = atm.top_radius - atm.planet_radius
        self.h_nodes = thick * (np.arange(grid.n_altitude) / (grid.n_altitude - 1)) ** 2
        self.th_max = np.radians(grid.max_sun_zenith)
        self.ths = np.linspace(0.0, self.th_max, grid.n_sun)
        xg, wg = np.polynomial.legendre.leggauss(grid.n_mu // 2)
        half = 0.5 * (xg + 1.0)
        self.mu_nodes = np.concatenate([-half[::-1], half])
        self.mu_w = np.concatenate([0.5 * wg[::-1], 0.5 * wg])
        self.phi_nodes = np.linspace(0.0, np.pi, grid.n_phi)
        self.shape = (grid.n_altitude, grid.n_sun, grid.n_mu, grid.n_phi)

    # directions of the grid in a frame with the sun in the x-z plane
    def directions(self) -> np.ndarray:
        mm, pp = np.meshgrid(self.mu_nodes, self.phi_nodes, indexing="ij")
        st = np.sqrt(1.0 - mm * mm)
        return np.stack([st * np.cos(pp), st * np.sin(pp), mm], axis=-1).reshape(-1, 3)

    def phase_matrices(self) -> np.ndarray:
        """(n_sc, n_dir, n_dir) row-normalised discrete phase operators on the grid."""
        nphi = self.grid.n_phi
        # full circle of azimuths, folded onto 0..π
        m_full = np.arange(2 * (nphi - 1))
        phi_full = np.pi * m_full / (nphi - 1)
        fold = np.where(m_full <= nphi - 1, m_full, 2 * (nphi - 1) - m_full)
        dphi = np.pi / (nphi - 1)
        d = self.directions()  # (n_dir, 3), index = l * nphi + m
        mu_f, ph_f = np.meshgrid(self.mu_nodes, phi_full, indexing="ij")
        st = np.sqrt(1.0 - mu_f * mu_f)
        dfull = np.stack([st * np.cos(ph_f), st * np.sin(ph_f), mu_f], axis=-1).reshape(-1, 3)
        wfull = (self.mu_w[:, None] * 2.0 * np.pi * np.ones_like(ph_f) * dphi / (2 * np.pi)).ravel()
        target = (np.arange(self.grid.n_mu)[:, None] * nphi + fold[None, :]).ravel()
        cos = np.clip(d @ dfull.T, -1.0, 1.0)
        out = []
        for _, _, phase in self.atm.scatterers:
            p = np.asarray(phase(cos), dtype=float) * wfull[None, :]
            p /= np.sum(p, axis=1, keepdims=True)
            folded = np.zeros((d.shape[0], d.shape[0]))
            np.add.at(folded.T, target, p.T)
            out.append(folded)
        return np.asarray(out)

    def locate(self, h, mus, mu, cphi):
        """Per-dimension lower indices and fractions for multilinear interpolation."""
        g = self.grid
        hh = np.clip(h, 0.0, self.h_nodes[-1])
        i = np.clip(np.searchsorted(self.h_nodes, hh, side="right") - 1, 0, g.n_altitude - 2)
        fi = (hh - self.h_nodes[i]) / (self.h_nodes[i + 1] - self.h_nodes[i])
        th = np.clip(np.arccos(np.clip(mus, -1.0, 1.0)), 0.0, self.th_max)
        xj = th / self.th_max * (g.n_sun - 1)
        j = np.clip(xj.astype(np.intp), 0, g.n_sun - 2)
        fj = xj - j
        mm = np.clip(mu, self.mu_nodes[0], self.mu_nodes[-1])
        k = np.clip(np.searchsorted(self.mu_nodes, mm, side="right") - 1, 0, g.n_mu - 2)
        fk = (mm - self.mu_nodes[k]) / (self.mu_nodes[k + 1] - self.mu_nodes[k])
        xl = np.arccos(np.clip(cphi, -1.0, 1.0)) / np.pi * (g.n_phi - 1)
        m = np.clip(xl.astype(np.intp), 0, g.n_phi - 2)
        fm = xl - m
        return (i, fi), (j, fj), (k, fk), (m, fm)

    def interp(self, table: np.ndarray, loc) -> np.ndarray:
        """Multilinear interpolation of ``table`` (n_r, n_s, n_mu, n_phi, C) at ``loc``."""
        (i, fi), (j, fj), (k, fk), (m, fm) = loc
        n_r, n_s, n_mu, n_phi = self.shape
        flat = table.reshape(-1, table.shape[-1])
        out = np.zeros(i.shape + (table.shape[-1],))
        for di, wi in ((0, 1 - fi), (1, fi)):
            for dj, wj in ((0, 1 - fj), (1, fj)):
                wij = wi * wj
                for dk, wk in ((0, 1 - fk), (1, fk)):
                    wijk = wij * wk
                    base = (((i + di) * n_s + (j + dj)) * n_mu + (k + dk)) * n_phi
                    out += np.take(flat, base + m, axis=0) * (wijk * (1 - fm))[..., None]
                    out += np.take(flat, base + m + 1, axis=0) * (wijk * fm)[..., None]
        return out


def _ground_irradiance(field: _Field, L: np.ndarray) -> np.ndarray:
    """Irradiance on the ground per solar zenith node, (n_sun, nwl), from a field L."""
    nphi = field.grid.n_phi
    wphi = np.full(nphi, 2.0 * np.pi / (nphi - 1))  # full circle from the folded half
    wphi[[0, -1]] *= 0.5
    up = field.mu_nodes > 0
    w = (field.mu_nodes[up] * field.mu_w[up])[:, None] * wphi[None, :]
    return np.einsum("skpw,kp->sw", L[0][:, up], w)


def _interp_e(field: _Field, E: np.ndarray, mus: np.ndarray) -> np.ndarray:
    th = np.clip(np.arccos(np.clip(mus, -1.0, 1.0)), 0.0, field.th_max)
    return np.stack([np.interp(th, field.ths, E[:, w]) for w in range(E.shape[1])], axis=-1)


def _gather(field: _Field, march: _March, S: np.ndarray) -> np.ndarray:
    """Σ_samples w T Σ_i β_i ρ_i S_i: S (n_r, n_s, n_mu, n_phi, n_sc, nwl) → (N, nwl)."""
    nsc, nwl = S.shape[-2:]
    if march.loc is None:
        march.loc = field.locate(march.h, march.mus, march.mu, march.cphi)
    vals = field.interp(S.reshape(field.shape + (nsc * nwl,)), march.loc)
    vals = vals.reshape(march.h.shape + (nsc, nwl))
    return np.einsum("nmiw,nmiw->nw", march.wt, vals)


class _FieldState:
    """Successive orders on the grid, extended on demand and cached per atmosphere."""

    def __init__(self, atm: qd.PreparedAtmosphere, grid: MultipleScatteringGrid, albedo: float):
        self.atm, self.albedo = atm, albedo
        self.field = field = _Field(atm, grid)
        dirs = field.directions()
        nwl = atm.n_wavelengths
        n_r, n_s, n_mu, n_phi = field.shape
        self.marches = {}
        # the marched rays are kept between orders unless that would take much memory
        # (many wavelengths): then they are recomputed for every order
        self.keep = nwl * max(len(atm.scatterers), 1) <= 24
        L = np.zeros(field.shape + (nwl,))
        for i, h in enumerate(field.h_nodes):
            r0 = atm.planet_radius + h
            for j, th in enumerate(field.ths):
                s = np.array([np.sin(th), 0.0, np.cos(th)])
                mc = _march(atm, r0, dirs, s, grid.order)
                if self.keep:
                    self.marches[i, j] = mc
                # order 1: exact single scattering + ground-reflected direct sun
                J = _single_J(atm, r0, dirs, s, grid.order)
                B = atm.scattering_weights(np.clip(dirs @ s, -1.0, 1.0))
                path = np.sum(B * J, axis=0)
                if albedo > 0:
                    e0 = _direct_ground_irradiance(atm, mc.mus_end, grid.order)
                    path += np.where(mc.ground[:, None], mc.t_end * albedo / np.pi * e0, 0.0)
                L[i, j] = path.reshape(n_mu, n_phi, nwl)
        self.W = field.phase_matrices()  # (nsc, ndir, ndir)
        self.L = L  # field of the highest order computed so far
        self.S: list[np.ndarray] = []  # S^1, S^2, ...

    def _source(self, L):
        f = self.field
        n_r, n_s, n_mu, n_phi = f.shape
        nsc, nwl = len(self.atm.scatterers), self.atm.n_wavelengths
        Lf = L.reshape(n_r, n_s, n_mu * n_phi, nwl)
        return np.einsum("iab,rsbw->rsaiw", self.W, Lf).reshape(f.shape + (nsc, nwl))

    def _next_field(self, S):
        f = self.field
        E = _ground_irradiance(f, self.L) if self.albedo > 0 else None
        Lnew = np.zeros_like(self.L)
        dirs = f.directions()
        for i, h in enumerate(f.h_nodes):
            for j, th in enumerate(f.ths):
                mc = self.marches.get((i, j))
                if mc is None:
                    s = np.array([np.sin(th), 0.0, np.cos(th)])
                    mc = _march(self.atm, self.atm.planet_radius + h, dirs, s, f.grid.order)
                self._accumulate(Lnew, i, j, mc, S, E)
        return Lnew

    def _accumulate(self, Lnew, i, j, mc, S, E):
        f = self.field
        n_mu, n_phi = f.shape[2:]
        path = _gather(f, mc, S)
        if self.albedo > 0:
            e = _interp_e(f, E, mc.mus_end)
            path += np.where(mc.ground[:, None], mc.t_end * self.albedo / np.pi * e, 0.0)
        Lnew[i, j] = path.reshape(n_mu, n_phi, -1)

    def source_sum(self, orders: int) -> np.ndarray:
        """Σ_{k=1}^{orders-1} S^k."""
        while len(self.S) < orders - 1:
            self._extend()
        return np.sum(self.S[: orders - 1], axis=0)

    def _extend(self):
        if self.S:
            self.L = self._next_field(self.S[-1])
        self.S.append(self._source(self.L))

    def converged_orders(self, tol: float, max_orders: int) -> tuple[int, float]:
        """Smallest number of orders whose omitted tail is below ``tol`` (relative).

        The sources of successive orders decay geometrically once the field has its
        asymptotic shape, so the tail after order k is estimated as
        ``S^k · r/(1 − r)`` with ``r = max S^k / max S^{k−1}``, taken relative to the
        accumulated source element by element (with a floor of 1e-6 of the largest value,
        so empty corners of the grid do not dominate).  Returns ``(orders, tail)``;
        ``orders`` is capped at ``max_orders`` (then ``tail`` says what was reached).
        """
        k = 2
        while True:
            self.source_sum(k)
            if len(self.S) >= 2:
                last, prev = self.S[k - 2], self.S[k - 3]
                total = np.sum(self.S[: k - 1], axis=0)
                m_prev = float(np.max(prev))
                r = float(np.max(last)) / m_prev if m_prev > 0 else 0.0
                floor = 1e-6 * float(np.max(total)) if np.max(total) > 0 else 1.0
                rel = float(np.max(last / (total + floor)))
                tail = rel * r / (1.0 - r) if r < 1.0 else np.inf
                if tail <= tol or k >= max_orders:
                    return k, tail
            elif not np.any(self.S[0] > 0):  # nothing scatters twice
                return k, 0.0
            k += 1


def _single_J(atm, r0, v, s, q):
    from .single import _evaluate_J, _graded, _graded_cost

    return _evaluate_J(atm, r0, v, s, lambda b: _graded(b, q), _graded_cost(q))


def _direct_ground_irradiance(atm: qd.PreparedAtmosphere, mus: np.ndarray, q: int) -> np.ndarray:
    """Direct-sun irradiance on the ground per unit solar irradiance: μ_s T_sun, (N, nwl)."""
    R = atm.planet_radius
    lit = mus > 0
    m = np.where(lit, mus, 1.0)
    p2 = R * R * (1.0 - m) * (1.0 + m)
    sig = R * m
    tau = np.zeros(mus.shape + (atm.n_wavelengths,))
    for g in range(len(atm.profiles)):
        tau += qd.optical_length_to_top(atm, g, p2, sig, max(q, 4), 1)[..., None] * atm.extinction[g]
    return np.where(lit[:, None], mus[:, None] * np.exp(-tau), 0.0)


_MAX_AUTO_ORDERS = 200


def _field_for(atm_obj, atm, grid, albedo, orders, tol=None):
    """Field and Σ S^k for ``orders`` orders (or, with ``orders=None``, until ``tol``)."""

    def result(st):
        n = orders
        if n is None:
            n, tail = st.converged_orders(tol, _MAX_AUTO_ORDERS)
            if tail > tol:
                warnings.warn(
                    f"multiple_scattering: after {n} orders the estimated remaining orders "
                    f"still add {tail:.1e} (relative) of the multiple-scattering source, above "
                    f"order_tolerance={tol:g}; the atmosphere is optically thick — pass "
                    "orders= explicitly to go further",
                    RuntimeWarning,
                    stacklevel=4,
                )
        return st.field, st.source_sum(n)

    try:
        key = (atm_obj, grid, float(albedo))
        hash(key)
    except TypeError:  # unhashable custom atmosphere: no caching
        return result(_FieldState(atm, grid, albedo))
    # one lock: renderers call from several threads, and a field state must neither be
    # built twice nor extended by two threads at once
    with _CACHE_LOCK:
        if key not in _CACHE:
            if len(_CACHE) >= _CACHE_MAX:
                _CACHE.pop(next(iter(_CACHE)))
            _CACHE[key] = _FieldState(atm, grid, albedo)
        return result(_CACHE[key])


def multiple_scattering(
    atmosphere,
    view_directions,
    sun_direction,
    *,
    altitude=0.0,
    orders: int | None = None,
    ground_albedo: float = 0.0,
    order_tolerance: float = 1e-4,
    grid: MultipleScatteringGrid | None = None,
    batch_size: int = 2048,
):
    """Sky radiance with ``orders`` orders of scattering, per unit solar irradiance [sr⁻¹].

    Seed 004's successive orders ``I = I¹ + I² + …`` with ``I^{i+1}`` obtained from
    ``I^i`` through the phase integral ``∫ I^i(ω′) β(ω, ω′) dω′`` and the view-path
    integral, including light reflected by a Lambertian ground of albedo
    ``ground_albedo`` (which counts as one order).

    Parameters
    ----------
    atmosphere : Atmosphere
        Planet, atmosphere and constituents.
    view_directions : array_like, shape (..., 3)
        Unit view directions (x east, y north, z up).
    sun_direction : array_like, shape (3,)
        Unit vector toward the sun.
    altitude : float
        Observer altitude [m] (any: ground, inside, top, space).
    orders : int or None
        Number of scattering orders, ≥ 1 (1 = :func:`single_scattering`, default method).
        ``None`` (default): as many as needed for the omitted orders to stay below
        ``order_tolerance`` of the multiple-scattering source (estimated from the geometric
        decay of successive orders; at most 200 orders, with a ``RuntimeWarning`` if that
        is not enough).  Fixed small counts are biased low: against 40 orders, 6 orders are
        1.7 % (turbidity 2) and 18 % (turbidity 6) low and 10 orders 0.05 % / 2.7 % low
        (max over the sky, sun 30° high); the automatic choice is within 2e-4.
    order_tolerance : float
        Target relative size of the omitted orders when ``orders=None`` [-], > 0.
    ground_albedo : float
        Lambertian ground albedo [-], in [0, 1].
    grid : MultipleScatteringGrid, optional
        Resolution of the precomputed field (default :data:`MULTIPLE_SCATTERING_GRID`).
        The field depends only on the atmosphere, albedo, orders and grid, and is cached
        (the first call costs a few seconds; later calls only the view-path gather).
    batch_size : int
        Directions per batch of the gather (bounds memory).

    Returns
    -------
    ndarray, shape (..., n_wavelengths)
        Path radiance per unit extraterrestrial irradiance [sr⁻¹] (ground surface radiance
        at the end of ground-hitting rays excluded), float32 for float32 directions.

    Notes
    -----
    Order 1 is computed exactly (:func:`single_scattering`); orders ≥ 2 on the grid (see
    module docstring).  Measured against a Monte Carlo path tracer, see
    ``docs/numerical_scattering.md``.
    """
    tol = float(check_range(order_tolerance, "order_tolerance", 0.0, 1.0, low_inclusive=False))
    n_orders = None if orders is None else int(check_range(orders, "orders", 1, 200))
    albedo = float(check_range(ground_albedo, "ground_albedo", 0.0, 1.0))
    grid = MULTIPLE_SCATTERING_GRID if grid is None else grid
    if not isinstance(grid, MultipleScatteringGrid):
        raise TypeError(f"grid must be a MultipleScatteringGrid, got {type(grid).__name__}")
    single = single_scattering(atmosphere, view_directions, sun_direction, altitude=altitude)
    if n_orders == 1:
        return single
    atm, v, finite, s, alt, out_dtype = _prepare_inputs(
        atmosphere, view_directions, sun_direction, altitude
    )
    if not atm.scatterers:
        return single
    field, S_sum = _field_for(atmosphere, atm, grid, albedo, n_orders, tol)
    vf = v.reshape(-1, 3)
    fin = finite.reshape(-1)
    vf = np.where(fin[:, None], vf, np.array([0.0, 0.0, 1.0]))
    r0 = atm.planet_radius + alt
    # rotate into the grid's frame is unnecessary: the march works in the local frame and
    # only uses local (h, μ, μ_s, cos φ) of every sample.
    def direct(vv):
        out = np.zeros((vv.shape[0], atm.n_wavelengths))
        for i0 in range(0, vv.shape[0], batch_size):
            vb = vv[i0 : i0 + batch_size]
            b = _Batch(atm, r0, vb, s)
            act = np.nonzero(b.sb > b.sa)[0]
            if act.size == 0:
                continue
            mc = _march(atm, r0, vb[act], s, field.grid.order)
            out[i0 + act] = _gather(field, mc, S_sum)
        return out

    if vf.shape[0] >= TABLE_THRESHOLD and r0 <= atm.top_radius:
        # the multiple-scattering part is a smooth function of (view zenith, azimuth from
        # the sun), symmetric about the solar vertical: tabulate it like single scattering
        table = _SkyTable(
            atm, r0, s, _MS_TABLE_NODES[0], _MS_TABLE_NODES[1], field.grid.order,
            values=lambda vv: direct(vv)[None], n_values=1, linear=True,
        )
        extra = np.concatenate(
            [table.J(vf[i : i + 65536])[0] for i in range(0, vf.shape[0], 65536)], axis=0
        )
    else:
        extra = direct(vf)
    extra = np.where(fin[:, None], np.maximum(extra, 0.0), np.nan)
    out = single.astype(float) + extra.reshape(single.shape)
    return out.astype(out_dtype)

"""Quadrature rules of :func:`atmoscatter.sky.single.single_scattering` (private).

The geometry shared by a batch of view rays (:class:`_Batch`: view segments inside the
atmosphere, the sun ray's impact parameter and the planet's shadow at every node), the
published nested view / optical-depth rules (seed 002 ``"keller_bohn"``, ``"midpoint"``,
``"gauss_legendre"``), this package's graded composite Gauss–Legendre rule, and the
evaluation of the phase-free integrals ``J_g`` over bounded-memory batches that the
dispatcher, the tables and :mod:`atmoscatter.sky.multiple` build on.
"""

from __future__ import annotations

import numpy as np

from . import _quadrature as qd

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


_KERNELS = {
    "keller_bohn": _keller_bohn,
    "midpoint": _midpoint,
    "gauss_legendre": _gauss_legendre,
}


# ----------------------------------------------------------------------------------------
# phase-free integrals over bounded-memory batches
# ----------------------------------------------------------------------------------------
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

"""Gather of a tabulated scattering source along marched rays (private kernel).

Multiple scattering (:mod:`atmoscatter.sky.multiple`) keeps the phase-integrated source
``S(h, θ_s, μ, φ)`` of every order on a grid over altitude, solar zenith angle, view
zenith cosine and azimuth relative to the sun.  Every view ray — the rays of the grid's
own nodes for the next order, and the caller's rays at the end — needs

    I(ray) = Σ_samples  w · T · β ρ  ·  S(h, θ_s, μ, φ at the sample)

with ``S`` interpolated at each sample.  Interpolation is bilinear in ``μ`` and ``φ``,
geometric (log-linear) in altitude — the source of an optically thick layer, or of the
air below the shadow height at twilight, falls roughly exponentially with depth, and
linear interpolation overestimated it (DISORT case 2C: 6 % of the multiple-scattering
part) — and *cubic in* ``log S`` along ``θ_s`` (through the four nearest solar-zenith
nodes): near and below the horizon the field falls by about e per degree of solar
depression (the lit part of the atmosphere shrinks by about one scale height per
degree), which interpolation of the logarithm follows and linear interpolation of the
values overestimates by orders of magnitude between nodes; the cubic removes the
second-order error that remains with log-linear interpolation at low sun (4 % of the
multiple-scattering part of the DISORT Rayleigh case 2B with nodes 2.7° apart).  Where
any of the four values is not positive, log-linear (or linear) between the neighbours.

Two implementations compute the same thing: a compiled kernel (numba, released GIL,
threaded by the caller over chunks of rays) and a NumPy one, which is the fallback
without numba and the kernel's check in the tests.
"""

from __future__ import annotations

import numpy as np

__all__: list[str] = []

def _locate_numpy(nodes: np.ndarray, x: np.ndarray):
    """Lower node index and fraction of ``x`` in sorted ``nodes`` (clamped to the ends)."""
    xx = np.clip(x, nodes[0], nodes[-1])
    i = np.clip(np.searchsorted(nodes, xx, side="right") - 1, 0, nodes.size - 2)
    f = (xx - nodes[i]) / (nodes[i + 1] - nodes[i])
    return i, f


def _lagrange4_numpy(xs, x):
    """Weights (4, K) of the cubic through the four abscissae ``xs`` (4, K) at ``x`` (K,)."""
    w = []
    for i in range(4):
        num = np.ones_like(x)
        den = np.ones_like(x)
        for k in range(4):
            if k != i:
                num = num * (x - xs[k])
                den = den * (xs[i] - xs[k])
        w.append(num / den)
    return np.stack(w)


def gather_numpy(table, h_nodes, th_nodes, mu_nodes, h, mus, mu, cphi, wt):
    """``Σ_m wt[n, m, c] S_c(sample)`` → (N, C); ``table`` is (n_h, n_s, n_mu, n_phi, C).

    Along the solar zenith angle ``log S`` is interpolated by the cubic through the four
    nearest nodes (the two around the sample and one more on each side, shifted inward
    at the ends of the grid); where any of the four values is not positive, log-linearly
    between the two neighbours (linearly if one of them is zero).
    """
    n_h, n_s, n_mu, n_phi, C = table.shape
    N, M = h.shape
    flat = table.reshape(-1, C)
    i, fi = _locate_numpy(h_nodes, h.ravel())
    th = np.clip(np.arccos(np.clip(mus.ravel(), -1.0, 1.0)), th_nodes[0], th_nodes[-1])
    j, fj = _locate_numpy(th_nodes, th)
    k, fk = _locate_numpy(mu_nodes, mu.ravel())
    xl = np.arccos(np.clip(cphi.ravel(), -1.0, 1.0)) / np.pi * (n_phi - 1)
    m = np.clip(xl.astype(np.intp), 0, n_phi - 2)
    fm = xl - m
    j0 = np.clip(j - 1, 0, n_s - 4)
    side = []
    for q in range(4):
        lev = []
        for di in (0, 1):
            acc = np.zeros((h.size, C))
            for dk, wk in ((0, 1 - fk), (1, fk)):
                base = (((i + di) * n_s + (j0 + q)) * n_mu + (k + dk)) * n_phi + m
                acc += flat[base] * (wk * (1 - fm))[:, None]
                acc += flat[base + 1] * (wk * fm)[:, None]
            lev.append(acc)
        x0, x1 = lev
        g = fi[:, None]
        both = (x0 > 0) & (x1 > 0)
        with np.errstate(divide="ignore", invalid="ignore"):
            geo_h = x0 * np.exp(g * np.log(np.where(both, x1, 1.0) / np.where(both, x0, 1.0)))
        side.append(np.where(both, geo_h, (1 - g) * x0 + g * x1))
    a = np.stack(side)  # (4, K, C)
    x = th_nodes[j] + fj * (th_nodes[j + 1] - th_nodes[j])
    lw = _lagrange4_numpy(np.stack([th_nodes[j0 + q] for q in range(4)]), x)  # (4, K)
    pos4 = np.all(a > 0, axis=0)
    with np.errstate(divide="ignore", invalid="ignore"):
        cubic = np.exp(np.sum(lw[..., None] * np.log(np.where(pos4, a, 1.0)), axis=0))
    rows = np.arange(h.size)
    jj = j - j0
    a0, a1 = a[jj, rows], a[jj + 1, rows]
    f = fj[:, None]
    pos = (a0 > 0) & (a1 > 0)
    with np.errstate(divide="ignore", invalid="ignore"):
        geo = a0 * np.exp(f * np.log(np.where(pos, a1, 1.0) / np.where(pos, a0, 1.0)))
    val = np.where(pos4, cubic, np.where(pos, geo, (1 - f) * a0 + f * a1))
    return np.einsum("nmc,nmc->nc", wt, val.reshape(N, M, C))


_KERNELS = None


def _kernels():
    """The compiled kernels (:mod:`._ms_kernels`), imported on first use so that importing
    the package does not import numba; ``None`` without numba."""
    global _KERNELS
    if _KERNELS is None:
        try:
            from . import _ms_kernels as k
        except ImportError:  # pragma: no cover - numba is a declared dependency
            _KERNELS = False
        else:
            _KERNELS = {"locate_rows": k._locate_rows, "gather_located": k._gather_located}
    return _KERNELS or None


def have_kernel() -> bool:
    """Whether the compiled kernels are available (numba installed)."""
    return _kernels() is not None




def gather(table, h_nodes, th_nodes, mu_nodes, h, mus, mu, cphi, wt, *, threads=1, use_kernel=True):
    """Compiled (or NumPy) gather; same contract as :func:`gather_numpy`."""
    N, M = h.shape
    C = table.shape[-1]
    if not use_kernel or N == 0 or not have_kernel():
        return gather_numpy(table, h_nodes, th_nodes, mu_nodes, h, mus, mu, cphi, wt)
    wt = np.ascontiguousarray(wt.reshape(N, M, C))
    if threads <= 1 or N < 256:
        return Located(table.shape[:4], h_nodes, th_nodes, mu_nodes, h, mus, mu, cphi).gather(table, wt)
    from concurrent.futures import ThreadPoolExecutor

    step = -(-N // threads)

    def part(a):
        sl = slice(a, min(a + step, N))
        loc = Located(table.shape[:4], h_nodes, th_nodes, mu_nodes, h[sl], mus[sl], mu[sl], cphi[sl])
        return loc.gather(table, wt[sl])

    with ThreadPoolExecutor(max_workers=threads) as pool:
        return np.concatenate(list(pool.map(part, range(0, N, step))), axis=0)


class Located:
    """Interpolation coordinates of a set of marched samples on one field grid, computed
    once and reused for every order (the node rays of the field are gathered again for
    each order).  ``base`` (N, M) int32 rows, ``frac`` (N, M, 4) float32 fractions."""

    def __init__(self, shape_out, h_nodes, th_nodes, mu_nodes, h, mus, mu, cphi):
        n_h, n_s, n_mu, n_phi = shape_out
        self.shape_out = shape_out
        self.th_nodes = np.ascontiguousarray(th_nodes, dtype=np.float64)
        N, M = h.shape
        base = np.empty((N, M), dtype=np.int64)
        frac = np.empty((N, M, 4))
        args = [np.ascontiguousarray(a, dtype=np.float64)
                for a in (h_nodes, th_nodes, mu_nodes, h, mus, mu, cphi)]
        _kernels()["locate_rows"](n_s, n_mu, n_phi, *args, base, frac)
        self.base = base.astype(np.int32)
        self.frac = frac.astype(np.float32)

    def gather(self, table, wt):
        """``Σ_m wt[n, m, c] S_c(sample)`` → (N, C) for ``table`` (*shape_out, C)."""
        n_h, n_s, n_mu, n_phi = self.shape_out
        C = table.shape[-1]
        flat = np.ascontiguousarray(table, dtype=np.float64).reshape(-1, C)
        N, M = self.base.shape
        out = np.empty((N, C))
        _kernels()["gather_located"](flat, n_s, n_mu, n_phi, self.th_nodes, self.base, self.frac,
                        wt.reshape(N, M, C), out)
        return out

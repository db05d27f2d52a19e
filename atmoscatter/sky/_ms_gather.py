"""Gather of a tabulated scattering source along marched rays (private kernel).

Multiple scattering (:mod:`atmoscatter.sky.multiple`) keeps the phase-integrated source
``S(h, θ_s, μ, φ)`` of every order on a grid over altitude, solar zenith angle, view
zenith cosine and azimuth relative to the sun.  Every view ray — the rays of the grid's
own nodes for the next order, and the caller's rays at the end — needs

    I(ray) = Σ_samples  w · T · β ρ  ·  S(h, θ_s, μ, φ at the sample)

with ``S`` interpolated at each sample.  Interpolation is multilinear in altitude, ``μ``
and ``φ`` and *cubic in* ``log S`` along ``θ_s`` (through the four nearest solar-zenith
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

try:  # numba is a declared dependency; the NumPy path computes the same values
    import numba as _numba
except ImportError:  # pragma: no cover
    _numba = None


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
        acc = np.zeros((h.size, C))
        for di, wi in ((0, 1 - fi), (1, fi)):
            for dk, wk in ((0, 1 - fk), (1, fk)):
                base = (((i + di) * n_s + (j0 + q)) * n_mu + (k + dk)) * n_phi + m
                w = wi * wk
                acc += flat[base] * (w * (1 - fm))[:, None]
                acc += flat[base + 1] * (w * fm)[:, None]
        side.append(acc)
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


if _numba is not None:

    @_numba.njit(cache=True, nogil=True, error_model="numpy")
    def _locate(nodes, x):  # pragma: no cover - compiled
        n = nodes.shape[0]
        if x <= nodes[0]:
            return 0, 0.0
        if x >= nodes[n - 1]:
            return n - 2, 1.0
        lo, hi = 0, n - 1
        while hi - lo > 1:
            mid = (lo + hi) // 2
            if nodes[mid] <= x:
                lo = mid
            else:
                hi = mid
        return lo, (x - nodes[lo]) / (nodes[lo + 1] - nodes[lo])

    @_numba.njit(cache=True, nogil=True, error_model="numpy")
    def _locate_rows(n_s, n_mu, n_phi, h_nodes, th_nodes, mu_nodes, h, mus, mu, cphi,
                     base, frac):  # pragma: no cover - compiled
        """Flat row index of the (0, 0, 0, 0) corner and the four fractions per sample."""
        N, M = h.shape
        for n in range(N):
            for s in range(M):
                i, fi = _locate(h_nodes, h[n, s])
                x = mus[n, s]
                x = -1.0 if x < -1.0 else (1.0 if x > 1.0 else x)
                j, fj = _locate(th_nodes, np.arccos(x))
                k, fk = _locate(mu_nodes, mu[n, s])
                y = cphi[n, s]
                y = -1.0 if y < -1.0 else (1.0 if y > 1.0 else y)
                xl = np.arccos(y) / np.pi * (n_phi - 1)
                m = int(xl)
                if m > n_phi - 2:
                    m = n_phi - 2
                base[n, s] = ((i * n_s + j) * n_mu + k) * n_phi + m
                frac[n, s, 0] = fi
                frac[n, s, 1] = fj
                frac[n, s, 2] = fk
                frac[n, s, 3] = xl - m

    @_numba.njit(cache=True, nogil=True, error_model="numpy")
    def _lagrange4(x0, x1, x2, x3, x):  # pragma: no cover - compiled
        w0 = (x - x1) * (x - x2) * (x - x3) / ((x0 - x1) * (x0 - x2) * (x0 - x3))
        w1 = (x - x0) * (x - x2) * (x - x3) / ((x1 - x0) * (x1 - x2) * (x1 - x3))
        w2 = (x - x0) * (x - x1) * (x - x3) / ((x2 - x0) * (x2 - x1) * (x2 - x3))
        w3 = (x - x0) * (x - x1) * (x - x2) / ((x3 - x0) * (x3 - x1) * (x3 - x2))
        return w0, w1, w2, w3

    @_numba.njit(cache=True, nogil=True, error_model="numpy")
    def _gather_located(flat, n_s, n_mu, n_phi, th_nodes, base, frac, wt, out):  # pragma: no cover
        C = flat.shape[1]
        N, M = base.shape
        a = np.empty((4, C))
        d_h = n_s * n_mu * n_phi
        d_s = n_mu * n_phi
        for n in range(N):
            for c in range(C):
                out[n, c] = 0.0
            for s in range(M):
                b = base[n, s]
                fi = frac[n, s, 0]
                fj = frac[n, s, 1]
                fk = frac[n, s, 2]
                fm = frac[n, s, 3]
                j = (b // d_s) % n_s
                j0 = j - 1
                if j0 < 0:
                    j0 = 0
                if j0 > n_s - 4:
                    j0 = n_s - 4
                x = th_nodes[j] + fj * (th_nodes[j + 1] - th_nodes[j])
                l0, l1, l2, l3 = _lagrange4(th_nodes[j0], th_nodes[j0 + 1], th_nodes[j0 + 2],
                                            th_nodes[j0 + 3], x)
                bb = b + (j0 - j) * d_s
                for q in range(4):
                    for c in range(C):
                        a[q, c] = 0.0
                for di in range(2):
                    wi = fi if di == 1 else 1.0 - fi
                    for dk in range(2):
                        wk = fk if dk == 1 else 1.0 - fk
                        w = wi * wk
                        w0 = w * (1.0 - fm)
                        w1 = w * fm
                        b0 = bb + di * d_h + dk * n_phi
                        for q in range(4):
                            bq = b0 + q * d_s
                            for c in range(C):
                                a[q, c] += flat[bq, c] * w0 + flat[bq + 1, c] * w1
                jj = j - j0  # position of node j in the stencil
                for c in range(C):
                    if a[0, c] > 0.0 and a[1, c] > 0.0 and a[2, c] > 0.0 and a[3, c] > 0.0:
                        v = np.exp(l0 * np.log(a[0, c]) + l1 * np.log(a[1, c])
                                   + l2 * np.log(a[2, c]) + l3 * np.log(a[3, c]))
                    else:
                        p0 = a[jj, c]
                        p1 = a[jj + 1, c]
                        if p0 > 0.0 and p1 > 0.0:
                            v = p0 * np.exp(fj * np.log(p1 / p0))
                        else:
                            v = (1.0 - fj) * p0 + fj * p1
                    out[n, c] += wt[n, s, c] * v


HAVE_KERNEL = _numba is not None


def gather(table, h_nodes, th_nodes, mu_nodes, h, mus, mu, cphi, wt, *, threads=1, use_kernel=True):
    """Compiled (or NumPy) gather; same contract as :func:`gather_numpy`."""
    N, M = h.shape
    C = table.shape[-1]
    if not (use_kernel and HAVE_KERNEL) or N == 0:
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
        _locate_rows(n_s, n_mu, n_phi, *args, base, frac)
        self.base = base.astype(np.int32)
        self.frac = frac.astype(np.float32)

    def gather(self, table, wt):
        """``Σ_m wt[n, m, c] S_c(sample)`` → (N, C) for ``table`` (*shape_out, C)."""
        n_h, n_s, n_mu, n_phi = self.shape_out
        C = table.shape[-1]
        flat = np.ascontiguousarray(table, dtype=np.float64).reshape(-1, C)
        N, M = self.base.shape
        out = np.empty((N, C))
        _gather_located(flat, n_s, n_mu, n_phi, self.th_nodes, self.base, self.frac,
                        wt.reshape(N, M, C), out)
        return out

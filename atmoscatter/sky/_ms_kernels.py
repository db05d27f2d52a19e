"""Compiled kernels of :mod:`atmoscatter.sky._ms_gather` (private; imported on first use,
so that ``import atmoscatter`` does not import numba)."""

import numba
import numpy as np


@numba.njit(cache=True, nogil=True, error_model="numpy")
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


@numba.njit(cache=True, nogil=True, error_model="numpy")
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


@numba.njit(cache=True, nogil=True, error_model="numpy")
def _lagrange4(x0, x1, x2, x3, x):  # pragma: no cover - compiled
    w0 = (x - x1) * (x - x2) * (x - x3) / ((x0 - x1) * (x0 - x2) * (x0 - x3))
    w1 = (x - x0) * (x - x2) * (x - x3) / ((x1 - x0) * (x1 - x2) * (x1 - x3))
    w2 = (x - x0) * (x - x1) * (x - x3) / ((x2 - x0) * (x2 - x1) * (x2 - x3))
    w3 = (x - x0) * (x - x1) * (x - x2) / ((x3 - x0) * (x3 - x1) * (x3 - x2))
    return w0, w1, w2, w3


@numba.njit(cache=True, nogil=True, error_model="numpy")
def _corner_weights(n_s, d_h, d_s, n_phi, th_nodes, b, fi, fj, fk, fm, rows, u0, u1):  # pragma: no cover
    """The 16 (altitude, θ_s, μ) rows of one sample's interpolation stencil and their
    weights for the lower (``u0``) and upper (``u1``) azimuth node: multilinear in
    altitude, μ and φ, cubic (4-point Lagrange, shifted inward at the grid's ends) in
    θ_s.  ``b`` is the flat row of the stencil's (0, 0, 0, 0) corner."""
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
    r = 0
    for di in range(2):
        wi = fi if di == 1 else 1.0 - fi
        for dk in range(2):
            wk = fk if dk == 1 else 1.0 - fk
            w = wi * wk
            w0 = w * (1.0 - fm)
            w1 = w * fm
            b0 = bb + di * d_h + dk * n_phi
            for q in range(4):
                lq = l0 if q == 0 else (l1 if q == 1 else (l2 if q == 2 else l3))
                rows[r] = b0 + q * d_s
                u0[r] = w0 * lq
                u1[r] = w1 * lq
                r += 1


@numba.njit(cache=True, nogil=True, error_model="numpy")
def _gather_log(logflat, n_s, n_mu, n_phi, th_nodes, start, base, frac, wt, out):  # pragma: no cover
    """``out[n, c] = Σ_s wt[s, c] exp(interpolated log S_c)`` over the samples
    ``start[n] ≤ s < start[n + 1]`` of ray ``n`` (packed: samples whose weight is zero in
    every channel are not stored, they add exactly nothing); interpolation of
    :func:`_corner_weights` on ``log S`` (``logflat``, rows × channels).

    The channels are summed in blocks of four with the accumulators in registers (the
    same operations in the same order as one channel at a time, so the result does not
    depend on the blocking)."""
    C = logflat.shape[1]
    C4 = C - C % 4
    N = start.shape[0] - 1
    d_h = n_s * n_mu * n_phi
    d_s = n_mu * n_phi
    u0 = np.empty(16)
    u1 = np.empty(16)
    rows = np.empty(16, dtype=np.int64)
    ex = np.empty(C)
    for n in range(N):
        for c in range(C):
            out[n, c] = 0.0
        for s in range(start[n], start[n + 1]):
            _corner_weights(n_s, d_h, d_s, n_phi, th_nodes, base[s], frac[s, 0], frac[s, 1],
                            frac[s, 2], frac[s, 3], rows, u0, u1)
            for cb in range(0, C4, 4):
                a0 = 0.0
                a1 = 0.0
                a2 = 0.0
                a3 = 0.0
                for r in range(16):
                    p = rows[r]
                    v0 = u0[r]
                    v1 = u1[r]
                    a0 += logflat[p, cb] * v0 + logflat[p + 1, cb] * v1
                    a1 += logflat[p, cb + 1] * v0 + logflat[p + 1, cb + 1] * v1
                    a2 += logflat[p, cb + 2] * v0 + logflat[p + 1, cb + 2] * v1
                    a3 += logflat[p, cb + 3] * v0 + logflat[p + 1, cb + 3] * v1
                ex[cb] = a0
                ex[cb + 1] = a1
                ex[cb + 2] = a2
                ex[cb + 3] = a3
            for c in range(C4, C):
                a = 0.0
                for r in range(16):
                    p = rows[r]
                    a += logflat[p, c] * u0[r] + logflat[p + 1, c] * u1[r]
                ex[c] = a
            for c in range(C):
                out[n, c] += wt[s, c] * np.exp(ex[c])


@numba.njit(cache=True, nogil=True, error_model="numpy")
def _tau_up_one(h_nodes, tau, nx, h, mu, c, acc):  # pragma: no cover - compiled
    """Bilinear ``τ↑`` of :class:`multiple._SunTransmittance` (nodes in ``h`` × ``√μ``)
    at one point, for every wavelength, times ``c``, added to ``acc``."""
    i, fi = _locate(h_nodes, h)
    x = np.sqrt(min(max(mu, 0.0), 1.0)) * (nx - 1)
    j = int(x)
    if j > nx - 2:
        j = nx - 2
    fj = x - j
    for w in range(tau.shape[2]):
        acc[w] += c * ((1.0 - fi) * ((1.0 - fj) * tau[i, j, w] + fj * tau[i, j + 1, w])
                       + fi * ((1.0 - fj) * tau[i + 1, j, w] + fj * tau[i + 1, j + 1, w]))


@numba.njit(cache=True, nogil=True, error_model="numpy")
def sun_transmittance(h_nodes, tau, R, top, h, mus, out):  # pragma: no cover - compiled
    """``out[n, w] = T`` of the sun ray at altitudes ``h`` and sun zenith cosines ``mus``
    (flat arrays): the compiled twin of :meth:`multiple._SunTransmittance.__call__`."""
    nx = tau.shape[1]
    nwl = tau.shape[2]
    acc = np.empty(nwl)
    for n in range(h.shape[0]):
        hh = min(max(h[n], 0.0), top - R)
        m = min(max(mus[n], -1.0), 1.0)
        for w in range(nwl):
            acc[w] = 0.0
        if m >= 0.0:
            _tau_up_one(h_nodes, tau, nx, hh, m, 1.0, acc)
        else:
            rp = (R + hh) * np.sqrt((1.0 - m) * (1.0 + m))
            if rp < R:
                for w in range(nwl):
                    out[n, w] = 0.0
                continue
            _tau_up_one(h_nodes, tau, nx, rp - R, 0.0, 2.0, acc)
            _tau_up_one(h_nodes, tau, nx, hh, -m, -1.0, acc)
        for w in range(nwl):
            out[n, w] = np.exp(-max(acc[w], 0.0))


@numba.njit(cache=True, nogil=True, error_model="numpy")
def march_weights(plen, rho, ext, smat, wq, weights, sc_group, sc_beta, wt, tau_end):  # pragma: no cover
    """Quadrature weights × view transmittance × scattering coefficient of marched rays:
    the compiled twin of the optical-depth part of :func:`multiple._march`.

    ``plen`` (N, P) panel lengths, ``rho`` (G, N, P·q) relative densities per profile at the
    nodes, ``ext`` (G, nwl) extinction at density 1, ``smat`` (q, q) and ``wq`` (q,) the unit
    panel's integration matrix and Gauss weights, ``weights`` (N, P·q) the nodes' quadrature
    weights, ``sc_group`` (nsc,) and ``sc_beta`` (nsc, nwl) the scatterers' profile and
    scattering coefficient.  Writes ``wt`` (N, P·q, nsc, nwl) =
    ``weights · ρ_g(i) · β_i · exp(−τ)`` with ``τ`` the optical depth from the ray's start
    to the node (whole earlier panels plus the node's share of its own), and ``tau_end``
    (N, nwl), the optical depth of the whole ray.
    """
    N, P = plen.shape
    G, nwl = ext.shape
    q = wq.shape[0]
    nsc = sc_group.shape[0]
    base = np.empty(nwl)
    part = np.empty(G)
    whole = np.empty(G)
    for n in range(N):
        for w in range(nwl):
            base[w] = 0.0
        for p in range(P):
            L = plen[n, p]
            for g in range(G):
                acc = 0.0
                for j in range(q):
                    acc += wq[j] * rho[g, n, p * q + j]
                whole[g] = L * acc
            for k in range(q):
                m = p * q + k
                for g in range(G):
                    acc = 0.0
                    for j in range(q):
                        acc += smat[k, j] * rho[g, n, p * q + j]
                    part[g] = L * acc
                for w in range(nwl):
                    tau = base[w]
                    for g in range(G):
                        tau += part[g] * ext[g, w]
                    t = np.exp(-tau)
                    for i in range(nsc):
                        wt[n, m, i, w] = weights[n, m] * rho[sc_group[i], n, m] * t * sc_beta[i, w]
            for w in range(nwl):
                for g in range(G):
                    base[w] += whole[g] * ext[g, w]
        for w in range(nwl):
            tau_end[n, w] = base[w]

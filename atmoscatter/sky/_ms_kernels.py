"""Compiled kernels of :mod:`atmoscatter.sky._ms_gather` (private; imported on first use,
so that ``import atmoscatter`` does not import numba).

One piece: every numba kernel of the multiple-scattering field build lives here, so that
one lazy import (:func:`atmoscatter._lazy.kernels`) loads them all, beside the small
compiled helpers they share — node location, the Lagrange weights, the sun's
transmittance, the local sun angles — which every gather and order-1 kernel calls (the
per-cell gather of the caller's rays and the slice gather of the field's node rays must
locate and weight a sample the same way: one definition of each step keeps them equal to
round-off)."""

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
def _theta_stencil(n_s, d_s, th_nodes, b, fj):  # pragma: no cover - compiled
    """The solar-zenith part of a sample's stencil: the flat row of its first θ_s node (the
    cubic's four nodes around the sample's interval ``j``, shifted inward at the grid's
    ends; ``b`` the row of the interval's lower corner, ``d_s`` the row stride of θ_s) and
    the four Lagrange weights at the sample's θ_s."""
    j = (b // d_s) % n_s
    j0 = min(max(j - 1, 0), n_s - 4)
    x = th_nodes[j] + fj * (th_nodes[j + 1] - th_nodes[j])
    l0, l1, l2, l3 = _lagrange4(th_nodes[j0], th_nodes[j0 + 1], th_nodes[j0 + 2],
                                th_nodes[j0 + 3], x)
    return b + (j0 - j) * d_s, l0, l1, l2, l3


@numba.njit(cache=True, nogil=True, error_model="numpy")
def _corner_weights(n_s, d_h, d_s, n_phi, th_nodes, b, fi, fj, fk, fm, rows, u0, u1):  # pragma: no cover
    """The 16 (altitude, θ_s, μ) rows of one sample's interpolation stencil and their
    weights for the lower (``u0``) and upper (``u1``) azimuth node: multilinear in
    altitude, μ and φ, cubic (4-point Lagrange, shifted inward at the grid's ends) in
    θ_s.  ``b`` is the flat row of the stencil's (0, 0, 0, 0) corner."""
    bb, l0, l1, l2, l3 = _theta_stencil(n_s, d_s, th_nodes, b, fj)
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
def _gather_log(logflat, n_s, n_mu, n_phi, th_nodes, ray, base, frac, wt, out):  # pragma: no cover
    """``out[n, c] = Σ_s wt[s, c] exp(interpolated log S_c)`` over the samples ``s`` of
    ray ``n`` (``ray[s] == n``), added in the order of the samples (packed: samples whose
    weight is zero in every channel are not stored, they add exactly nothing);
    interpolation of :func:`_corner_weights` on ``log S`` (``logflat``, rows × channels).
    The samples may come in any order: the field's node rays come sorted by their
    (altitude, μ) cell, so that the table is read nearly in sequence (see
    :func:`multiple._node_sample_order`).

    The channels are summed in blocks of four with the accumulators in registers (the
    same operations in the same order as one channel at a time, so the result does not
    depend on the blocking)."""
    C = logflat.shape[1]
    C4 = C - C % 4
    d_h = n_s * n_mu * n_phi
    d_s = n_mu * n_phi
    u0 = np.empty(16)
    u1 = np.empty(16)
    rows = np.empty(16, dtype=np.int64)
    ex = np.empty(C)
    out[:, :] = 0.0
    for s in range(base.shape[0]):
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
        n = ray[s]
        for c in range(C):
            out[n, c] += wt[s, c] * np.exp(ex[c])


@numba.njit(cache=True, nogil=True, error_model="numpy")
def _gather_log6(logflat, n_s, n_mu, n_phi, th_nodes, ray, base, frac, wt, out):  # pragma: no cover
    """:func:`_gather_log` for exactly six channels (two scatterers × three wavelengths: the
    RGB field of every Earth and Mars preset), written out so that the stencil weights
    and the six interpolated logarithms stay in registers (1.4× faster on the 2-core
    machine: ``benchmarks/bench_multiple.py``).  The same
    products in the same order as :func:`_gather_log` — the corners in the order of
    :func:`_corner_weights`, each weight formed as ``((w_i w_k)(1 − f_φ)) l_q`` — so both
    agree to round-off (``tests/test_multiple.py``)."""
    d_h = n_s * n_mu * n_phi
    d_s = n_mu * n_phi
    lf = logflat.ravel()
    out[:, :] = 0.0
    for s in range(base.shape[0]):
        b = np.int64(base[s])
        fi = np.float64(frac[s, 0])
        fj = np.float64(frac[s, 1])
        fk = np.float64(frac[s, 2])
        fm = np.float64(frac[s, 3])
        bb, l0, l1, l2, l3 = _theta_stencil(n_s, d_s, th_nodes, b, fj)
        a0 = 0.0
        a1 = 0.0
        a2 = 0.0
        a3 = 0.0
        a4 = 0.0
        a5 = 0.0
        for di in range(2):
            wi = fi if di == 1 else 1.0 - fi
            for dk in range(2):
                wk = fk if dk == 1 else 1.0 - fk
                w = wi * wk
                w0 = w * (1.0 - fm)
                w1 = w * fm
                for q in range(4):
                    lq = l0 if q == 0 else (l1 if q == 1 else (l2 if q == 2 else l3))
                    v0 = w0 * lq
                    v1 = w1 * lq
                    p = (bb + di * d_h + dk * n_phi + q * d_s) * 6
                    a0 += lf[p] * v0 + lf[p + 6] * v1
                    a1 += lf[p + 1] * v0 + lf[p + 7] * v1
                    a2 += lf[p + 2] * v0 + lf[p + 8] * v1
                    a3 += lf[p + 3] * v0 + lf[p + 9] * v1
                    a4 += lf[p + 4] * v0 + lf[p + 10] * v1
                    a5 += lf[p + 5] * v0 + lf[p + 11] * v1
        n = ray[s]
        out[n, 0] += wt[s, 0] * np.exp(a0)
        out[n, 1] += wt[s, 1] * np.exp(a1)
        out[n, 2] += wt[s, 2] * np.exp(a2)
        out[n, 3] += wt[s, 3] * np.exp(a3)
        out[n, 4] += wt[s, 4] * np.exp(a4)
        out[n, 5] += wt[s, 5] * np.exp(a5)


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
def _sun_t_one(h_nodes, tau, R, top, h, mus, acc):  # pragma: no cover - compiled
    """``acc[w] = T`` of the sun ray at altitude ``h`` and sun zenith cosine ``mus`` (one
    point, every wavelength; see :meth:`multiple._SunTransmittance.__call__`)."""
    nx = tau.shape[1]
    nwl = tau.shape[2]
    hh = min(max(h, 0.0), top - R)
    m = min(max(mus, -1.0), 1.0)
    for w in range(nwl):
        acc[w] = 0.0
    if m >= 0.0:
        _tau_up_one(h_nodes, tau, nx, hh, m, 1.0, acc)
    else:
        rp = (R + hh) * np.sqrt((1.0 - m) * (1.0 + m))
        if rp < R:  # in the planet's shadow: T = 0 (acc is still zero)
            return
        _tau_up_one(h_nodes, tau, nx, rp - R, 0.0, 2.0, acc)
        _tau_up_one(h_nodes, tau, nx, hh, -m, -1.0, acc)
    for w in range(nwl):
        acc[w] = np.exp(-max(acc[w], 0.0))


@numba.njit(cache=True, nogil=True, error_model="numpy")
def sun_transmittance(h_nodes, tau, R, top, h, mus, out):  # pragma: no cover - compiled
    """``out[n, w] = T`` of the sun ray at altitudes ``h`` and sun zenith cosines ``mus``
    (flat arrays): the compiled twin of :meth:`multiple._SunTransmittance.__call__`."""
    acc = np.empty(tau.shape[2])
    for n in range(h.shape[0]):
        _sun_t_one(h_nodes, tau, R, top, h[n], mus[n], acc)
        for w in range(tau.shape[2]):
            out[n, w] = acc[w]


@numba.njit(cache=True, nogil=True, error_model="numpy")
def _local_sun(r0, s_z, sig, s0, nu, rr, u):  # pragma: no cover - compiled
    """Local sun zenith cosine and cosine of the relative azimuth at a node ``sig`` of a
    view ray (the formulas of :func:`multiple._march_sun`)."""
    x = (r0 * s_z + (sig - s0) * nu) / rr
    ms = -1.0 if x < -1.0 else (1.0 if x > 1.0 else x)
    d2 = (1.0 - u * u) * (1.0 - ms * ms)
    den = np.sqrt(d2) if d2 > 0.0 else 0.0
    if den > 1e-12:
        y = (nu - u * ms) / den
        return ms, (-1.0 if y < -1.0 else (1.0 if y > 1.0 else y))
    return ms, 1.0


@numba.njit(cache=True, nogil=True, error_model="numpy")
def _add_order1(h_nodes, tau, R, top, hm, ms, wt, P, n, m, t, path):  # pragma: no cover
    """``path[n, w] += T_sun(hm, ms) Σ_i wt[n, m, i, w] P[n, i]`` (``t``: scratch)."""
    _sun_t_one(h_nodes, tau, R, top, hm, ms, t)
    for w in range(wt.shape[3]):
        a = 0.0
        for i in range(wt.shape[2]):
            a += wt[n, m, i, w] * P[n, i]
        path[n, w] += a * t[w]


@numba.njit(cache=True, nogil=True, error_model="numpy")
def order1_path(sigma, rr, s0, r0, s_z, nu, mu, h, wt, P, keep, h_nodes, tau, R, top,
                mus_out, cphi_out, path):  # pragma: no cover - compiled
    """Order 1 of a node-ray batch for one sun direction, in one pass: the local sun
    zenith cosine ``mus_out`` and cosine of the relative azimuth ``cphi_out`` (N, M) at
    every node (the formulas of :func:`multiple._march_sun`), and the single-scattering
    path ``path[n, w] = Σ_m T_sun(h, μ_s) Σ_i wt[n, m, i, w] P[n, i]`` over the nodes
    with weight (``keep``), ``T_sun`` from the tabulated sun transmittance
    (:func:`sun_transmittance`).  The compiled twin of the NumPy order 1 of
    :class:`multiple._FieldState` (which forms the same sums with ``einsum``)."""
    N, M = sigma.shape
    for n in range(N):
        for m in range(M):
            mus_out[n, m], cphi_out[n, m] = _local_sun(r0, s_z, sigma[n, m], s0[n], nu[n],
                                                       rr[n, m], mu[n, m])
    _order1_pass(sigma, rr, s0, r0, s_z, nu, mu, h, wt, P, keep, h_nodes, tau, R, top, path)


@numba.njit(cache=True, nogil=True, error_model="numpy")
def order1_located(sigma, rr, s0, r0, s_z, nu, mu, h, wt, P, keep, h_nodes, tau, R, top,
                   slot, th_nodes, j, jt, ft, mp, fp, path):  # pragma: no cover - compiled
    """:func:`order1_path` for the node rays of one altitude and the solar-zenith node
    ``j`` of the slice gather, which keeps, instead of the local angles, the (θ_s, φ)
    stencil of every kept sample (:func:`_locate_sun_one`: ``jt``, ``ft``, ``mp``, ``fp``
    at ``[s, j, p]``): ray ``n`` is view zenith ``n // n_phi`` and azimuth node
    ``p = n % n_phi``, its node ``m`` is kept sample ``slot[n // n_phi, m]`` (−1: none)."""
    # two passes over the nodes (the same local angles in each): one loop doing both was
    # 1.6 times slower on the 2-core machine
    _order1_pass(sigma, rr, s0, r0, s_z, nu, mu, h, wt, P, keep, h_nodes, tau, R, top, path)
    _locate_pass(sigma, rr, s0, r0, s_z, nu, mu, slot, th_nodes, j, jt, ft, mp, fp)


@numba.njit(cache=True, nogil=True, error_model="numpy")
def _order1_pass(sigma, rr, s0, r0, s_z, nu, mu, h, wt, P, keep, h_nodes, tau, R, top,
                 path):  # pragma: no cover - compiled
    """The single-scattering path of :func:`order1_path` (no local angles written)."""
    N, M = sigma.shape
    t = np.empty(wt.shape[3])
    path[:, :] = 0.0
    for n in range(N):
        for m in range(M):
            if not keep[n, m]:
                continue
            ms, _ = _local_sun(r0, s_z, sigma[n, m], s0[n], nu[n], rr[n, m], mu[n, m])
            _add_order1(h_nodes, tau, R, top, h[n, m], ms, wt, P, n, m, t, path)


@numba.njit(cache=True, nogil=True, error_model="numpy")
def _locate_pass(sigma, rr, s0, r0, s_z, nu, mu, slot, th_nodes, j, jt, ft, mp, fp):  # pragma: no cover
    """The (θ_s, φ) stencils of :func:`order1_located`'s kept samples."""
    N, M = sigma.shape
    n_phi = jt.shape[2]
    for n in range(N):
        k = n // n_phi
        p = n - k * n_phi
        for m in range(M):
            s = slot[k, m]
            if s < 0:
                continue
            ms, cphi = _local_sun(r0, s_z, sigma[n, m], s0[n], nu[n], rr[n, m], mu[n, m])
            jj, fj, mm, fm = _locate_sun_one(th_nodes, n_phi, ms, cphi)
            jt[s, j, p] = jj
            ft[s, j, p] = fj
            mp[s, j, p] = mm
            fp[s, j, p] = fm


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


@numba.njit(cache=True, nogil=True, error_model="numpy")
def locate_geometry(h_nodes, mu_nodes, h, mu, n_s, n_out, n_phi, hrow, fh, fmu):  # pragma: no cover
    """The (altitude, μ) part of the stencil of samples that every solar zenith and azimuth
    of a node ray shares (:func:`gather_slices`): ``hrow`` the flat row of the (altitude,
    θ_s = 0, μ, φ = 0) corner, ``fh`` and ``fmu`` the fractions, as :func:`_locate_rows`
    finds them."""
    for s in range(h.shape[0]):
        i, fi = _locate(h_nodes, h[s])
        k, fk = _locate(mu_nodes, mu[s])
        hrow[s] = (i * n_s * n_out + k) * n_phi
        fh[s] = fi
        fmu[s] = fk


@numba.njit(cache=True, nogil=True, error_model="numpy")
def _locate_sun_one(th_nodes, n_phi, mus, cphi):  # pragma: no cover - compiled
    """The (θ_s, φ) part of the stencil of one sample, by the formulas of
    :func:`_locate_rows`: the solar-zenith interval ``j`` and fraction ``f_j``, the azimuth
    cell ``m`` and fraction ``f_m``."""
    x = -1.0 if mus < -1.0 else (1.0 if mus > 1.0 else mus)
    j, fj = _locate(th_nodes, np.arccos(x))
    y = -1.0 if cphi < -1.0 else (1.0 if cphi > 1.0 else cphi)
    xl = np.arccos(y) / np.pi * (n_phi - 1)
    m = int(xl)
    if m > n_phi - 2:
        m = n_phi - 2
    return j, fj, m, xl - m


@numba.njit(cache=True, nogil=True, error_model="numpy")
def _slice_range(n_s, n_phi, jt, s, j_lo, j_hi):  # pragma: no cover - compiled
    """The solar-zenith nodes ``lo``–``hi`` (exclusive) that the cubic stencils of sample
    ``s`` read at the solar-zenith nodes ``j_lo``–``j_hi`` and every azimuth."""
    lo = n_s
    hi = 0
    for j in range(j_lo, j_hi):
        for p in range(n_phi):
            j0 = min(max(np.int64(jt[s, j, p]) - 1, 0), n_s - 4)
            if j0 < lo:
                lo = j0
            if j0 + 4 > hi:
                hi = j0 + 4
    return lo, hi


@numba.njit(cache=True, nogil=True, error_model="numpy")
def _fill_slice(logflat, s, lo, hi, d_h, d_s, n_phi, hrow, fh, fmu, A):  # pragma: no cover
    """``A[j, p, c]``: ``log S`` bilinear in (altitude, μ) at sample ``s`` for the
    solar-zenith nodes ``lo``–``hi`` and every azimuth node."""
    C = A.shape[2]
    fi = fh[s]
    fk = fmu[s]
    w00 = (1.0 - fi) * (1.0 - fk)
    w01 = (1.0 - fi) * fk
    w10 = fi * (1.0 - fk)
    w11 = fi * fk
    for jj in range(lo, hi):
        b = hrow[s] + jj * d_s
        for p in range(n_phi):
            r00 = b + p
            r01 = r00 + n_phi
            r10 = r00 + d_h
            r11 = r10 + n_phi
            for c in range(C):
                A[jj, p, c] = (w00 * logflat[r00, c] + w01 * logflat[r01, c]
                               + w10 * logflat[r10, c] + w11 * logflat[r11, c])


@numba.njit(cache=True, nogil=True, error_model="numpy")
def _ray_stencil(th_nodes, inv, n_s, jt, ft, mp, fp, s, j, p):  # pragma: no cover - compiled
    """The (θ_s, φ) stencil of sample ``s`` of the ray at solar-zenith node ``j`` and
    azimuth node ``p``: the first θ_s node ``j0`` of the cubic, the azimuth cell ``m`` and
    the eight weights ``l_q (1 − f_φ)`` and ``l_q f_φ`` (Lagrange weights ``l_q`` with the
    inverse denominators ``inv`` of :func:`lagrange_inverse_denominators`)."""
    jj = np.int64(jt[s, j, p])
    j0 = min(max(jj - 1, 0), n_s - 4)
    x = th_nodes[jj] + np.float64(ft[s, j, p]) * (th_nodes[jj + 1] - th_nodes[jj])
    d0 = x - th_nodes[j0]
    d1 = x - th_nodes[j0 + 1]
    d2 = x - th_nodes[j0 + 2]
    d3 = x - th_nodes[j0 + 3]
    l0 = d1 * d2 * d3 * inv[j0, 0]
    l1 = d0 * d2 * d3 * inv[j0, 1]
    l2 = d0 * d1 * d3 * inv[j0, 2]
    l3 = d0 * d1 * d2 * inv[j0, 3]
    f1 = np.float64(fp[s, j, p])
    f0 = 1.0 - f1
    return (j0, np.int64(mp[s, j, p]), l0 * f0, l0 * f1, l1 * f0, l1 * f1, l2 * f0, l2 * f1,
            l3 * f0, l3 * f1)


def lagrange_inverse_denominators(th_nodes):
    """``inv[j0, q] = 1 / Π_{r≠q} (x_q − x_r)`` over the four nodes ``x = th_nodes[j0:j0+4]``
    of every cubic stencil (:func:`gather_slices`), shape (max(n − 3, 1), 4)."""
    th = np.asarray(th_nodes, dtype=np.float64)
    n = th.size
    inv = np.zeros((max(n - 3, 1), 4))
    for j0 in range(n - 3):
        x = th[j0 : j0 + 4]
        for q in range(4):
            d = 1.0
            for r in range(4):
                if r != q:
                    d *= x[q] - x[r]
            inv[j0, q] = 1.0 / d
    return inv


@numba.njit(cache=True, nogil=True, error_model="numpy")
def gather_slices(logflat, n_s, n_out, n_phi, th_nodes, inv, starts, k0, k1, hrow, fh, fmu, wt,
                  jt, ft, mp, fp, j_lo, j_hi, out):  # pragma: no cover - compiled
    """The gather of :func:`_gather_log` for the node rays of one altitude, by slices.

    The node rays of an altitude that share their view zenith (ray ``k``) share their
    samples — altitude, view zenith, weight — for every solar zenith ``j`` and azimuth
    ``p``: only the sample's local solar zenith and azimuth differ.  So for each sample the
    bilinear (altitude, μ) part of the interpolation of ``log S`` is formed once, as a
    slice over the solar-zenith nodes the rays' stencils read and every azimuth node
    (:func:`_fill_slice`), and each ray then interpolates that slice by the cubic in θ_s
    and linearly in φ (:func:`_ray_stencil`): the tensor product of
    :func:`_corner_weights`, summed in another order (equal to round-off), for a fraction
    of the table reads.

    ``starts`` (n_rays + 1,) the offsets of each ray's samples (kept samples, along the
    ray), rays ``k0``–``k1`` gathered; per sample ``hrow``, ``fh``, ``fmu``
    (:func:`locate_geometry`) and the weights ``wt`` (K, C); per sample, solar zenith
    node and azimuth node ``jt``, ``ft``, ``mp``, ``fp`` (K, n_s, n_phi)
    (:func:`order1_located`); ``inv``: :func:`lagrange_inverse_denominators`.  The
    solar-zenith nodes ``j_lo``–``j_hi`` (exclusive) are added to ``out`` (n_s, n_rays,
    n_phi, C)."""
    C = logflat.shape[1]
    d_h = n_s * n_out * n_phi
    d_s = n_out * n_phi
    A = np.empty((n_s, n_phi, C))
    ex = np.empty(C)
    u = np.empty(4)
    v = np.empty(4)
    for k in range(k0, k1):
        for s in range(starts[k], starts[k + 1]):
            lo, hi = _slice_range(n_s, n_phi, jt, s, j_lo, j_hi)
            _fill_slice(logflat, s, lo, hi, d_h, d_s, n_phi, hrow, fh, fmu, A)
            for j in range(j_lo, j_hi):
                for p in range(n_phi):
                    j0, m, u[0], v[0], u[1], v[1], u[2], v[2], u[3], v[3] = _ray_stencil(
                        th_nodes, inv, n_s, jt, ft, mp, fp, s, j, p)
                    for c in range(C):
                        ex[c] = 0.0
                    for q in range(4):
                        for c in range(C):
                            ex[c] += u[q] * A[j0 + q, m, c] + v[q] * A[j0 + q, m + 1, c]
                    for c in range(C):
                        out[j, k, p, c] += wt[s, c] * np.exp(ex[c])


@numba.njit(cache=True, nogil=True, error_model="numpy")
def gather_slices6(logflat, n_s, n_out, n_phi, th_nodes, inv, starts, k0, k1, hrow, fh, fmu,
                   wt, jt, ft, mp, fp, j_lo, j_hi, out):  # pragma: no cover - compiled
    """:func:`gather_slices` for exactly six channels (two scatterers × three wavelengths),
    written out so that the interpolated logarithms stay in registers: the same products
    in the same order, so both agree to round-off."""
    d_h = n_s * n_out * n_phi
    d_s = n_out * n_phi
    A = np.empty((n_s, n_phi, 6))
    for k in range(k0, k1):
        for s in range(starts[k], starts[k + 1]):
            lo, hi = _slice_range(n_s, n_phi, jt, s, j_lo, j_hi)
            _fill_slice(logflat, s, lo, hi, d_h, d_s, n_phi, hrow, fh, fmu, A)
            w0 = wt[s, 0]
            w1 = wt[s, 1]
            w2 = wt[s, 2]
            w3 = wt[s, 3]
            w4 = wt[s, 4]
            w5 = wt[s, 5]
            for j in range(j_lo, j_hi):
                for p in range(n_phi):
                    j0, m, u0, v0, u1, v1, u2, v2, u3, v3 = _ray_stencil(
                        th_nodes, inv, n_s, jt, ft, mp, fp, s, j, p)
                    e0 = 0.0
                    e1 = 0.0
                    e2 = 0.0
                    e3 = 0.0
                    e4 = 0.0
                    e5 = 0.0
                    for q in range(4):
                        u = u0 if q == 0 else (u1 if q == 1 else (u2 if q == 2 else u3))
                        v = v0 if q == 0 else (v1 if q == 1 else (v2 if q == 2 else v3))
                        e0 += u * A[j0 + q, m, 0] + v * A[j0 + q, m + 1, 0]
                        e1 += u * A[j0 + q, m, 1] + v * A[j0 + q, m + 1, 1]
                        e2 += u * A[j0 + q, m, 2] + v * A[j0 + q, m + 1, 2]
                        e3 += u * A[j0 + q, m, 3] + v * A[j0 + q, m + 1, 3]
                        e4 += u * A[j0 + q, m, 4] + v * A[j0 + q, m + 1, 4]
                        e5 += u * A[j0 + q, m, 5] + v * A[j0 + q, m + 1, 5]
                    out[j, k, p, 0] += w0 * np.exp(e0)
                    out[j, k, p, 1] += w1 * np.exp(e1)
                    out[j, k, p, 2] += w2 * np.exp(e2)
                    out[j, k, p, 3] += w3 * np.exp(e3)
                    out[j, k, p, 4] += w4 * np.exp(e4)
                    out[j, k, p, 5] += w5 * np.exp(e5)


@numba.njit(cache=True, nogil=True, error_model="numpy")
def refine_intervals(logt, i_lo, i_hi, i0, w, r, out):  # pragma: no cover - compiled
    """The values :func:`multiple._refine_log` inserts in the altitude intervals
    ``i_lo``–``i_hi`` (exclusive) of ``logt`` (n, E): in interval ``i`` at ``out[r i + k]``
    (k = 1 … r − 1) the cubic ``Σ_q w[i, k − 1, q] logt[i0[i] + q]`` (summed in the order of
    ``q``) limited to the range of ``logt[i]`` and ``logt[i + 1]``; with fewer than four
    nodes (``i0[i] < 0``) the linear step ``a + (b − a) k/r``."""
    E = logt.shape[1]
    for i in range(i_lo, i_hi):
        q0 = i0[i]
        for k in range(1, r):
            o = r * i + k
            w0 = w[i, k - 1, 0]
            w1 = w[i, k - 1, 1]
            w2 = w[i, k - 1, 2]
            w3 = w[i, k - 1, 3]
            t = k / r
            for e in range(E):
                a = logt[i, e]
                b = logt[i + 1, e]
                lo = a if a < b else b
                hi = b if a < b else a
                if q0 < 0:
                    mid = a + (b - a) * t
                else:
                    mid = (w0 * logt[q0, e] + w1 * logt[q0 + 1, e]) + w2 * logt[q0 + 2, e]
                    mid = mid + w3 * logt[q0 + 3, e]
                out[o, e] = lo if mid < lo else (hi if mid > hi else mid)


@numba.njit(cache=True, nogil=True, error_model="numpy")
def decay_test(last, prev, total, floor, r_all, g_prev, has_prev, g):  # pragma: no cover
    """The decay test of :meth:`multiple._FieldState.converged_sum` in one pass:
    ``g = r/(1 − r)`` with ``r = last/prev`` where ``prev`` is above the floor (else
    ``r_all``) clipped to [0, 0.98], written to ``g``; returns ``(rel, drift)``, the
    largest ``last g/(total + floor)`` and (with ``has_prev``) the largest
    ``|g − g_prev|/max(g, 1e-300)`` where ``last`` is above the floor (else −inf).

    ``last``, ``prev``, ``total``, ``g_prev``, ``g``: (n_r, n_cols, K) with the
    wavelength the fastest index of ``K``; ``floor`` (n_cols, nwl).  The operations of
    the NumPy lines, element by element, so the same values."""
    n_r, nc, K = last.shape
    nwl = floor.shape[1]
    rel = -np.inf
    drift = -np.inf
    for i in range(n_r):
        for j in range(nc):
            for k in range(K):
                fl = floor[j, k % nwl]
                lt = last[i, j, k]
                pv = prev[i, j, k]
                r = lt / pv if pv > fl else r_all
                r = min(max(r, 0.0), 0.98)
                gg = r / (1.0 - r)
                g[i, j, k] = gg
                v = lt * gg / (total[i, j, k] + fl)
                if v > rel or v != v:
                    rel = v
                if has_prev:
                    d = abs(gg - g_prev[i, j, k]) / max(gg, 1e-300) * (1.0 if lt > fl else 0.0)
                    if d > drift or d != d:
                        drift = d
    return rel, drift

"""Gather of a tabulated scattering source along marched rays (private kernel).

Multiple scattering (:mod:`atmoscatter.sky.multiple`) keeps the phase-integrated source
``S(h, θ_s, μ, φ)`` of every order on a grid over altitude, solar zenith angle, view
zenith cosine and azimuth relative to the sun.  Every view ray — the rays of the grid's
own nodes for the next order, and the caller's rays at the end — needs

    I(ray) = Σ_samples  w · T · β ρ  ·  S(h, θ_s, μ, φ at the sample)

with ``S`` interpolated at each sample.  Interpolation is on ``log S``: multilinear in ``μ`` and ``φ`` and in altitude — the
source of an optically thick layer, or of the air below the shadow height at twilight,
falls roughly exponentially with depth, and linear interpolation of the values
overestimated it (DISORT case 2C: 6 % of the multiple-scattering part) — and cubic
along ``θ_s`` (through the four nearest solar-zenith
nodes): near and below the horizon the field falls by about e per degree of solar
depression (the lit part of the atmosphere shrinks by about one scale height per
degree), which interpolation of the logarithm follows and linear interpolation of the
values overestimates by orders of magnitude between nodes; the cubic removes the
second-order error that remains with log-linear interpolation at low sun (4 % of the
multiple-scattering part of the DISORT Rayleigh case 2B with nodes 2.7° apart).  Values
below :data:`LOG_FLOOR` of a channel's maximum are floored there ("dark").  One
exponential per sample and channel: the logarithms are taken once per table.

Two implementations compute the same thing: a compiled kernel (numba, released GIL,
threaded by the caller over chunks of rays) and a NumPy one, which is the fallback
without numba and the kernel's check in the tests.
"""

from __future__ import annotations

from functools import cache

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


#: values of the source below this fraction of a channel's maximum are floored there
#: before taking logarithms (they stand for "dark": e.g. deep inside the planet's shadow)
LOG_FLOOR = 1e-30


def channel_max(a: np.ndarray) -> np.ndarray:
    """The largest value of each channel (the last axis) of ``a``, exactly as
    ``np.max(a, axis=all but the last)``, faster: NumPy reduces a long run of rows of few
    channels one row at a time, so the rows are taken in blocks of 256 first."""
    C = a.shape[-1]
    flat = a.reshape(-1, C)
    n = flat.shape[0]
    head = n - n % 256
    parts = []
    if head:
        parts.append(flat[:head].reshape(-1, 256 * C).max(axis=0).reshape(256, C).max(axis=0))
    if head < n:
        parts.append(flat[head:].max(axis=0))
    return np.maximum.reduce(parts) if parts else np.full(C, -np.inf)


def log_table(table: np.ndarray, out: np.ndarray | None = None,
              floor: np.ndarray | None = None) -> np.ndarray:
    """``log S`` of a source table (..., C), floored at :data:`LOG_FLOOR` × each channel's
    maximum (and at the smallest normal number); ``out``: an array of the table's shape
    to write into (it may be a strided view); ``floor``: :func:`log_floor` of a larger
    table this one is a part of (default: this table's)."""
    floor = log_floor(table) if floor is None else floor
    out = np.maximum(table, floor, out=out)
    return np.log(out, out=out)


def log_floor(table: np.ndarray) -> np.ndarray:
    """The floor of :func:`log_table` per channel: :data:`LOG_FLOOR` × the channel's
    maximum, at least the smallest normal number."""
    C = table.shape[-1]
    flat = table.reshape(-1, C)
    top = channel_max(flat) if flat.size else np.ones(C)
    return np.maximum(top * LOG_FLOOR, np.finfo(float).tiny)


class LogTable:
    """A log table (:func:`log_table`, shape (..., C)) prepared for the compiled gather: the
    flat (rows, C) array and, for more than six channels, contiguous slabs of six channels
    (and one of the rest).  The gather reads one slab at a time, with the written-out
    six-channel kernel: a 21-wavelength field's table (0.37 GB on the default grid) does
    not stay in cache, a slab of it does, and every channel is computed by the same
    operations as before, so the values do not change.  The slabs replace the table (no
    second copy is kept); :attr:`array` reassembles it (the NumPy fallback)."""

    def __init__(self, logt: np.ndarray):
        self.shape = logt.shape
        C = logt.shape[-1]
        flat = np.ascontiguousarray(logt, dtype=np.float64).reshape(-1, C)
        if C <= 6:
            self.blocks = [(0, C, flat)]
        else:
            self.blocks = [(c, min(c + 6, C), np.ascontiguousarray(flat[:, c : c + 6]))
                           for c in range(0, C, 6)]

    @property
    def array(self) -> np.ndarray:
        """The table, shape (..., C)."""
        if len(self.blocks) == 1:
            return self.blocks[0][2].reshape(self.shape)
        return np.concatenate([b for _, _, b in self.blocks], axis=1).reshape(self.shape)


def gather_numpy(table, h_nodes, th_nodes, mu_nodes, h, mus, mu, cphi, wt, logt=None):
    """``Σ_m wt[n, m, c] S_c(sample)`` → (N, C); ``table`` is (n_h, n_s, n_mu, n_phi, C).

    ``log S`` (:func:`log_table`) is interpolated multilinearly in altitude, ``μ`` and
    ``φ`` and by the cubic through the four nearest nodes (shifted inward at the ends of
    the grid) along the solar zenith angle, then exponentiated.
    """
    n_h, n_s, n_mu, n_phi, C = table.shape
    N, M = h.shape
    logt = log_table(table) if logt is None else logt
    flat = logt.reshape(-1, C)
    i, fi = _locate_numpy(h_nodes, h.ravel())
    th = np.clip(np.arccos(np.clip(mus.ravel(), -1.0, 1.0)), th_nodes[0], th_nodes[-1])
    j, fj = _locate_numpy(th_nodes, th)
    k, fk = _locate_numpy(mu_nodes, mu.ravel())
    xl = np.arccos(np.clip(cphi.ravel(), -1.0, 1.0)) / np.pi * (n_phi - 1)
    m = np.clip(xl.astype(np.intp), 0, n_phi - 2)
    fm = xl - m
    j0 = np.clip(j - 1, 0, n_s - 4)
    x = th_nodes[j] + fj * (th_nodes[j + 1] - th_nodes[j])
    lw = _lagrange4_numpy(np.stack([th_nodes[j0 + q] for q in range(4)]), x)  # (4, K)
    acc = np.zeros((h.size, C))
    for q in range(4):
        for di, wi in ((0, 1 - fi), (1, fi)):
            for dk, wk in ((0, 1 - fk), (1, fk)):
                base = (((i + di) * n_s + (j0 + q)) * n_mu + (k + dk)) * n_phi + m
                w = wi * wk * lw[q]
                acc += flat[base] * (w * (1 - fm))[:, None]
                acc += flat[base + 1] * (w * fm)[:, None]
    return np.einsum("nmc,nmc->nc", wt, np.exp(acc).reshape(N, M, C))


@cache
def _kernels():
    """The compiled kernels (:mod:`._ms_kernels`), imported on first use so that importing
    the package does not import numba; ``None`` without numba (looked up once: the
    field build asks for them per grid cell)."""
    from .._lazy import kernels

    k = kernels("atmoscatter.sky._ms_kernels")
    if k is None:  # pragma: no cover - numba is a declared dependency
        return None
    return {"locate_rows": k._locate_rows, "gather_log": k._gather_log,
            "gather_log6": k._gather_log6,
            "sun_transmittance": k.sun_transmittance, "march_weights": k.march_weights,
            "order1_path": k.order1_path, "order1_located": k.order1_located,
            "locate_geometry": k.locate_geometry,
            "gather_slices": k.gather_slices,
            "gather_slices6": k.gather_slices6,
            "lagrange_inverse_denominators": k.lagrange_inverse_denominators,
            "refine_intervals": k.refine_intervals, "decay_test": k.decay_test}


def have_kernel() -> bool:
    """Whether the compiled kernels are available (numba installed)."""
    return _kernels() is not None


def kernel(name: str):
    """The compiled kernel ``name`` of :mod:`._ms_kernels`, or ``None`` without numba."""
    k = _kernels()
    return None if k is None else k[name]


def gather(table, h_nodes, th_nodes, mu_nodes, h, mus, mu, cphi, wt, *, threads=1, use_kernel=True,
           logt=None):
    """Compiled (or NumPy) gather; same contract as :func:`gather_numpy` (``logt``: the
    table's :func:`log_table`, if already computed)."""
    N, M = h.shape
    C = table.shape[-1]
    logt = log_table(table) if logt is None else logt
    if not use_kernel or N == 0 or not have_kernel():
        arr = logt.array if isinstance(logt, LogTable) else logt
        return gather_numpy(arr, h_nodes, th_nodes, mu_nodes, h, mus, mu, cphi, wt, arr)
    if not isinstance(logt, LogTable):
        logt = LogTable(logt)  # once, not per chunk
    wt = wt.reshape(N, M, C)
    if threads <= 1 or N < 256:
        return Located(table.shape[:4], h_nodes, th_nodes, mu_nodes, h, mus, mu, cphi, wt).gather(logt)
    from concurrent.futures import ThreadPoolExecutor

    step = -(-N // threads)

    def part(a):
        sl = slice(a, min(a + step, N))
        loc = Located(table.shape[:4], h_nodes, th_nodes, mu_nodes, h[sl], mus[sl], mu[sl], cphi[sl],
                      wt[sl])
        return loc.gather(logt)

    with ThreadPoolExecutor(max_workers=threads) as pool:
        return np.concatenate(list(pool.map(part, range(0, N, step))), axis=0)


def pack_weights(wt, N: int, M: int, key=None):
    """``(index, ray, packed)`` of the samples of (N, M, C) weights ``wt`` that are non-zero
    in some channel: flat sample indices (K,), the ray of each (K,) int32 and the packed
    (K, C) weights (see :class:`Located`).  Rays that share their weights (the grid's node
    rays at one altitude, for every solar zenith angle) are packed once.

    ``key`` (N, M) integers, optional: the samples come sorted by it (stable: along each
    ray within equal keys) instead of ray by ray.  The gather adds each ray's samples in
    the order given, so an order changes its sums only at round-off; one that follows the
    table's rows makes its reads nearly sequential."""
    wt = np.asarray(wt).reshape(N, M, -1)
    keep = np.any(wt != 0, axis=-1)
    index = np.flatnonzero(keep)
    if key is not None:
        index = index[np.argsort(np.asarray(key).reshape(-1)[index], kind="stable")]
    ray = (index // max(M, 1)).astype(np.int32)
    return index, ray, np.ascontiguousarray(wt.reshape(N * M, -1)[index])


class Located:
    """Interpolation coordinates and weights of a set of marched samples on one field
    grid, computed once and reused for every order (the node rays of the field are
    gathered again for each order).

    Only the samples whose weight ``wt`` (N, M, C) is non-zero in some channel are kept
    (about half of a node-ray batch: the rays of a batch share one sample count, and
    the shorter ones are padded with empty panels); they contribute exactly nothing to
    the sums, so leaving them out changes no value.  Kept sample ``s`` belongs to ray
    ``ray[s]``: ``base`` (K,) int32 rows, ``frac`` (K, 4) float32 fractions, ``wt`` (K, C)
    weights (dtype of the input; ``packed``: the result of :func:`pack_weights` for
    ``wt``, if already computed — the packed weights are then shared, not copied, and the
    samples keep its order).
    """

    def __init__(self, shape_out, h_nodes, th_nodes, mu_nodes, h, mus, mu, cphi, wt, packed=None):
        n_h, n_s, n_mu, n_phi = shape_out
        self.shape_out = shape_out
        self.th_nodes = np.ascontiguousarray(th_nodes, dtype=np.float64)
        N, M = h.shape
        self.n_rays = N
        if packed is None:
            packed = pack_weights(wt, N, M)
        index, self.ray, self.wt = packed
        K = index.size
        base = np.empty((K, 1), dtype=np.int64)
        frac = np.empty((K, 1, 4))
        nodes = [np.ascontiguousarray(a, dtype=np.float64) for a in (h_nodes, th_nodes, mu_nodes)]
        samples = [np.ascontiguousarray(np.asarray(a, dtype=np.float64).reshape(-1)[index]).reshape(K, 1)
                   for a in (h, mus, mu, cphi)]
        _kernels()["locate_rows"](n_s, n_mu, n_phi, *nodes, *samples, base, frac)
        self.base = base.reshape(K).astype(np.int32)
        self.frac = frac.reshape(K, 4).astype(np.float32)

    def gather(self, logt):
        """``Σ_m wt[n, m, c] exp(log S_c(sample))`` → (N, C) for the log table ``logt``
        (*shape_out, C) of :func:`log_table`, or its :class:`LogTable` (prepared once for
        many gathers)."""
        n_h, n_s, n_mu, n_phi = self.shape_out
        tab = logt if isinstance(logt, LogTable) else LogTable(logt)
        out = np.empty((self.n_rays, tab.shape[-1]))
        k = _kernels()
        for c0, c1, flat in tab.blocks:
            # six channels (two scatterers × RGB, or a slab of a spectral table): the
            # kernel written out for them
            kern = k["gather_log6"] if c1 - c0 == 6 else k["gather_log"]
            kern(flat, n_s, n_mu, n_phi, self.th_nodes, self.ray, self.base, self.frac,
                 self.wt[:, c0:c1], out[:, c0:c1])
        return out

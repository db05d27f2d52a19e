"""Checked log-space table of single scattering (private; ``method="table"`` and the default
for large batches of :func:`atmoscatter.sky.single.single_scattering`).

:class:`_LogSkyTable` tabulates ``log J_g`` over (view zenith, relative azimuth), checks
every cell against the direct graded rule and integrates the directions of failed cells
directly; :func:`_table_radiance` evaluates it (cached per atmosphere, observer and sun) in
chunks over a small thread pool.  :data:`TABLE_FLOOR` is re-exported by
:mod:`atmoscatter.sky.single`.
"""

from __future__ import annotations

import os
import threading
from collections import OrderedDict
from concurrent.futures import ThreadPoolExecutor

import numpy as np

from ._disk_memo import memo_values, table_key, table_meta
from ._single_rules import _evaluate_J, _graded, _graded_cost
from ._sky_table import _TWO_OVER_PI

_N_THREADS = max(1, min(4, os.cpu_count() or 1))


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

    def __init__(self, atm, r0, s, n_u, n_phi, q, tol=None, floor=None, stretch=None,
                 disk_key=None, disk_meta=None):
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
        # disk_key: the node values may come from the persistent cache (bit for bit the
        # computed ones; see _disk_memo), keyed by it, the stretch and the nodes
        J = memo_values("single_scattering_table",
                        None if disk_key is None else (disk_key, self.stretch),
                        self._direct, meta=disk_meta)(v)  # (G, N, nwl)
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
    evaluating one sky in many batches, possibly from several threads, builds it once),
    and their node values across processes through the persistent cache."""
    def build():  # the node values may come from the persistent cache (_disk_memo)
        disk_key = table_key("single_scattering_table", atmosphere, float(r0),
                             [float(x) for x in s], int(n_mu), int(n_phi), int(q))
        return _LogSkyTable(atm, r0, s, n_mu, n_phi, q, disk_key=disk_key,
                            disk_meta=table_meta(atmosphere, r0, s, nodes=[int(n_mu), int(n_phi)]))

    try:
        key = (atmosphere, float(r0), tuple(float(x) for x in s), n_mu, n_phi, q)
        hash(key)
    except TypeError:
        return build()
    with _TABLE_LOCK:
        table = _TABLE_CACHE.get(key)
        if table is None:
            table = build()
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

"""Chebyshev-resampled table of ``J_g(μ, φ)`` for an observer inside a horizontally uniform
atmosphere (private; :class:`_SkyTable`, used by :func:`atmoscatter.multiple_scattering` for
its smooth multiple-scattering part)."""

from __future__ import annotations

import numpy as np

from ._single_rules import _evaluate_J, _graded, _graded_cost


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

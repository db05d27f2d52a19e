"""Private quadrature and ray-geometry kernels for the numerical sky models.

Everything here works in a *perigee coordinate* along a straight ray: for a ray
through a point at distance ``r`` from the planet centre with direction cosine ``mu``
(against the local vertical), ``sigma = t + r mu`` is the signed distance from the
ray's perigee (the point closest to the planet centre), and the distance from the
centre along the ray is ``sqrt(p2 + sigma**2)`` with ``p2 = r**2 (1 - mu**2)`` the
squared impact parameter.  Densities are even in ``sigma``, which the optical-length
integrals exploit.

Numerical guards (named, as in Bruneton 2017):

* impact parameters come from cross products (``|r x d|**2``), not from
  ``r**2 - (r.d)**2``, so they never go negative by cancellation;
* altitudes are clipped to ``[0, top]`` before a profile is evaluated, so no profile is
  ever evaluated inside the planet (where an exponential would overflow);
* quadratic roots use the cancellation-free form ``q = -(b + sign(b) sqrt(D))``.

Nothing here is public API; :mod:`atmoscatter.sky.single` and
:mod:`atmoscatter.sky.multiple` build on it.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import numpy as np

__all__: list[str] = []


# ----------------------------------------------------------------------------------------
# one-dimensional rules on the unit interval
# ----------------------------------------------------------------------------------------
@lru_cache(maxsize=64)
def gauss_legendre_unit(q: int) -> tuple[np.ndarray, np.ndarray]:
    """Gauss–Legendre nodes and weights of order ``q`` on [0, 1]."""
    x, w = np.polynomial.legendre.leggauss(int(q))
    return (x + 1.0) / 2.0, w / 2.0


@lru_cache(maxsize=64)
def integration_matrix_unit(q: int) -> np.ndarray:
    """Matrix ``S`` with ``(S @ f)[k] ≈ ∫_0^{x_k} f`` for ``f`` sampled at the GL nodes ``x_k``.

    ``S = Iv V⁻¹`` where ``V`` is the Legendre Vandermonde matrix at the nodes and ``Iv``
    holds the indefinite integrals of the Legendre polynomials from −1 to each node.
    Exact for polynomials of degree < q.
    """
    leg = np.polynomial.legendre
    x, _ = leg.leggauss(int(q))
    vander = leg.legvander(x, q - 1)
    iv = np.empty((q, q))
    for n in range(q):
        c = np.zeros(q)
        c[n] = 1.0
        iv[:, n] = leg.legval(x, leg.legint(c, lbnd=-1.0))
    return (iv @ np.linalg.inv(vander)) / 2.0


def cumulative_panel_integral(plen: np.ndarray, values: np.ndarray, q: int):
    """Running integral of ``values`` along Gauss–Legendre panels.

    ``plen`` (n, P) are panel lengths and ``values`` (n, P, q) the integrand at each panel's
    q nodes.  Returns ``(cum, total)``: ``cum`` (n, P·q) is the integral from the start of
    the path to every node (whole earlier panels plus the part of the node's own panel,
    via :func:`integration_matrix_unit`), ``total`` (n,) the integral over the whole path.
    """
    smat = integration_matrix_unit(q)
    _, wq = gauss_legendre_unit(q)
    panel = plen * (values @ wq)
    before = np.cumsum(panel, axis=-1) - panel
    inside = plen[..., None] * np.einsum("kj,npj->npk", smat, values)
    n, npan = plen.shape
    return (before[..., None] + inside).reshape(n, npan * q), np.sum(panel, axis=-1)


@lru_cache(maxsize=64)
def power_midpoint_unit(n: int, power: float) -> tuple[np.ndarray, np.ndarray]:
    """Seed 002 non-equidistant midpoint rule: cells ``[(i/n)^p, ((i+1)/n)^p]``.

    The node of each cell is the midpoint of its two ends (as in the seed's pseudo-code,
    ``a + (b - a) * 0.5``) and its weight is the cell length.  ``power=1`` is the uniform
    midpoint rule.
    """
    edges = (np.arange(n + 1) / n) ** power
    return 0.5 * (edges[1:] + edges[:-1]), np.diff(edges)


# ----------------------------------------------------------------------------------------
# atmosphere preparation
# ----------------------------------------------------------------------------------------
@dataclass
class PreparedAtmosphere:
    """Arrays extracted once from an :class:`~atmoscatter.Atmosphere`.

    Constituents sharing one density profile are grouped so that each optical length
    is integrated once per profile.
    """

    planet_radius: float
    top_radius: float
    n_wavelengths: int
    profiles: list
    scales: np.ndarray  # (G,) characteristic lengths [m]
    breakpoints: list  # per group: array of kink altitudes inside (0, top)
    extinction: np.ndarray  # (G, n_wl) [m^-1] at relative density 1
    scatterers: list  # (group index, scattering (n_wl,), phase callable)

    tau_levels: np.ndarray = None  # altitudes [m] where the vertical optical depth is e^j
    grazing_levels: np.ndarray = None  # same for the optical depth of a grazing ray

    def density(self, g: int, altitude: np.ndarray) -> np.ndarray:
        """Relative density of group ``g`` at ``altitude`` [m], clipped to the atmosphere."""
        h = np.clip(altitude, 0.0, self.top_radius - self.planet_radius)
        return np.asarray(self.profiles[g].density(h), dtype=float)

    def scattering_weights(self, cos_theta: np.ndarray) -> np.ndarray:
        """``B_g(ν) = Σ_{i in g} β_s,i p_i(ν)`` [m⁻¹ sr⁻¹], shape (G, ..., n_wl)."""
        out = np.zeros((len(self.profiles),) + cos_theta.shape + (self.n_wavelengths,))
        for g, beta, phase in self.scatterers:
            out[g] += np.asarray(phase(cos_theta), dtype=float)[..., None] * beta
        return out


def prepare_atmosphere(atmosphere) -> PreparedAtmosphere:
    """Group the constituents of ``atmosphere`` by density profile."""
    for attr in ("planet_radius", "top_radius", "constituents", "n_wavelengths"):
        if not hasattr(atmosphere, attr):
            raise TypeError(
                f"atmosphere must be an atmoscatter.Atmosphere (missing .{attr}), "
                f"got {type(atmosphere).__name__}"
            )
    R = float(atmosphere.planet_radius)
    top = float(atmosphere.top_radius)
    nwl = int(atmosphere.n_wavelengths)
    profiles: list = []
    ext: list = []
    scatterers: list = []
    for c in atmosphere.constituents:
        sc = np.asarray(c.scattering_array, dtype=float)
        ex = np.asarray(c.extinction_array, dtype=float)
        if not (np.any(sc > 0) or np.any(ex > 0)):
            continue
        matches = [i for i, p in enumerate(profiles) if p == c.profile]
        if matches:
            g = matches[0]
        else:
            profiles.append(c.profile)
            ext.append(np.zeros(nwl))
            g = len(profiles) - 1
        ext[g] = ext[g] + ex
        if np.any(sc > 0) and c.phase is not None:
            scatterers.append((g, sc, c.phase))
    thickness = top - R
    scales = []
    bps = []
    for p in profiles:
        s = float(getattr(p, "scale", thickness))
        if not np.isfinite(s) or s <= 0:
            s = thickness
        scales.append(min(s, thickness))
        b = np.asarray(getattr(p, "breakpoints", ()), dtype=float).ravel()
        bps.append(np.unique(b[(b > 0) & (b < thickness)]))
    prep = PreparedAtmosphere(
        planet_radius=R,
        top_radius=top,
        n_wavelengths=nwl,
        profiles=profiles,
        scales=np.asarray(scales, dtype=float),
        breakpoints=bps,
        extinction=np.asarray(ext, dtype=float).reshape(len(profiles), nwl),
        scatterers=scatterers,
    )
    prep.tau_levels = _optical_depth_levels(prep)
    # a ray grazing at altitude h has ~ sqrt(2π r/H) times the vertical optical depth above h
    hmin = float(np.min(prep.scales)) if prep.profiles else 1.0
    prep.grazing_levels = _optical_depth_levels(prep, np.sqrt(2.0 * np.pi * R / hmin), 60.0)
    return prep


def _optical_depth_levels(
    atm: PreparedAtmosphere, factor: float = 1.0, tau_max: float = 30.0
) -> np.ndarray:
    """Altitudes where ``factor`` × the vertical optical depth above (largest over
    wavelengths) is ``e^j`` (j = −9 … −1), then ``(1 + k/2)²`` up to ``tau_max``.

    Along any ray the transmittance changes by a factor ~e between consecutive levels,
    wherever the atmosphere is optically thick; making their crossings panel
    boundaries samples a thick atmosphere uniformly in optical depth (where the
    geometric grading alone would put panels of tens of scale heights).
    """
    thick = atm.top_radius - atm.planet_radius
    if not atm.profiles:
        return np.zeros(0)
    hmin = float(np.min(atm.scales))
    n = int(min(20000, max(2000, 40 * thick / hmin)))
    h = thick * (np.linspace(0.0, 1.0, n) ** 1.5)
    k = np.zeros(n)
    for g in range(len(atm.profiles)):
        k = k + atm.density(g, h) * float(np.max(atm.extinction[g]))
    seg = 0.5 * (k[1:] + k[:-1]) * np.diff(h)
    tau_above = factor * np.concatenate([np.cumsum(seg[::-1])[::-1], [0.0]])  # decreasing
    # e-folds up to τ = 1, then steps of ~√τ (the width of the peak of e^{−τ} × growth),
    # up to τ_max (beyond, e^{−τ} < 1e-13 of the light is left)
    targets = np.concatenate([np.exp(np.arange(-9.0, 0.0)), (1.0 + 0.5 * np.arange(0, 40)) ** 2])
    targets = targets[targets <= tau_max]
    targets = targets[(targets < tau_above[0]) & (targets > 0)]
    if targets.size == 0:
        return np.zeros(0)
    # tau_above decreases with h: interpolate h(tau) on the reversed arrays
    return np.interp(targets, tau_above[::-1], h[::-1])


# ----------------------------------------------------------------------------------------
# geometry
# ----------------------------------------------------------------------------------------
def view_segments(r0: float, v: np.ndarray, R: float, top: float):
    """Part of each view ray inside the atmosphere, in perigee coordinates.

    Parameters
    ----------
    r0 : float
        Observer distance from the planet centre [m].
    v : ndarray (N, 3)
        Unit view directions in the observer's local frame (z up).

    Returns
    -------
    p2 : (N,) squared impact parameter [m²]
    s0 : (N,) perigee coordinate of the observer [m]
    sa, sb : (N,) perigee coordinates of the start and end of the lit-or-not path [m];
        ``sa == sb`` where the ray misses the atmosphere.
    """
    mu = v[:, 2]
    p2 = r0 * r0 * (v[:, 0] ** 2 + v[:, 1] ** 2)
    s0 = r0 * mu
    s_top = np.sqrt(np.maximum(top * top - p2, 0.0))
    hits_ground = (mu < 0.0) & (p2 < R * R)
    s_ground = -np.sqrt(np.maximum(R * R - p2, 0.0))
    if r0 <= R:
        # observer on the ground (or numerically below it): downward rays end at once
        hits_ground = mu < 0.0
    if r0 <= top:
        sa = s0.copy()
        s_ground = np.where(hits_ground & (r0 <= R), s0, s_ground)
        sb = np.where(hits_ground, s_ground, s_top)
        sb = np.maximum(sb, sa)
    else:
        enters = (s0 < 0.0) & (p2 < top * top)
        sa = np.where(enters, -s_top, s0)
        sb = np.where(enters, np.where(hits_ground, s_ground, s_top), s0)
        sb = np.maximum(sb, sa)
    return p2, s0, sa, sb


def shadow_interval(r0: float, v: np.ndarray, s: np.ndarray, R: float):
    """Interval of ``t`` along each view ray where the planet hides the sun.

    The shadow is the half-cylinder ``|P x s| < R`` and ``P.s < 0`` behind the planet.
    Returns ``(lo, hi)`` in ``t`` (possibly infinite); ``lo >= hi`` means no shadow.
    """
    zxs = np.array([-s[1], s[0], 0.0])  # z x s
    vxs = np.cross(v, s)
    nu = v @ s
    a = np.einsum("ij,ij->i", vxs, vxs)
    b = r0 * (vxs @ zxs)
    c = r0 * r0 * float(zxs @ zxs) - R * R
    disc = b * b - a * c
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        sq = np.sqrt(np.maximum(disc, 0.0))
        qq = -(b + np.where(b >= 0, sq, -sq))
        t1 = qq / a
        t2 = c / qq
    lo_c = np.minimum(t1, t2)
    hi_c = np.maximum(t1, t2)
    degenerate = a <= 1e-14
    # a ~ 0: v parallel to the sun direction; inside the cylinder for all t iff c < 0
    lo_c = np.where(degenerate, np.where(c < 0, -np.inf, np.inf), lo_c)
    hi_c = np.where(degenerate, np.where(c < 0, np.inf, -np.inf), hi_c)
    none = (~degenerate) & ((disc <= 0) | ~np.isfinite(lo_c) | ~np.isfinite(hi_c))
    lo_c = np.where(none, np.inf, lo_c)
    hi_c = np.where(none, -np.inf, hi_c)
    # half-space P.s < 0:  r0 s_z + t nu < 0
    with np.errstate(divide="ignore", invalid="ignore"):
        tc = -r0 * s[2] / nu
    lo_h = np.where(nu > 0, -np.inf, np.where(nu < 0, tc, np.where(s[2] < 0, -np.inf, np.inf)))
    hi_h = np.where(nu > 0, tc, np.where(nu < 0, np.inf, np.where(s[2] < 0, np.inf, -np.inf)))
    return np.maximum(lo_c, lo_h), np.minimum(hi_c, hi_h)


def geometric_offsets(m: int, k: int) -> np.ndarray:
    """Offsets ``d_j`` (j = 0..k) of a geometric panel grading, in units of the first scale.

    ``d_j = (ρ^j − 1)/(ρ − 1)/m`` with ``ρ = 2^{1/m}``: the first panel is ``1/m`` long and
    each next one is ``ρ`` times longer (``m`` panels per doubling).
    """
    rho = 2.0 ** (1.0 / m)
    j = np.arange(k + 1, dtype=float)
    return (rho**j - 1.0) / (rho - 1.0) / m


def n_geometric_panels(span_over_scale: float, m: int) -> int:
    """Number of graded panels needed to cover ``span_over_scale`` first scales."""
    rho = 2.0 ** (1.0 / m)
    x = max(float(span_over_scale), 0.0) * (rho - 1.0) * m + 1.0
    return int(np.clip(np.ceil(np.log(x) / np.log(rho)), 1, 80 * m))


def local_scale(H: float, sigma: np.ndarray, p2: np.ndarray) -> np.ndarray:
    """Length along a ray over which a density of scale height ``H`` changes by ~e.

    At perigee coordinate ``sigma`` the altitude grows like ``|sigma|/r`` per metre and
    curves by ``1/r``: the scale is ``H / (|sigma|/r + sqrt(2H/r))`` (``H/mu`` far from the
    perigee, ``sqrt(rH/2)`` at it).
    """
    r = np.sqrt(p2 + sigma * sigma)
    r = np.maximum(r, H)
    return H / (np.abs(sigma) / r + np.sqrt(2.0 * H / r))


def compact_bounds(bounds: np.ndarray, rel: float = 1e-12) -> np.ndarray:
    """Drop repeated boundaries of sorted ``bounds`` (..., nb) as far as the batch allows.

    Interior boundaries closer than ``rel`` × the row's span (or a few ulp of its
    magnitude) to their predecessor or to the last boundary are moved to the end (as
    copies of the last boundary) and the array is cut to the largest number of distinct
    boundaries in the batch, so no work is spent on empty panels.  The first and the last
    boundary are always kept: the panels cover exactly the original interval.  (The
    tolerance is relative to the span, not to the perigee coordinates themselves: on a
    very large planet those are ~1e12 m and a tolerance relative to them dropped the last
    0.7 m of a 10 km path — 0.4 % of a grazing-sun slab's single scattering.)
    """
    if bounds.shape[-1] <= 2:
        return bounds
    first = bounds[..., :1]
    last = bounds[..., -1:]
    scale = np.maximum((last - first) * rel, np.abs(last) * 4.0 * np.finfo(float).eps)
    dup = np.zeros(bounds.shape, dtype=bool)
    inner = bounds[..., 1:-1]
    dup[..., 1:-1] = ((inner - bounds[..., :-2]) <= scale) | ((last - inner) <= scale)
    key = np.where(dup, np.inf, bounds)
    key = np.sort(key, axis=-1)
    n = int(np.max(np.sum(~dup, axis=-1)))
    n = max(n, 2)
    key = key[..., :n]
    return np.where(np.isfinite(key), key, last)


def panel_rule(bounds: np.ndarray, q: int):
    """Composite GL nodes and weights from sorted panel boundaries ``(..., nb)``.

    Returns nodes and weights of shape ``(..., (nb - 1) * q)`` (panels in order).
    """
    x, w = gauss_legendre_unit(q)
    a = bounds[..., :-1, None]
    length = np.diff(bounds, axis=-1)[..., None]
    nodes = a + length * x
    weights = length * w
    shp = bounds.shape[:-1] + (-1,)
    return nodes.reshape(shp), weights.reshape(shp), length[..., 0]


# ----------------------------------------------------------------------------------------
# optical length along a ray to the top of the atmosphere (graded composite GL)
# ----------------------------------------------------------------------------------------
def optical_length_to_top(
    atm: PreparedAtmosphere, g: int, p2: np.ndarray, sig: np.ndarray, q: int, m: int
) -> np.ndarray:
    """Optical length [m] of profile group ``g`` from a point to the top of the atmosphere.

    The ray is given by its squared impact parameter ``p2`` and the perigee coordinate
    ``sig`` of its start (any shape; the caller guarantees the ray does not hit the
    ground).  If ``sig < 0`` the ray first descends to its perigee: by symmetry
    ``∫_sig^top = 2 ∫_0^{|sig|} + ∫_{|sig|}^top``, so one graded rule from
    ``max(sig, 0)`` covers both parts.  Panels grow geometrically from the lowest point
    (``m`` per doubling, first one the local density scale), and extra panel boundaries
    sit where the ray crosses the profile's breakpoints; each panel gets ``q`` GL nodes.
    """
    R = atm.planet_radius
    top = atm.top_radius
    H = float(atm.scales[g])
    lo = np.maximum(sig, 0.0)
    hi = np.sqrt(np.maximum(top * top - p2, 0.0))
    hi = np.maximum(hi, lo)
    ell = local_scale(H, lo, p2)
    span = float(np.max((hi - lo) / ell)) if lo.size else 0.0
    k = n_geometric_panels(span, m)
    d = geometric_offsets(m, k)
    cuts = [lo[..., None] + ell[..., None] * d, np.abs(sig)[..., None]]
    bp = atm.breakpoints[g]
    if bp.size:
        rb = R + bp
        cuts.append(np.sqrt(np.maximum(rb * rb - p2[..., None], 0.0)))
    bounds = np.concatenate(cuts, axis=-1)
    bounds = np.sort(np.clip(bounds, lo[..., None], hi[..., None]), axis=-1)
    bounds = np.concatenate([lo[..., None], bounds, hi[..., None]], axis=-1)
    nodes, weights, _ = panel_rule(compact_bounds(bounds), q)
    weights = np.where((sig[..., None] < 0) & (nodes < -sig[..., None]), 2.0 * weights, weights)
    h = np.sqrt(p2[..., None] + nodes * nodes) - R
    return np.sum(weights * atm.density(g, h), axis=-1)


def optical_length_rule(
    atm: PreparedAtmosphere, g: int, p2: np.ndarray, s_from: np.ndarray, s_to: np.ndarray,
    x: np.ndarray, w: np.ndarray,
) -> np.ndarray:
    """Optical length [m] of group ``g`` on ``[s_from, s_to]`` with a fixed unit rule (x, w)."""
    length = (s_to - s_from)[..., None]
    nodes = s_from[..., None] + length * x
    h = np.sqrt(p2[..., None] + nodes * nodes) - atm.planet_radius
    return np.sum(length * w * atm.density(g, h), axis=-1)

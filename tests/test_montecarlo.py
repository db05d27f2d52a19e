"""Independent Monte Carlo validation of single and multiple scattering (issue 5).

``_mc_radiance`` is a small vectorised backward path tracer written only for these
tests: delta (Woodcock) tracking in the spherical atmosphere with a majorant extinction,
next-event estimation toward the sun at every real collision and every ground hit
(transmittance from the foundation's exact :func:`atmoscatter.optical_length`, planet
shadow by a ray–sphere test), phase sampling (Henyey–Greenstein by inversion, Rayleigh
by rejection), Lambertian ground by cosine sampling.  Contributions are tallied per
scattering order (a ground reflection counts as one), so a run truncated at ``K`` orders
estimates exactly what ``multiple_scattering(..., orders=K)`` computes.  Fixed seeds.
"""

from __future__ import annotations

import numpy as np
import pytest

import atmoscatter as ac
from atmoscatter.sky.multiple import multiple_scattering
from atmoscatter.sky.single import single_scattering


def _sample_phase(phase, mu_dummy, rng, n):
    if isinstance(phase, ac.HenyeyGreensteinPhase):
        g = phase.g
        xi = rng.random(n)
        if abs(g) < 1e-6:
            return 2 * xi - 1
        s = (1 - g * g) / (1 - g + 2 * g * xi)
        return np.clip((1 + g * g - s * s) / (2 * g), -1, 1)
    if isinstance(phase, ac.RayleighPhase):
        out = np.empty(n)
        todo = np.arange(n)
        while todo.size:
            mu = 2 * rng.random(todo.size) - 1
            ok = rng.random(todo.size) < (1 + mu * mu) / 2
            out[todo[ok]] = mu[ok]
            todo = todo[~ok]
        return out
    if isinstance(phase, ac.IsotropicPhase):
        return 2 * rng.random(n) - 1
    raise NotImplementedError(type(phase))


def _rotate(d, cos_t, rng):
    """Directions at angle acos(cos_t) from unit vectors d, uniform azimuth."""
    phi = 2 * np.pi * rng.random(len(d))
    sin_t = np.sqrt(np.maximum(1 - cos_t * cos_t, 0))
    a = np.where(np.abs(d[:, [0]]) < 0.9, np.array([[1.0, 0, 0]]), np.array([[0, 1.0, 0]]))
    u = np.cross(d, a)
    u /= np.linalg.norm(u, axis=1)[:, None]
    w = np.cross(d, u)
    return (cos_t[:, None] * d + (sin_t * np.cos(phi))[:, None] * u
            + (sin_t * np.sin(phi))[:, None] * w)


def _scatter(d, sca, sca_tot, cons, rng):
    """New directions after a real collision: choose the species by its share of the
    scattering coefficient, then a direction from its phase function."""
    u = rng.random(len(d)) * sca_tot
    cum = np.zeros(len(d))
    new_d = d.copy()
    for sr, c in zip(sca, cons, strict=True):
        pick = (u >= cum) & (u < cum + sr)
        cum += sr
        if np.any(pick):
            cos_t = _sample_phase(c.phase, None, rng, int(pick.sum()))
            new_d[pick] = _rotate(d[pick], cos_t, rng)
    return new_d


def _enter_atmosphere(pos, d, alive, altitude, R, top):
    """For an observer in space, move the paths to where their ray enters the atmosphere
    (in place) and keep only those that enter; otherwise ``alive`` unchanged."""
    if altitude <= top - R:
        return alive
    near, _ = _exit_distance(pos, d, top)
    hit = np.isfinite(near) & (near > 0)
    pos[hit] += near[hit, None] * d[hit]
    return alive[hit]


def _exit_distance(pos, d, radius):
    b = np.einsum("ij,ij->i", pos, d)
    c = np.einsum("ij,ij->i", pos, pos) - radius * radius
    disc = b * b - c
    ok = disc >= 0
    sq = np.sqrt(np.where(ok, disc, 0))
    return np.where(ok, -b - sq, np.inf), np.where(ok, -b + sq, -np.inf)


def _mc_radiance(atm, view, sun, altitude, n_paths, max_order, albedo, seed):
    """Per-order mean radiance [sr^-1] (max_order, n_wl=1) and its standard error."""
    assert atm.n_wavelengths == 1
    R, top = atm.planet_radius, atm.top_radius
    rng = np.random.default_rng(seed)
    cons = [c for c in atm.constituents if c.extinction_array[0] > 0]
    hs = np.linspace(0, top - R, 20001)
    beta_max = 1.01 * np.max(sum(c.extinction_array[0] * c.profile.density(hs) for c in cons))
    sun = np.asarray(sun, float) / np.linalg.norm(sun)

    def coeffs(h):
        ext = sum(c.extinction_array[0] * c.profile.density(h) for c in cons)
        sca = [c.scattering_array[0] * c.profile.density(h) for c in cons]
        return ext, sca

    def t_sun(pos):
        r = np.linalg.norm(pos, axis=1)
        mu_s = np.einsum("ij,j->i", pos, sun) / r
        near, _ = _exit_distance(pos, np.broadcast_to(sun, pos.shape), R)
        # a sun ray whose line misses the planet (near = inf) is lit: without isfinite
        # every point of a low-sun (sunset) geometry with r·sin θ_s > R was shadowed
        shadow = np.isfinite(near) & (near > 0)
        tau = np.zeros(len(pos))
        for c in cons:
            tau += c.extinction_array[0] * ac.optical_length(
                c.profile, np.maximum(r - R, 0), mu_s, planet_radius=R, top_radius=top)
        return np.where(shadow, 0.0, np.exp(-tau)), mu_s

    pos = np.tile([0.0, 0.0, R + altitude], (n_paths, 1))
    d = np.tile(np.asarray(view, float) / np.linalg.norm(view), (n_paths, 1))
    w = np.ones(n_paths)
    k = np.zeros(n_paths, dtype=int)
    tally = np.zeros((max_order, n_paths))
    alive = np.arange(n_paths)
    alive = _enter_atmosphere(pos, d, alive, altitude, R, top)
    while alive.size:
        p, dd = pos[alive], d[alive]
        g_near, _ = _exit_distance(p, dd, R)
        g_dist = np.where((g_near > 1e-9), g_near, np.inf)
        _, t_top = _exit_distance(p, dd, top)
        t_top = np.maximum(t_top, 0)
        step = -np.log(rng.random(alive.size)) / beta_max
        ground = (g_dist < t_top) & (step >= g_dist)
        escape = (~ground) & (step >= t_top)
        coll = ~(ground | escape)
        # ground hits: NEE + Lambertian bounce (not for the observer's own ray: path radiance)
        gi = alive[ground & (k[alive] > 0)] if albedo > 0 else alive[:0]
        if gi.size:
            gp = pos[gi] + g_dist[np.isin(alive, gi)][:, None] * d[gi]
            gp *= R / np.linalg.norm(gp, axis=1)[:, None]
            ts, mu_s = t_sun(gp)
            k[gi] += 1
            tally[np.minimum(k[gi], max_order) - 1, gi] += w[gi] * albedo / np.pi * np.maximum(mu_s, 0) * ts
            up = gp / R
            cos_t = np.sqrt(rng.random(gi.size))
            pos[gi] = gp * (1 + 1e-12)
            d[gi] = _rotate(up, cos_t, rng)
            w[gi] *= albedo
        dead = alive[escape | (ground & ~np.isin(alive, gi))]
        ci = alive[coll]
        pos[ci] = pos[ci] + step[coll, None] * d[ci]
        h = np.linalg.norm(pos[ci], axis=1) - R
        ext, sca = coeffs(h)
        real = rng.random(ci.size) < ext / beta_max
        ri = ci[real]
        if ri.size:
            ext_r = ext[real]
            sca_r = [x[real] for x in sca]
            ts, _ = t_sun(pos[ri])
            mu_view = d[ri] @ sun
            f = sum(sr * np.asarray(c.phase(mu_view)) for sr, c in zip(sca_r, cons, strict=True))
            k[ri] += 1
            tally[k[ri] - 1, ri] += w[ri] * f * ts / ext_r
            sca_tot = sum(sca_r)
            w[ri] *= sca_tot / ext_r
            d[ri] = _scatter(d[ri], sca_r, sca_tot, cons, rng)
        finished = np.concatenate([dead, ri[k[ri] >= max_order], gi[k[gi] >= max_order]])
        alive = np.setdiff1d(alive, finished)
    mean = tally.mean(axis=1)
    return mean, tally.std(axis=1, ddof=1) / np.sqrt(n_paths), tally.sum(axis=0)


def _atm(scale=1.0, g=0.8, wl=440.0):
    return ac.Atmosphere(6.36e6, 6.42e6, (wl,), (
        ac.Constituent("air", 3.31e-5 * scale, 0.0, ac.ExponentialProfile(8000.0), ac.RayleighPhase()),
        ac.Constituent("haze", 4.0e-6 * scale, 4.4e-7 * scale, ac.ExponentialProfile(1200.0),
                       ac.HenyeyGreensteinPhase(g)),
    ))


def _dir(z, a):
    z, a = np.radians(z), np.radians(a)
    return np.array([np.sin(z) * np.sin(a), np.sin(z) * np.cos(a), np.cos(z)])


def test_mc_order1_matches_single_scattering():
    """The tracer's first order reproduces the quadrature: validates the tracer itself."""
    atm = _atm()
    s = _dir(60, 180)
    for v in (_dir(0, 0), _dir(75, 30)):
        mean, err, _ = _mc_radiance(atm, v, s, 0.0, 20000, 1, 0.0, seed=1)
        ref = single_scattering(atm, v, s, method="reference")[0]
        assert abs(mean[0] - ref) < 4 * err[0]


# Stated accuracy of multiple_scattering's orders >= 2 (grid discretisation), as a fraction
# of the multiple-scattering part; docs/numerical_scattering.md quotes the measured values.
_MS_PART_TOL = 0.03


@pytest.mark.parametrize(
    "scale, albedo, orders, view",
    [
        (1.0, 0.3, 6, (0.0, 0.0)),      # thin (tau ~ 0.3 at 440 nm), bright ground
        (1.0, 0.3, 6, (85.0, 180.0)),   # thin, near the horizon toward the sun
        # the thick field costs ~15 s to build: CI's extended step (DISORT covers thick
        # layers in the default run)
        pytest.param(10.0, 0.0, 8, (0.0, 0.0), marks=pytest.mark.extended),    # thick (tau ~ 3), zenith
        pytest.param(10.0, 0.0, 8, (75.0, 30.0), marks=pytest.mark.extended),  # thick, low sky
    ],
)
def test_multiple_scattering_matches_monte_carlo(scale, albedo, orders, view):
    atm = _atm(scale)
    s = _dir(60, 180)
    v = _dir(*view)
    mean, _, per_path = _mc_radiance(atm, v, s, 0.0, 20000, orders, albedo, seed=7)
    sigma = per_path.std(ddof=1) / np.sqrt(per_path.size)
    ms = multiple_scattering(atm, v, s, orders=orders, ground_albedo=albedo)[0]
    ms_part = mean[1:].sum()
    assert ms_part > 0.05 * mean.sum()  # the case really tests multiple scattering
    assert abs(ms - mean.sum()) <= 3 * sigma + _MS_PART_TOL * ms_part


# ----------------------------------------------------------------------------------------
# Sunset and twilight on a spherical planet (issue 10, part 3)
# ----------------------------------------------------------------------------------------
# The tracer below differs from _mc_radiance in two ways that make twilight affordable,
# neither of which uses the package's multiple-scattering code:
#
# * next-event estimation at every *tentative* (real or null) collision of the delta
#   tracking, weighted by 1/β_maj: the tentative points form a Poisson process of rate
#   β_maj along the ray and the walk survives to each with probability T(x), so
#   Σ_i f(x_i)/β_maj estimates ∫ T(x) f(x) dx without bias, with ~β_maj·L samples per ray
#   instead of ~τ.  Lit regions high above a shadowed observer are sampled on every pass;
# * the sun transmittance comes from a table of ac.optical_length over (altitude, μ_s ≥ 0)
#   (one per atmosphere), interpolated log-linearly.  Sun below the local horizon: the
#   ray passes a perigee at radius p = r·sqrt(1 − μ_s²); shadow if p < R, otherwise
#   τ = 2 τ(h_p, 0) − τ(h, −μ_s) (the path is symmetric about the perigee).
#   test_sun_table_matches_optical_length checks the table against direct calls.
def _sun_tau_table(atm, n_h=241, n_x=241):
    R, top = atm.planet_radius, atm.top_radius
    key = (atm, n_h, n_x)
    if key in _SUN_TABLES:
        return _SUN_TABLES[key]
    h_nodes = (top - R - 1.0) * (np.arange(n_h) / (n_h - 1)) ** 1.5
    x_nodes = np.linspace(0.0, 1.0, n_x)  # μ = x²
    hh, xx = np.meshgrid(h_nodes, x_nodes, indexing="ij")
    tau = np.zeros(hh.shape)
    for c in atm.constituents:
        if c.extinction_array[0] > 0:
            tau += c.extinction_array[0] * ac.optical_length(
                c.profile, hh, xx * xx, planet_radius=R, top_radius=top)
    table = (h_nodes, x_nodes, np.log(np.maximum(tau, 1e-300)))
    _SUN_TABLES[key] = table
    return table


_SUN_TABLES: dict = {}


def _interp_tau(table, h, mu):
    h_nodes, x_nodes, logt = table
    hh = np.clip(h, 0.0, h_nodes[-1])
    i = np.clip(np.searchsorted(h_nodes, hh) - 1, 0, h_nodes.size - 2)
    fi = (hh - h_nodes[i]) / (h_nodes[i + 1] - h_nodes[i])
    x = np.sqrt(np.clip(mu, 0.0, 1.0))
    xs = x * (x_nodes.size - 1)
    j = np.clip(xs.astype(int), 0, x_nodes.size - 2)
    fj = xs - j
    v = ((1 - fi) * (1 - fj) * logt[i, j] + fi * (1 - fj) * logt[i + 1, j]
         + (1 - fi) * fj * logt[i, j + 1] + fi * fj * logt[i + 1, j + 1])
    return np.exp(v)


def _sun_transmittance(atm, table, pos, sun):
    R = atm.planet_radius
    r = np.linalg.norm(pos, axis=1)
    h = r - R
    mu_s = np.clip(pos @ sun / r, -1.0, 1.0)
    below = mu_s < 0
    p = r * np.sqrt(np.maximum(1.0 - mu_s * mu_s, 0.0))
    tau = _interp_tau(table, h, np.abs(mu_s))
    tau_p = _interp_tau(table, p - R, np.zeros_like(p))
    tau = np.where(below, 2.0 * tau_p - tau, tau)
    return np.where(below & (p < R), 0.0, np.exp(-tau))


def _mc_twilight(atm, view, sun, altitude, n_paths, max_order, seed, majorant=2.0):
    """Black-ground path radiance [sr^-1] by delta tracking with tentative-collision NEE.

    Returns (total, sigma_total, ms, sigma_ms) with ms = orders 2..max_order.
    """
    assert atm.n_wavelengths == 1
    R, top = atm.planet_radius, atm.top_radius
    rng = np.random.default_rng(seed)
    table = _sun_tau_table(atm)
    cons = [c for c in atm.constituents if c.extinction_array[0] > 0]
    hs = np.linspace(0, top - R, 20001)
    beta_maj = majorant * np.max(sum(c.extinction_array[0] * c.profile.density(hs) for c in cons))
    sun = np.asarray(sun, float) / np.linalg.norm(sun)
    pos = np.tile([0.0, 0.0, R + altitude], (n_paths, 1))
    d = np.tile(np.asarray(view, float) / np.linalg.norm(view), (n_paths, 1))
    w = np.ones(n_paths)
    k = np.zeros(n_paths, dtype=int)
    first = np.zeros(n_paths)
    rest = np.zeros(n_paths)
    alive = np.arange(n_paths)
    alive = _enter_atmosphere(pos, d, alive, altitude, R, top)
    while alive.size:
        p, dd = pos[alive], d[alive]
        g_near, _ = _exit_distance(p, dd, R)
        g_dist = np.where(g_near > 1e-9, g_near, np.inf)
        _, t_top = _exit_distance(p, dd, top)
        end = np.minimum(np.maximum(t_top, 0.0), g_dist)
        step = -np.log(rng.random(alive.size)) / beta_maj
        inside = step < end
        ci = alive[inside]
        pos[ci] += step[inside, None] * d[ci]
        h = np.linalg.norm(pos[ci], axis=1) - R
        sca = [c.scattering_array[0] * c.profile.density(h) for c in cons]
        ext = sum(c.extinction_array[0] * c.profile.density(h) for c in cons)
        mu_view = d[ci] @ sun
        f = sum(s * np.asarray(c.phase(mu_view)) for s, c in zip(sca, cons, strict=True))
        contrib = w[ci] * f * _sun_transmittance(atm, table, pos[ci], sun) / beta_maj
        is1 = k[ci] == 0
        first[ci[is1]] += contrib[is1]
        rest[ci[~is1]] += contrib[~is1]
        real = rng.random(ci.size) < ext / beta_maj
        ri = ci[real]
        if ri.size:
            sca_r = [s[real] for s in sca]
            sca_tot = sum(sca_r)
            w[ri] *= sca_tot / ext[real]
            k[ri] += 1
            d[ri] = _scatter(d[ri], sca_r, sca_tot, cons, rng)
        done = np.concatenate([alive[~inside], ri[k[ri] >= max_order]])
        alive = np.setdiff1d(alive, done)
    total = first + rest
    n = n_paths
    return (total.mean(), total.std(ddof=1) / np.sqrt(n), rest.mean(), rest.std(ddof=1) / np.sqrt(n))


def _twilight_atm():
    """Rayleigh (440 nm, H = 8 km, τ ≈ 0.26) + haze (H = 1.2 km, τ ≈ 0.11, ω = 0.9, g = 0.8)."""
    return ac.Atmosphere(6.36e6, 6.42e6, (440.0,), (
        ac.Constituent("air", 3.31e-5, 0.0, ac.ExponentialProfile(8000.0), ac.RayleighPhase()),
        ac.Constituent("haze", 8.0e-5, 8.9e-6, ac.ExponentialProfile(1200.0),
                       ac.HenyeyGreensteinPhase(0.8)),
    ))


def test_sun_table_matches_optical_length():
    """The tabulated sun transmittance against direct ac.optical_length calls (incl. shadow)."""
    atm = _twilight_atm()
    table = _sun_tau_table(atm)
    rng = np.random.default_rng(0)
    n = 3000
    R, top = atm.planet_radius, atm.top_radius
    h = (top - R) * rng.random(n) ** 2
    mu = np.concatenate([rng.uniform(-0.2, 0.2, n // 2), rng.uniform(-0.6, 1.0, n - n // 2)])
    pos = np.stack([np.zeros(n), np.zeros(n), R + h], -1)
    t_tab = np.array([_sun_transmittance(atm, table, pos[i:i + 1],
                                         np.array([np.sqrt(1 - mu[i] ** 2), 0.0, mu[i]]))[0]
                      for i in range(n)])
    tau = sum(c.extinction_array[0] * ac.optical_length(c.profile, h, mu, planet_radius=R,
                                                        top_radius=top) for c in atm.constituents)
    shadow = (mu < 0) & ((R + h) * np.sqrt(1 - mu * mu) < R)
    t_dir = np.where(shadow, 0.0, np.exp(-tau))
    # measured here: max |ΔT| 5e-5, max relative 7e-4 where T > 1e-3 — far below the 1 %
    # tolerance of the comparisons it feeds
    assert np.max(np.abs(t_tab - t_dir)) < 2e-4
    assert np.max(np.abs(t_tab - t_dir)[t_dir > 1e-3] / t_dir[t_dir > 1e-3]) < 2e-3


@pytest.mark.parametrize("elev, view, alt", [(2.0, (85.0, 180.0), 0.0), (-6.0, (80.0, 90.0), 12e3)])
def test_twilight_tracer_order1_matches_single_scattering(elev, view, alt):
    """Validates the twilight tracer: its first order equals the exact quadrature."""
    atm = _twilight_atm()
    s, v = _dir(90.0 - elev, 180.0), _dir(*view)
    mean, err, _, _ = _mc_twilight(atm, v, s, alt, 8000, 1, seed=11)
    ref = single_scattering(atm, v, s, altitude=alt, method="reference")[0]
    assert abs(mean - ref) < 4 * err


_R_EARTH = 6.36e6
_ALT_SPACE = 500e3
_LIMB_ZENITH = 180.0 - np.degrees(np.arcsin((_R_EARTH + 15e3) / (_R_EARTH + _ALT_SPACE)))
_VIEWS = {  # name: (observer altitude [m], (view zenith, azimuth) [deg]); the sun is at azimuth 180
    "ground-zenith": (0.0, (0.0, 0.0)),
    "ground-sun-85": (0.0, (85.0, 180.0)),
    "ground-antisun-85": (0.0, (85.0, 0.0)),
    "12km-80deg-side": (12e3, (80.0, 90.0)),
    "space-500km-limb-15km": (_ALT_SPACE, (_LIMB_ZENITH, 90.0)),
}


def _twilight_tol(elev):
    # issue 10: 1 % of the total (and 3 % of the MS part) down to sun −6°, 3 % down to −12°
    return (0.01, 0.03) if elev >= -6.0 else (0.03, None)


# per-path relative standard deviation of the total, measured with 4000 paths (seed 1)
# on the 2-core VM; used only to size n_paths so that 3σ ≤ tol (asserted in the test)
_PER_PATH_RSD = {
    (2.0, "ground-zenith"): 1.3, (2.0, "ground-sun-85"): 1.3, (2.0, "ground-antisun-85"): 1.6,
    (2.0, "12km-80deg-side"): 0.60, (2.0, "space-500km-limb-15km"): 0.65,
    (0.0, "ground-zenith"): 1.4, (0.0, "ground-sun-85"): 1.9, (0.0, "ground-antisun-85"): 2.0,
    (0.0, "12km-80deg-side"): 0.60, (0.0, "space-500km-limb-15km"): 0.60,
    (-6.0, "ground-zenith"): 9.7, (-6.0, "ground-sun-85"): 4.3, (-6.0, "ground-antisun-85"): 24.0,
    (-6.0, "12km-80deg-side"): 8.4, (-6.0, "space-500km-limb-15km"): 4.5,
    (-10.0, "ground-zenith"): 45.0, (-10.0, "ground-sun-85"): 13.0,
    (-10.0, "ground-antisun-85"): 57.0, (-10.0, "12km-80deg-side"): 36.0,
    (-10.0, "space-500km-limb-15km"): 30.0,
}
_QUICK = {(2.0, "12km-80deg-side"), (0.0, "12km-80deg-side")}
_MAX_PATHS = 4_000_000


def _twilight_case(elev, name, n_paths, seed=21):
    atm = _twilight_atm()
    alt, view = _VIEWS[name]
    s, v = _dir(90.0 - elev, 180.0), _dir(*view)
    mc, sig, mc_ms, sig_ms = _mc_twilight(atm, v, s, alt, n_paths, 50, seed=seed)
    ours = float(multiple_scattering(atm, v, s, altitude=alt)[0])
    ours1 = float(multiple_scattering(atm, v, s, altitude=alt, orders=1)[0])
    return mc, sig, mc_ms, sig_ms, ours, ours1


def _n_paths(elev, name):
    tol = _twilight_tol(elev)[0]
    need = int((3.0 * _PER_PATH_RSD[elev, name] / tol) ** 2 * 1.5)  # 3σ ≤ tol, 50 % margin
    return min(need, 60_000 if (elev, name) in _QUICK else _MAX_PATHS)


@pytest.mark.parametrize(
    "elev, name",
    [pytest.param(e, n, id=f"sun{e:+.0f}deg-{n}", marks=[] if (e, n) in _QUICK else [pytest.mark.slow])
     for e in (2.0, 0.0, -6.0, -10.0) for n in _VIEWS],
)
def test_sunset_twilight_against_monte_carlo(elev, name):
    """Sunset / twilight sky (sun +2°, 0°, −6°, −10°) on an Earth-sized planet, black ground.

    Reference: the independent tracer ``_mc_twilight`` (50 orders; Rayleigh + haze,
    ``_twilight_atm``).  Requirement (issue 10): |ours − mc| ≤ 3σ + tol·mc with tol = 1 %
    down to −6° (and 3 % of the multiple-scattering part, orders ≥ 2) and 3 % below.  The
    test first asserts that the Monte Carlo is precise enough to fail at that tolerance
    (3σ ≤ tol·mc).  Quick CI variants: the 12 km observer at sun +2° and 0° (~20 s each);
    the others are ``slow`` (n_paths sized from the measured per-path spread, capped at
    4e6 — if the cap is hit the precision assertion says so).
    """
    tol, tol_ms = _twilight_tol(elev)
    n = _n_paths(elev, name)
    mc, sig, mc_ms, sig_ms, ours, ours1 = _twilight_case(elev, name, n)
    assert 3 * sig <= tol * mc, (
        f"Monte Carlo too noisy to test {tol:.0%}: 3σ/mc = {3 * sig / mc:.4f} with {n} paths")
    assert abs(ours - mc) <= 3 * sig + tol * mc, (
        f"total: ours/mc = {ours / mc:.4f} ± {sig / mc:.4f} (1σ), allowed {tol:.0%}")
    if tol_ms is not None and (elev, name) not in _QUICK:
        assert 3 * sig_ms <= tol_ms * mc_ms, f"MS part too noisy: 3σ/ms = {3 * sig_ms / mc_ms:.3f}"
        assert abs((ours - ours1) - mc_ms) <= 3 * sig_ms + tol_ms * mc_ms, (
            f"MS part: ours/mc = {(ours - ours1) / mc_ms:.4f} ± {sig_ms / mc_ms:.4f} (1σ)")


def twilight_table(scale=1.0, cases=None):
    """(case, mc, ours, ratio, σ_rel, ms ratio, σ_ms_rel) rows for scripts/ms_reference_check.py."""
    rows = []
    for (elev, name) in cases or _PER_PATH_RSD:
        n = max(2000, int(_n_paths(elev, name) * scale))
        mc, sig, mc_ms, sig_ms, ours, ours1 = _twilight_case(elev, name, n)
        rows.append((f"sun{elev:+.0f}deg-{name}", n, mc, ours, ours / mc, sig / mc,
                     (ours - ours1) / mc_ms if mc_ms > 0 else np.nan,
                     sig_ms / mc_ms if mc_ms > 0 else np.nan))
    return rows

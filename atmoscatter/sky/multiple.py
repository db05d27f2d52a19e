"""Multiple scattering on a spherical planet with a Lambertian ground (seed 004).

Public objects
--------------
multiple_scattering
    Sky radiance per unit extraterrestrial solar irradiance [sr⁻¹] including ``orders``
    orders of scattering (``orders=1`` is :func:`atmoscatter.single_scattering`).
MULTIPLE_SCATTERING_GRID
    The default grid of the precomputed radiance field (documents its resolution); its
    solar-zenith nodes centre on the call's own sun, so each sun has its own field.
ACCURATE_MULTIPLE_SCATTERING_GRID
    A finer grid centred on the sun the same way, about twice the first-call cost
    (measured: ``docs/convergence.md``).
TABLE_MULTIPLE_SCATTERING_GRID
    A grid over every sun: one field per atmosphere, for animations and batches over many
    suns; less accurate than the default for one sky.
MULTIPLE_SCATTERING_GRIDS
    All three, by name (``"default"``, ``"accurate"``, ``"table"``): what ``Scene.ms_grid``
    selects.
MultipleScatteringGrid
    The grid itself (every resolution knob; :meth:`MultipleScatteringGrid.for_sun`).

Method (successive orders, seed 004's recursion)::

    I¹(ω)    = ∫ e^{−τ(P,x)} [Σ β_s ρ p(ω·ω_s) e^{−τ(x,sun)}] dx       (exact: single.py)
    S^i(x,ω) = ∫_{4π} I^i(x, ω′) p(ω·ω′) dω′                          (per species)
    I^{i+1}  = ∫ e^{−τ(P,x)} Σ β_s ρ(x) S^i(x, ω) dx  +  e^{−τ(P,G)} (a/π) E^i(G)

``E^i`` is the irradiance of order ``i`` on the ground ``G`` where a ray ends (``E⁰`` is
the direct sun).  The radiance field ``I^i`` of each order is kept on a grid over
altitude × solar zenith angle × view zenith (Gauss nodes) × relative azimuth (0–π,
the field is symmetric about the solar vertical) — the horizontally uniform atmosphere
and parallel sun make these four variables sufficient (Bruneton & Neyret 2008 use the
same reduction).  The grid is the design's core; each axis is chosen for where the field
changes fastest:

* **solar zenith** — with the default and accurate grids (``sun_nodes="scene"``) the
  nodes centre on the scene's own sun, a node exactly at its solar zenith and eight times
  denser within about 12° of it (:meth:`MultipleScatteringGrid.sun_zenith_nodes`): the
  air an observer sees, and the air that lights it, has a sun within about a ray's length
  of the observer's own, so a single sky needs nodes there only.  The ``table`` grid
  (``sun_nodes="all"``) covers every sun instead, dense from about 75° to 110° (the sun
  near and below the horizon).  Either way the source is interpolated by a cubic in
  ``log S`` through the four nearest nodes (:mod:`._ms_gather`): below the horizon the
  field falls by about e per degree, and linear interpolation of the values on a 9° grid
  made civil twilight 13× and nautical twilight 90× too bright (issue 10);
* **view zenith** — the source ``S^i = Σ W L^i`` is evaluated at the quadrature nodes
  *and* at the zenith and nadir, so interpolation spans [−1, 1]: before, the zenith cap
  was clamped to the last node (11.4° from the zenith) and read the field toward the sun;
* **altitude** — nodes equidistributed in a mix of height and vertical optical depth
  (:func:`_altitude_nodes`), so an optically thick layer gets nodes below its top;
* the **order-1 field** at the nodes uses the sun's transmittance from a table over
  (altitude, solar zenith) that follows the terminator exactly (:class:`_SunTransmittance`);
  the caller's own order 1 is :func:`single_scattering`, exact.

``S^i`` is obtained with a discrete phase matrix whose rows are normalised (energy is
conserved exactly on the grid), applied per azimuthal Fourier mode (it depends on the
azimuth difference only: :meth:`_Field.phase_spectra`), and gathered along every ray by a
compiled kernel, weighted by the exact density and transmittance on graded
Gauss–Legendre panels; the grid's node rays by slices (:class:`_NodeRays`: rays of one
altitude and view zenith share their samples for every sun and azimuth).  With
``orders=None`` successive orders are summed until the geometric tail estimate is small
and the tail itself is added (:meth:`_FieldState.converged_sum`).  Large batches (≥
``TABLE_THRESHOLD`` directions, observer inside the atmosphere) tabulate the smooth
multiple-scattering part over the observer's sky (257 × 33 nodes; 513 × 65 with the sun
more than 12° below the horizon) and interpolate it; a test proves the table gives the small-batch answer within 1 % of the multiple-scattering
part in every regime where it is used.

The field depends on the atmosphere, the albedo, the grid and the order setting and, with
a grid centred on the sun, on the solar zenith at the observer (and, above the atmosphere,
on how far it sees past the horizon: :meth:`MultipleScatteringGrid.for_sun`) — not on the
view directions or their number.  With the ``table`` grid one field serves every scene of
an atmosphere.  Fields are kept per process and in the persistent cache
(:mod:`atmoscatter.cache`; a new process or a Dask worker reads them instead of
recomputing; checksummed, written atomically).

The returned radiance is the light scattered by the atmosphere into the view ray (path
radiance).  For rays that end on the ground the ground's own reflected radiance is *not*
included (so ``orders=1`` equals single scattering for every direction); the ground
albedo acts through light reflected by the ground and scattered again.

Accuracy (measured, never assumed): against the published DISORT test problems
(``tests/test_rt_benchmarks.py``), the spherical sunset/twilight Monte Carlo tracer
(``tests/test_montecarlo.py``) and a refined grid (``docs/convergence.md``, which also
gives error against run time for each resolution knob).  ``scripts/ms_reference_check.py``
prints the comparison tables.

Why one module: the field build is one indivisible algorithm — the march, the sun's
transmittance table, the field, the gather and the order state all share the grid and the
prepared atmosphere at every step, and splitting them would only spread one recursion over
several files; its compiled kernels (:mod:`._ms_gather`, :mod:`._ms_kernels`), the shared
quadratures (:mod:`._quadrature`) and the sky table (:mod:`._sky_table`) live apart.

References
----------
* Preetham, A. J. Modeling skylight and aerial perspective (seed 004), ``I^{i+1}(ω)``.
* Keller & Bohn (seed 002) Eq. 5.5 (second order).
* Bruneton, E., Neyret, F. Precomputed atmospheric scattering, EGSR 2008.
"""

from __future__ import annotations

import os
import threading
import warnings
import weakref
from dataclasses import dataclass, fields, replace

import numpy as np

from .. import _progress
from .._validate import check_range
from . import _quadrature as qd
from ._disk_memo import memo_values, table_key, table_meta
from ._ms_gather import Located as _Located
from ._ms_gather import LogTable as _LogTable
from ._ms_gather import channel_max as _channel_max
from ._ms_gather import gather as _gather_kernel
from ._ms_gather import have_kernel as _have_kernel
from ._ms_gather import kernel as _ms_kernel
from ._ms_gather import log_floor as _log_floor
from ._ms_gather import log_table as _log_table
from ._ms_gather import pack_weights as _pack_weights
from ._single_rules import _Batch, _extinction_scale
from ._sky_table import _SkyTable
from .single import TABLE_THRESHOLD, _prepare_inputs, single_scattering

__all__ = ["multiple_scattering", "MULTIPLE_SCATTERING_GRID", "ACCURATE_MULTIPLE_SCATTERING_GRID",
           "TABLE_MULTIPLE_SCATTERING_GRID", "MULTIPLE_SCATTERING_GRIDS", "MultipleScatteringGrid",
           "GridTooCoarseError"]


@dataclass(frozen=True)
class MultipleScatteringGrid:
    """Resolution of the radiance-field grid of :func:`multiple_scattering`.

    Parameters
    ----------
    n_altitude : int
        Altitude levels, ≥ 2, equidistributed in a mix of height and vertical optical depth
        (:func:`_altitude_nodes`).
    n_sun : int
        Solar zenith angles, ≥ 2, in 0–``max_sun_zenith``; their density grows toward
        the horizon and below it (``horizon_density``), where the field changes fastest.
    n_mu : int
        View zenith cosines of the quadrature, even, ≥ 2 (Gauss nodes: half above the
        horizontal, the rest split at each altitude's horizon between the limb and the
        ground).  The source is also evaluated at the zenith and the nadir, so
        interpolation never extrapolates toward the poles.
    n_phi : int
        Relative azimuths, ≥ 2, uniform in 0–π inclusive.
    order : int
        Gauss–Legendre order per panel of the ray integrals, ≥ 1.
    max_sun_zenith : float
        Largest solar zenith angle on the grid [deg], in (90, 180] (beyond: the value at
        the last node, which is deep night for Earth-like planets).
    horizon_density : float
        Node density at solar zenith 92° relative to the density at the zenith [-], ≥ 1
        (1: uniform nodes).
    altitude_refine : int
        Refinement of the altitude axis of the source table the ray integrals read, ≥ 1:
        ``altitude_refine − 1`` values inserted in every interval by the cubic in
        ``log S`` (:func:`_refine_log`; 1: log-linear between the nodes).  No extra rays
        are marched; the table grows by this factor.  With 1, optically thick
        conservative layers lost energy in every order (DISORT 2D 6–8 %, 3B 7–12 % low);
        with 4 both are within 0.4 %.
    high_orders : MultipleScatteringGrid or None
        A grid for the orders from ``high_orders_from`` on (``None``: every order on this
        grid).  The fields of higher orders are smoother than the first ones, so they can
        live on a coarser grid; their source is resampled onto this grid's nodes by the
        gather's own interpolation before it is summed (:class:`_HighOrders`).  Must not
        have ``high_orders`` itself.
    high_orders_from : int
        The first order whose field is computed on ``high_orders``, ≥ 2 (its rays gather
        the previous order's source from this grid's table).
    sun_nodes : {"all", "scene"}
        ``"all"`` (the dataclass default; the ``table`` grid): the solar-zenith nodes
        cover every sun, dense near the horizon, so one field serves every scene of an
        atmosphere (animations, batches over many suns).  ``"scene"`` (the default and
        accurate grids): the nodes are concentrated at the call's own sun — a node
        exactly at its solar zenith, ``n_sun`` nodes equidistributed in a density that is
        ``_SCENE_PEAK`` times higher within about ``sun_width`` of it — so a single sky
        gets the accuracy of a much larger table for a fraction of its cost; each sun
        has its own field (cached in the process and on disk like any field).
        :func:`multiple_scattering` specialises such a grid to its sun
        (:meth:`for_sun`).
    sun_zenith : float or None
        Centre of the nodes of a ``"scene"`` grid: the solar zenith angle [deg] it was
        specialised to, in [0, ``max_sun_zenith``] (``None``: not yet specialised; must
        be ``None`` with ``"all"``).
    sun_width : float
        Half-width [deg] of the dense band of a ``"scene"`` grid, in (0, 180]: the local
        solar zenith of the air an observer inside the atmosphere sees, and of the air that
        lights it, stays within about a ray's length of its own (±8° for Earth's 60 km
        atmosphere).  Observers above the atmosphere see farther (:meth:`for_sun`).
    band_orders_from : int or None
        ``None`` (the dataclass default): every order at every node.  An integer ``K`` ≥ 3
        (the default grid: 3), for a ``"scene"`` grid with no ``high_orders``: orders
        ``K`` and later are computed only at the solar-zenith
        nodes within ``band_width`` (or ``sun_width``) of the sun and one node beyond on
        each side (the band); elsewhere each order is the
        previous one times its cell's decay per order (capped at the band's), and the
        summation stops when the band has converged (:meth:`_FieldState.converged_sum`).
        In daylight the air far from the band feeds the band's high orders with light
        that changes little from order to order: the default grid's measured errors are
        unchanged to the digits of the study's tables (``docs/convergence.md``), for a
        shorter first call (``benchmarks/bench_multiple.py``).  In twilight the sunlit
        nodes outside the band light the band's through orders 1 and 2, which are
        computed everywhere; with the band from the third order the default grid's
        errors at sun −3° to −18° moved by at most 0.15 % (of the reference's radiance),
        for a first call 15–25 % shorter (it was off below the horizon until measured).
        For observers above the atmosphere :meth:`for_sun` widens the band by the
        observer's dip, as it widens ``sun_width``: the band then holds all the air the
        observer sees, and the values over the disc and across the limb from 500 km moved
        by at most 7e-6 (T 2.5, sun 60° to −6°) and 1.2e-4 (T 10, sun 30°) against every
        order at every node (``docs/convergence/ms_space.md``), for a shorter first call
        (it was off from space until measured).
    band_width : float or None
        Half-width [deg] of the band of ``band_orders_from``, in (0, 180] (``None``, the
        dataclass default: ``sun_width``).  The scene's own rays read the air within about
        ±8° of its sun (a ray's length in Earth's 60 km atmosphere); the band's high orders
        read about as far again, where outside the band each order is the previous one
        times its cell's decay.  From noon to civil twilight that decay is steady and a
        band of ±6° (the default grid) gives the values of one of ±12° and of every node
        to the digits of the study's tables, for a shorter first call; in deeper twilight
        the decay outside the band is not steady (the lit air moves with the order), so
        :meth:`for_sun` gives a sun below :data:`TWILIGHT_BAND_ELEVATION` the full
        ``sun_width`` (``docs/convergence.md``: the ``band_width`` rows).
    space_n_mu : int or None
        View zenith cosines (even, ≥ 2) used instead of ``n_mu`` for an observer above the
        atmosphere (:meth:`for_sun` with ``observer_dip`` > 0; ``None``, the dataclass
        default: ``n_mu`` for every observer).  Seen from space, the limb is made of rays
        that graze the upper atmosphere, where the field changes fastest with the view
        zenith near each altitude's horizon: with the default grid's 32 cosines the limb's
        total was 1.0 % off, with 36 it is within the 1 % bound
        (``docs/convergence.md``).
    horizon_n_sun : int or None
        Solar-zenith nodes (≥ 4) used instead of ``n_sun`` by :meth:`for_sun` for a sun
        within :data:`HORIZON_SUN_ELEVATION` (−18° to +6° elevation: sunset and twilight)
        seen by an observer inside the atmosphere (``None``, the dataclass default:
        ``n_sun`` at every sun).  There the air the scene sees crosses the terminator, and
        the field changes fastest with the solar zenith: with the default grid's 16 nodes
        the total at sun 0° and −3° was 1.2 % and 2.5 % off, with 24 within 0.7 %; at
        −12°, −15° and −18° 16 nodes were 3.3 %, 37 % and 30 % off, 24 nodes 1.4 %, 3.0 %
        and 2.3 % against the study's reference over every sun, which is not converged
        in solar zenith below −12°: against references centred on the sun (48 and 64
        nodes, agreeing to 0.2 %) 24 nodes are 1.2 %, 4.7 % and 11 % off at −12°, −15° and
        −18°, 40 nodes 1.2 %, 0.5 % and 2.5 % (``docs/convergence.md``,
        ``benchmarks/ms_deep_twilight.py``).
    horizon_n_phi : int or None
        Azimuths (≥ 2) used instead of ``n_phi`` by :meth:`for_sun` in the same case as
        ``horizon_n_sun`` (``None``, the dataclass default: ``n_phi`` at every sun).  With
        the sun low the field's azimuthal contrast (bright towards the sun, dark away from
        it) is strongest: with 17 azimuths the multiple-scattering part at sunset was at
        the 3 % bound, with 19 within it; with the sun higher 17 and 19 give the same
        errors to the study's digits, for a shorter first call
        (``docs/convergence.md``, ``benchmarks/bench_multiple.py``).
    space_day_n_sun : int or None
        Solar-zenith nodes (≥ 4, before the widening by the dip) used instead of ``n_sun``
        by :meth:`for_sun` for an observer above the atmosphere with the sun at least
        :data:`SPACE_DAY_ELEVATION` above its horizon (``None``, the dataclass default:
        ``n_sun``).  Such an observer sees, and is lit by, air whose own sun stays high,
        where the field changes slowly with the solar zenith; nearer the terminator the
        widened band keeps the spacing of ``n_sun``.  From 500 km, over the disc and across
        the limb, 10 nodes against 24 (T 2.5): 3.1e-6, 1.2e-5, 3.5e-4, 3.3e-3 and 3.3e-3 at
        sun 60°, 45°, 30°, 20° and 10°, 1.1e-2 at −6°; at 30° 2.1e-4 (T 1.5) and 4.7e-4
        (T 10) (``docs/convergence/ms_space.md``).
    """

    n_altitude: int = 20
    n_sun: int = 32
    n_mu: int = 24
    n_phi: int = 17
    order: int = 3
    max_sun_zenith: float = 120.0
    horizon_density: float = 6.0
    altitude_refine: int = 4
    high_orders: MultipleScatteringGrid | None = None
    high_orders_from: int = 3
    sun_nodes: str = "all"
    sun_zenith: float | None = None
    sun_width: float = 12.0
    band_orders_from: int | None = None
    band_width: float | None = None
    space_n_mu: int | None = None
    horizon_n_sun: int | None = None
    horizon_n_phi: int | None = None
    space_day_n_sun: int | None = None

    def __post_init__(self):
        for name in ("n_altitude", "n_sun", "n_mu", "n_phi", "order", "altitude_refine",
                     "high_orders_from"):
            value = getattr(self, name)
            low = 1 if name in ("order", "altitude_refine") else 2
            if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < low:
                raise ValueError(
                    f"MultipleScatteringGrid.{name} must be an integer >= {low}, got {value!r}"
                )
        if self.n_mu % 2:
            raise ValueError(f"MultipleScatteringGrid.n_mu must be even, got {self.n_mu!r}")
        if not (90.0 < float(self.max_sun_zenith) <= 180.0):
            raise ValueError(
                "MultipleScatteringGrid.max_sun_zenith must be in (90, 180] deg, "
                f"got {self.max_sun_zenith!r}"
            )
        if not (float(self.horizon_density) >= 1.0 and np.isfinite(self.horizon_density)):
            raise ValueError(
                "MultipleScatteringGrid.horizon_density must be finite and >= 1, "
                f"got {self.horizon_density!r}"
            )
        if self.sun_nodes not in ("all", "scene"):
            raise ValueError(
                f"MultipleScatteringGrid.sun_nodes must be 'all' or 'scene', got {self.sun_nodes!r}"
            )
        if self.sun_zenith is not None:
            if self.sun_nodes != "scene":
                raise ValueError(
                    "MultipleScatteringGrid.sun_zenith is only for sun_nodes='scene', got "
                    f"sun_zenith={self.sun_zenith!r} with sun_nodes={self.sun_nodes!r}"
                )
            z = self.sun_zenith
            if (isinstance(z, bool) or not isinstance(z, (int, float, np.floating))
                    or not (0.0 <= float(z) <= float(self.max_sun_zenith))):
                raise ValueError(
                    "MultipleScatteringGrid.sun_zenith must be None or in [0, "
                    f"max_sun_zenith={self.max_sun_zenith:g}] deg, got {z!r}"
                )
        for name, low, even in (("band_orders_from", 3, False), ("space_n_mu", 2, True),
                                ("horizon_n_sun", 4, False), ("horizon_n_phi", 2, False),
                                ("space_day_n_sun", 4, False)):
            m = getattr(self, name)
            if m is not None and (isinstance(m, bool) or not isinstance(m, (int, np.integer))
                                  or m < low or (even and m % 2)):
                kind = "an even integer" if even else "an integer"
                raise ValueError(
                    f"MultipleScatteringGrid.{name} must be None or {kind} >= {low}, got {m!r}"
                )
        w = self.sun_width
        if (isinstance(w, bool) or not isinstance(w, (int, float, np.floating))
                or not (0.0 < float(w) <= 180.0)):
            raise ValueError(f"MultipleScatteringGrid.sun_width must be in (0, 180] deg, got {w!r}")
        b = self.band_width
        if b is not None and (isinstance(b, bool) or not isinstance(b, (int, float, np.floating))
                              or not (0.0 < float(b) <= 180.0)):
            raise ValueError(
                f"MultipleScatteringGrid.band_width must be None or in (0, 180] deg, got {b!r}"
            )
        if self.high_orders is not None:
            if not isinstance(self.high_orders, MultipleScatteringGrid):
                raise TypeError(
                    "MultipleScatteringGrid.high_orders must be a MultipleScatteringGrid or "
                    f"None, got {type(self.high_orders).__name__}"
                )
            if self.high_orders.high_orders is not None:
                raise ValueError(
                    "MultipleScatteringGrid.high_orders must not have high_orders itself"
                )

    def describe(self) -> str:
        """The grid in words: every knob and its value (and, with ``high_orders``, the
        second grid's), as ``--explain`` prints it."""
        text = ", ".join(f"{f.name} {getattr(self, f.name):g}" for f in fields(self)
                         if f.name not in ("high_orders", "high_orders_from", "sun_nodes",
                                           "sun_zenith", "sun_width", "band_orders_from",
                                           "band_width",
                                           "space_n_mu", "horizon_n_sun", "horizon_n_phi",
                                           "space_day_n_sun"))
        if self.sun_nodes == "scene":
            text += (f"; solar-zenith nodes centred on the scene's sun (±{self.sun_width:g}° "
                     "band; one field per sun)")
            if self.sun_zenith is not None:
                text += f", here at {self.sun_zenith:.6g}°"
            if self.band_orders_from is not None:
                text += (f"; orders ≥ {self.band_orders_from} only in the band of nodes "
                         f"within {self._band_width():g}° of the sun")
                if self.sun_zenith is None:
                    if self.band_width is not None:
                        text += (f" ({self.sun_width:g}° with the sun below "
                                 f"{TWILIGHT_BAND_ELEVATION:g}°; wider by the dip for an "
                                 "observer above the atmosphere)")
                    else:
                        text += " (wider by the dip for an observer above the atmosphere)"
            if self.sun_zenith is None:  # specialised (for_sun): the knobs above are the sun's
                near = [f"{name} {value}" for name, value in (("n_sun", self.horizon_n_sun),
                                                              ("n_phi", self.horizon_n_phi))
                        if value is not None]
                if near:
                    lo, hi = HORIZON_SUN_ELEVATION
                    text += (f"; {', '.join(near)} for a sun {lo:g}° to +{hi:g}° from the "
                             "horizon (observer in the atmosphere)")
                if self.space_n_mu is not None:
                    text += f"; n_mu {self.space_n_mu} for an observer above the atmosphere"
                if self.space_day_n_sun is not None:
                    day = (f"n_sun {self.space_day_n_sun} with the sun "
                           f"{SPACE_DAY_ELEVATION:g}° or more above its horizon")
                    text += (f" ({day})" if self.space_n_mu is not None
                             else f"; {day} for an observer above the atmosphere")
        else:
            text += "; solar-zenith nodes for every sun (one field per atmosphere)"
        if self.high_orders is not None:
            text += f"; orders ≥ {self.high_orders_from} on ({self.high_orders.describe()})"
        return text

    def _band_width(self) -> float:
        """Half-width [deg] of the band of ``band_orders_from`` (``band_width``, or
        ``sun_width`` where it is ``None``)."""
        return float(self.sun_width if self.band_width is None else self.band_width)

    def sun_zenith_nodes(self) -> np.ndarray:
        """Solar zenith nodes [rad], increasing, from 0 to ``max_sun_zenith``.

        ``sun_nodes="all"``: equidistributed in the node density ``1 + (horizon_density −
        1) exp(−((θ − 92°)/16°)²)``: with the dataclass defaults 8.4° apart at the zenith,
        1.4–2.2° from 80° to 104° (sun 14° below the horizon), 2.5–4° to 110°.

        ``sun_nodes="scene"``: equidistributed in ``1 + (_SCENE_PEAK − 1) exp(−((θ −
        θ₀)/w)²)`` with ``θ₀ = sun_zenith`` and ``w = sun_width``, on each side of ``θ₀``
        so that ``θ₀`` is a node (the observer's own solar zenith is read without
        interpolation; a sun within half a spacing of 0 or ``max_sun_zenith`` is read at
        that end's node); with 16 nodes and ``w = 12°`` they are 2.1–2.9° apart within
        6° of the sun and 13–18° apart far from it.

        Raises
        ------
        ValueError
            For a ``"scene"`` grid not specialised to a sun (:meth:`for_sun`).
        """
        top = float(self.max_sun_zenith)
        th = np.linspace(0.0, top, 8001)
        if self.sun_nodes == "scene":
            if self.sun_zenith is None:
                raise ValueError(
                    "a MultipleScatteringGrid with sun_nodes='scene' has no nodes until it is "
                    "specialised to a sun: use grid.for_sun(sun_zenith_deg) (multiple_scattering "
                    "does this for its sun)"
                )
            centre, width, peak = float(self.sun_zenith), float(self.sun_width), _SCENE_PEAK
        else:
            centre, width, peak = _SUN_CENTRE, _SUN_WIDTH, float(self.horizon_density)
        dens = 1.0 + (peak - 1.0) * np.exp(-(((th - centre) / width) ** 2))
        cdf = np.concatenate([[0.0], np.cumsum(0.5 * (dens[1:] + dens[:-1]) * np.diff(th))])
        n, total = self.n_sun, cdf[-1]
        nodes = np.interp(np.linspace(0.0, total, n), cdf, th)
        if self.sun_nodes == "scene":
            # equidistributed on each side of the sun, so that it is a node: ``k`` nodes
            # below it, as many as its share of the density (a sun within half a spacing
            # of an end is read at that end's node)
            c = float(np.interp(centre, th, cdf))
            k = int(round((n - 1) * c / total))
            if 0 < k < n - 1:
                left = np.interp(np.linspace(0.0, c, k + 1), cdf, th)
                right = np.interp(np.linspace(c, total, n - k), cdf, th)
                nodes = np.concatenate([left[:-1], [centre], right[1:]])
        nodes[0], nodes[-1] = 0.0, top
        return np.radians(nodes)

    def for_sun(self, sun_zenith: float, observer_dip: float = 0.0) -> MultipleScatteringGrid:
        """This grid specialised to one sun (``sun_nodes="scene"``; others: unchanged).

        Parameters
        ----------
        sun_zenith : float
            Solar zenith angle at the observer [deg]; beyond ``max_sun_zenith`` the nodes
            centre on ``max_sun_zenith`` (deep night).
        observer_dip : float
            Angle [deg] ≥ 0 between the observer's vertical and the vertical where its
            line of sight grazes the planet (``arccos(R/r)`` of an observer above the
            atmosphere, 0 inside it).  An observer in space sees air whose own sun is up to
            this much farther from its own: the dense band widens by it and the node count
            grows in proportion (``ceil(n_sun (w + dip)/w)``), keeping the spacing;
            the band of ``band_orders_from`` widens by it too.

        Returns
        -------
        MultipleScatteringGrid
            With ``sun_zenith`` (and, for ``observer_dip > 0``, ``sun_width``, ``n_sun``
            — from ``space_day_n_sun`` where it is set and the sun is at least
            :data:`SPACE_DAY_ELEVATION` up — and, if ``space_n_mu`` is set,
            ``n_mu = space_n_mu``; for a sun near the
            horizon inside the atmosphere, ``n_sun = horizon_n_sun`` and
            ``n_phi = horizon_n_phi`` where they are set) set, and ``band_width`` that
            of the sun's regime (:data:`TWILIGHT_BAND_ELEVATION`) plus the dip; a grid
            already specialised is returned as it is.
        """
        if self.sun_nodes != "scene" or self.sun_zenith is not None:
            return self
        z = float(sun_zenith)
        dip = float(observer_dip)
        if not (np.isfinite(z) and np.isfinite(dip) and dip >= 0.0):
            raise ValueError(
                f"for_sun needs a finite sun_zenith and an observer_dip >= 0 [deg], got "
                f"sun_zenith={sun_zenith!r}, observer_dip={observer_dip!r}"
            )
        z = min(max(z, 0.0), float(self.max_sun_zenith))
        high = self.high_orders
        if high is not None:
            high = high.for_sun(z, dip)
        width = min(float(self.sun_width) + dip, 180.0)  # dip 0: the width and n_sun stay
        lo, hi = HORIZON_SUN_ELEVATION
        # the limits are inclusive to within _LIMIT_SLACK: a sun given as a vector at −6°
        # has a zenith angle of 96.00000000000001° in floating point
        elevation = 90.0 - z
        near_horizon = dip == 0.0 and lo - _LIMIT_SLACK <= elevation <= hi + _LIMIT_SLACK
        n_sun = self.horizon_n_sun if (near_horizon and self.horizon_n_sun is not None) else self.n_sun
        if (dip > 0.0 and self.space_day_n_sun is not None
                and elevation >= SPACE_DAY_ELEVATION - _LIMIT_SLACK):
            n_sun = self.space_day_n_sun
        n = int(np.ceil(n_sun * width / float(self.sun_width)))
        # in twilight the band takes the full sun_width (TWILIGHT_BAND_ELEVATION); from
        # space it widens by the dip, as sun_width does (None: sun_width, widened above)
        band_width = (min(float(self.band_width) + dip, 180.0)
                      if (self.band_width is not None
                          and elevation >= TWILIGHT_BAND_ELEVATION - _LIMIT_SLACK)
                      else None)
        n_mu = self.space_n_mu if (dip > 0.0 and self.space_n_mu is not None) else self.n_mu
        n_phi = self.horizon_n_phi if (near_horizon and self.horizon_n_phi is not None) else self.n_phi
        return replace(self, sun_zenith=z, sun_width=width, n_sun=n, n_mu=n_mu, n_phi=n_phi,
                       high_orders=high, band_width=band_width)


HORIZON_SUN_ELEVATION: tuple[float, float] = (-18.0, 6.0)
"""Sun elevations [deg] (inclusive) at which :meth:`MultipleScatteringGrid.for_sun` uses
``horizon_n_sun`` solar-zenith nodes and ``horizon_n_phi`` azimuths for an observer inside
the atmosphere (sunset and twilight): measured at sun 5°, 2°, 0°, −1°, −3° (ground) and
2° (12 km), where the daylight grid (16 nodes, 17 azimuths) missed the bounds or sat at
them, and at −12°, −15° and −18°, where 16 nodes were 3.3 %, 37 % and 30 % off (the
first above the 3 % bound of issue 10); with 8° and 10° (ground) within them on 16 nodes.
The band was −8° to +6° until the deep-twilight scenes were measured; between −8° and −10°
16 nodes were within the bounds too, so extending it there costs those suns a longer first
call for no measured need, against one band instead of two (``docs/convergence.md``)."""

SPACE_DAY_ELEVATION: float = 30.0
"""Sun elevation [deg] (inclusive) from which :meth:`MultipleScatteringGrid.for_sun` gives an
observer above the atmosphere ``space_day_n_sun`` solar-zenith nodes: measured from 500 km
against 24 nodes, 10 nodes were within 5e-4 from 30° up (T 1.5–10), 3.3e-3 off at 20° and
10° and up to 1.1e-2 in twilight, where the air seen from space reaches the terminator
(``docs/convergence/ms_space.md``)."""

#: slack [deg] of the inclusive sun-elevation limits of :meth:`MultipleScatteringGrid.for_sun`
#: (round-off of a zenith angle computed from a direction vector, ~1e-14°)
_LIMIT_SLACK = 1e-9

TWILIGHT_BAND_ELEVATION: float = -6.0
"""Sun elevation [deg] below which :meth:`MultipleScatteringGrid.for_sun` sets a grid's
``band_width`` back to ``None`` (the band of high orders as wide as ``sun_width``): at and
above it a band of ±6° gives the answer of every node, below it the extrapolated high
orders outside a narrow band are not steady enough (``docs/convergence.md``)."""

MULTIPLE_SCATTERING_GRID = MultipleScatteringGrid(n_altitude=32, n_sun=16, n_mu=32, n_phi=17,
                                                  sun_nodes="scene", band_orders_from=3,
                                                  band_width=6.0,
                                                  space_n_mu=36, horizon_n_sun=24,
                                                  horizon_n_phi=19, space_day_n_sun=10)
"""Default grid: solar-zenith nodes centred on the scene's sun (one field per sun), finer in
altitude (haze) and view zenith (the zenith cap, the limb) than :data:`TABLE_MULTIPLE_SCATTERING_GRID`
for about the same first call;
orders from the third on are computed only in the band of nodes within 6° of the sun
(``band_orders_from``, ``band_width``; within 12° with the sun below
:data:`TWILIGHT_BAND_ELEVATION`; both wider by the observer's dip above the atmosphere,
:meth:`MultipleScatteringGrid.for_sun`); for an observer above the atmosphere 36 view cosines
(``space_n_mu``: 32 left the limb's total at the 1 % bound) and, with the sun 30° or more
above its horizon, 10 solar-zenith nodes before the widening (``space_day_n_sun``: the air
seen stays far from the terminator), and for a sun near or below
the horizon (:data:`HORIZON_SUN_ELEVATION`, sunset and twilight down to −18°) 24
solar-zenith nodes and 19 azimuths (``horizon_n_sun``, ``horizon_n_phi``: 16 nodes missed
the bounds at and just below the horizon and at −12°, and were tens of per cent off
below, 17 azimuths left sunset's multiple-scattering part at the 3 % bound); chosen from the
error-against-run-time study and measured against a grid finer in every knob
(``docs/convergence.md``)."""

ACCURATE_MULTIPLE_SCATTERING_GRID = MultipleScatteringGrid(n_altitude=32, n_sun=24, n_mu=36,
                                                           n_phi=21, sun_nodes="scene")
"""A finer grid (``grid=ACCURATE_MULTIPLE_SCATTERING_GRID``, ``ms_grid=accurate``), centred on
the scene's sun like the default, for about twice its first call; its error against a grid
refined beyond it, next to the default's, is measured by ``benchmarks/ms_accurate_grid.py``
(``docs/convergence/ms_accurate_grid.md``)."""

TABLE_MULTIPLE_SCATTERING_GRID = MultipleScatteringGrid()
"""A grid over every sun (``sun_nodes="all"``, ``ms_grid=table``): one field serves every scene
of an atmosphere, so animations and batches over many suns build it once; less accurate than
the default for one sky (measured in ``docs/convergence.md``).  It was the default grid
until the default followed the scene's sun (CHANGELOG)."""

MULTIPLE_SCATTERING_GRIDS = {"default": MULTIPLE_SCATTERING_GRID,
                             "accurate": ACCURATE_MULTIPLE_SCATTERING_GRID,
                             "table": TABLE_MULTIPLE_SCATTERING_GRID}
"""The named grids, by the name a scene gives (``Scene.ms_grid``, ``--set ms_grid=…``);
the EXR header quotes each one's measured error (``atmoscatter/data/ms_accuracy.json``)."""

DEFAULT_ORDER_TOLERANCE: float = 1e-3
"""Default ``order_tolerance`` of :func:`multiple_scattering` (relative error of the summed
orders; the convergence study measures the default grid with it)."""

#: (view-zenith, azimuth) nodes of the table used for the multiple-scattering part of large
#: batches (≥ TABLE_THRESHOLD directions, observer inside the atmosphere)
_MS_TABLE_NODES = (257, 33)
#: the same with the sun lower than _DEEP_TWILIGHT_ELEVATION: there the multiple-scattering
#: part changes fast near the horizon, in azimuth 60–80° from the sun and, seen from 12 km,
#: in elevation just above the ground's horizon.  With 257 × 33 nodes up to 1.8 % of it was
#: lost between the nodes at sun −18° (T 1.5–10, ground and 12 km); with 257 × 65, 1.1 %
#: (T 10, 12 km, 2.5° below the horizontal); with 513 × 65, ≤ 0.8 %, for about 1.7× the
#: table's cost (tests/test_multiple.py::test_large_batches_give_the_answer_of_small_ones)
_MS_TABLE_NODES_DEEP_TWILIGHT = (513, 65)
_DEEP_TWILIGHT_ELEVATION = -12.0  # [deg]


def _table_azimuths(n_table: int, n_field: int) -> int:
    """Azimuth nodes of the multiple-scattering sky table: at least ``n_table``, and a
    multiple of the field's azimuth spacing (``k (n_field − 1) + 1``), so that every field
    azimuth node is a table node.  The gather interpolates the field linearly in azimuth,
    so the multiple-scattering part has kinks at the field's nodes; a bilinear table whose
    nodes miss them cuts the corners (with the field's 19 azimuths near the horizon and 33
    table azimuths, 1.7 % of the multiple-scattering part at sun 2° seen from 12 km;
    ``tests/test_multiple.py::test_large_batches_give_the_answer_of_small_ones``)."""
    step = int(n_field) - 1
    return step * int(np.ceil((int(n_table) - 1) / step)) + 1


_SUN_CENTRE, _SUN_WIDTH = 92.0, 16.0  # [deg] where the solar-zenith nodes are densest
#: node density at the sun of a ``sun_nodes="scene"`` grid relative to far from it [-]
_SCENE_PEAK = 8.0
_HORIZON_SPLIT = True  # μ quadrature split at each altitude's horizon (see _Field)
#: kept node rays gathered by slices (:class:`_NodeRays`; False: per cell, as the caller's
#: rays are gathered — the tests' comparison)
_SLICE_GATHER = True
_CACHE: dict = {}
_CACHE_LOCK = threading.Lock()
_CACHE_MAX = 4
#: memory budget [bytes] of the in-process caches of field states (``_CACHE``) and of summed
#: fields (``_RESULTS``), each: beyond it the oldest entries go (the newest always stays;
#: the disk cache, or a rebuild, gives the same values back).  A sun-centred grid builds a
#: field per sun, so a process rendering many suns filled the count-limited caches with
#: fields it would not read again: a 21-wavelength twilight series (the gallery) reached
#: 21 GB and was killed on a 24 GB machine
_CACHE_BYTES = 2 * 2**30
_THREADS = max(1, min(4, os.cpu_count() or 1))
#: memory budget [bytes] for the node rays kept between orders (:class:`_FieldState`).  The
#: default grid keeps about 0.25 GB at 3 wavelengths and 0.3 GB at 21 (spectral sampling);
#: before, fields of more than 12 wavelengths re-marched every node ray for every order
#: (a 21-wavelength field: 7 min on the 2-core machine)
_KEEP_BYTES = 2 * 2**30
#: memory budget [bytes] of the per-order sources S^1, S^2, … a field state keeps (a later
#: request for fewer orders, or another tolerance, sums them again).  Beyond it the oldest
#: go but the last two, which the summation reads (:meth:`_FieldState._extend`); a request
#: that needs a dropped one rebuilds the state (:func:`_field_for`).  One source of the
#: default grid is about 25 MB at 3 wavelengths and 170 MB at 21: a spectral twilight field
#: of 15–25 orders kept 2.5–4 GB of them before
_SOURCES_BYTES = 2**30
#: with orders=None, summation stops once the estimated tail is below this multiple of
#: order_tolerance, and the tail is added (see _FieldState.converged_sum)
_ACCELERATION = 30.0
#: version of the stopping rule of the automatic sum (:meth:`_FieldState._floor`): part of
#: the persistent cache's key of fields summed to a tolerance
_SUM_RULE = 2


# ----------------------------------------------------------------------------------------
# ray marching shared by grid nodes and user rays
# ----------------------------------------------------------------------------------------
@dataclass
class _March:
    wt: np.ndarray  # (N, M, n_sc, nwl) weight × transmittance × β_s,i ρ_i
    h: np.ndarray  # (N, M) altitude of samples
    mu: np.ndarray  # (N, M) local view zenith cosine
    mus: np.ndarray  # (N, M) local sun zenith cosine
    cphi: np.ndarray  # (N, M) cos relative azimuth
    ground: np.ndarray  # (N,) ray ends on the ground
    t_end: np.ndarray  # (N, nwl) transmittance to the end
    mus_end: np.ndarray  # (N,) sun zenith cosine at the end point


def _ms_view_bounds(atm: qd.PreparedAtmosphere, sa: np.ndarray, sb: np.ndarray, p2: np.ndarray,
                    m: int = 1) -> np.ndarray:
    """Panel boundaries along a view ray for integrals of a *smooth* source.

    The single-scattering rule (:func:`atmoscatter.sky._single_rules._graded_view_bounds`) also
    splits at the planet's shadow and where the sun ray grazes optical-depth levels,
    because the sun's transmittance changes abruptly there.  The multiple-scattering
    source varies smoothly along a ray (it is a phase integral of the field, and the
    order-1 field comes from a smooth transmittance table), so here panels grow
    geometrically from the ray's lowest point and from its start (first panel no longer
    than the local density scale and extinction length), with profile breakpoints and the
    view ray's optical-depth levels as extra boundaries.
    """
    c = np.clip(0.0, sa, sb)
    hmin = float(np.min(atm.scales)) if atm.scales.size else atm.top_radius - atm.planet_radius

    def scale(x):
        return np.minimum(qd.local_scale(hmin, x, p2), _extinction_scale(atm, p2, x))

    ell_c, ell_a = scale(c), scale(sa)
    span = max(
        float(np.max(np.maximum(sb - c, c - sa) / ell_c)) if sa.size else 0.0,
        float(np.max((sb - sa) / ell_a)) if sa.size else 0.0,
    )
    k = qd.n_geometric_panels(span, m)
    d = qd.geometric_offsets(m, k)[1:]
    cuts = [c[:, None] + ell_c[:, None] * d, c[:, None] - ell_c[:, None] * d,
            sa[:, None] + ell_a[:, None] * d]
    levels = [bp for bp in atm.breakpoints if bp.size]
    if atm.tau_levels is not None and atm.tau_levels.size:
        levels.append(atm.tau_levels)
    if levels:
        rl = atm.planet_radius + np.unique(np.concatenate(levels))
        sq = np.sqrt(np.maximum(rl * rl - p2[:, None], 0.0))
        cuts += [sq, -sq]
    bounds = np.concatenate(cuts, axis=-1)
    bounds = np.sort(np.clip(bounds, sa[:, None], sb[:, None]), axis=-1)
    return qd.compact_bounds(np.concatenate([sa[:, None], bounds, sb[:, None]], axis=-1))


@dataclass
class _ViewMarch:
    """The part of a march that does not depend on the sun: the nodes along the view rays,
    their weights × view transmittance × β_s ρ, and where the rays end.  The grid's node
    rays at one altitude are the same for every solar zenith angle, so they are marched
    once per altitude and combined with each sun direction by :func:`_march_sun`."""

    atm: qd.PreparedAtmosphere
    r0: float
    v: np.ndarray  # (N, 3)
    sigma: np.ndarray  # (N, M) coordinate of the nodes along the ray (0 at the perigee)
    rr: np.ndarray  # (N, M) radius of the nodes
    s0: np.ndarray  # (N,) coordinate of the observer
    p2: np.ndarray  # (N,) squared impact parameter
    sb: np.ndarray  # (N,) coordinate of the ray's end
    wt: np.ndarray  # (N, M, n_sc, nwl)
    h: np.ndarray  # (N, M)
    mu: np.ndarray  # (N, M)
    ground: np.ndarray  # (N,)
    t_end: np.ndarray  # (N, nwl)


def _march_view(atm: qd.PreparedAtmosphere, r0: float, v: np.ndarray, q: int,
                use_kernel: bool = True) -> _ViewMarch:
    n = v.shape[0]
    nwl = atm.n_wavelengths
    nsc = len(atm.scatterers)
    R = atm.planet_radius
    p2, s0, sa, sb = qd.view_segments(r0, v, atm.planet_radius, atm.top_radius)
    bounds = _ms_view_bounds(atm, sa, sb, p2)
    sigma, weights, plen = qd.panel_rule(bounds, q)
    npan = plen.shape[1]
    rr = np.sqrt(p2[:, None] + sigma * sigma)
    h = rr - R
    rho = [atm.density(g, h) for g in range(len(atm.profiles))]
    wt = np.empty((n, sigma.shape[1], nsc, nwl))
    kern = _ms_kernel("march_weights") if use_kernel else None
    if kern is not None and nsc and n:
        # one compiled pass: optical depth along the ray, transmittance and weights
        # (the NumPy lines below compute the same, with more temporaries)
        tau_end = np.empty((n, nwl))
        _, wq = qd.gauss_legendre_unit(q)
        kern(np.ascontiguousarray(plen, dtype=float), np.ascontiguousarray(np.stack(rho)),
             np.ascontiguousarray(atm.extinction, dtype=float), qd.integration_matrix_unit(q),
             np.ascontiguousarray(wq, dtype=float), np.ascontiguousarray(weights, dtype=float),
             np.array([g for g, _, _ in atm.scatterers], dtype=np.int64),
             np.ascontiguousarray(np.stack([beta for _, beta, _ in atm.scatterers]), dtype=float),
             wt, tau_end)
    else:
        tau = np.zeros(sigma.shape + (nwl,))
        tau_end = np.zeros((n, nwl))
        for g in range(len(atm.profiles)):
            cum, total = qd.cumulative_panel_integral(plen, rho[g].reshape(n, npan, q), q)
            tau += np.multiply.outer(cum, atm.extinction[g])
            tau_end += total[:, None] * atm.extinction[g]
        trans = np.exp(np.negative(tau, out=tau))
        for i, (g, beta, _) in enumerate(atm.scatterers):
            np.multiply((weights * rho[g])[..., None] * trans, beta, out=wt[:, :, i, :])
    mu = np.clip(sigma / rr, -1.0, 1.0)
    # end of the ray on the ground?
    mu0 = v[:, 2]
    if r0 <= R * (1.0 + 1e-12):
        ground = mu0 < 0.0  # on the ground looking down: the ground itself, no path
    else:
        ground = (sb > sa) & (mu0 < 0.0) & (p2 < R * R) & np.isclose(
            np.sqrt(p2 + sb * sb), R, rtol=1e-9, atol=1e-3
        )
    return _ViewMarch(atm, r0, v, sigma, rr, s0, p2, sb, wt, h, mu, ground, np.exp(-tau_end))


def _sun_at_ends(vm: _ViewMarch, s: np.ndarray):
    """``(ν, μ_s,end)``: the cosine of the angle between each view ray and the sun ``s``,
    and the sun's zenith cosine where each ray ends."""
    nu = np.clip(vm.v @ s, -1.0, 1.0)
    r_end = np.sqrt(vm.p2 + vm.sb * vm.sb)
    mus_end = np.clip((vm.r0 * s[2] + (vm.sb - vm.s0) * nu) / np.maximum(r_end, 1.0), -1.0, 1.0)
    return nu, mus_end


def _march_sun(vm: _ViewMarch, s: np.ndarray) -> _March:
    """Complete a view march with the sun direction ``s``: local sun zenith cosine and
    relative azimuth at every node, and the sun's zenith cosine where the ray ends."""
    nu, mus_end = _sun_at_ends(vm, s)
    t = vm.sigma - vm.s0[:, None]
    mu = vm.mu
    mus = np.clip((vm.r0 * s[2] + t * nu[:, None]) / vm.rr, -1.0, 1.0)
    den = np.sqrt(np.maximum((1.0 - mu * mu) * (1.0 - mus * mus), 0.0))
    with np.errstate(divide="ignore", invalid="ignore"):
        cphi = np.where(den > 1e-12, (nu[:, None] - mu * mus) / np.where(den > 1e-12, den, 1.0), 1.0)
    cphi = np.clip(cphi, -1.0, 1.0)
    return _March(vm.wt, vm.h, mu, mus, cphi, vm.ground, vm.t_end, mus_end)


def _order1(vm: _ViewMarch, s: np.ndarray, P: np.ndarray, keep: np.ndarray,
            sun_t: _SunTransmittance, use_kernel: bool = True):
    """The march of node rays ``vm`` completed for the sun ``s`` (:func:`_march_sun`) and
    their order-1 path ``Σ_m T_sun Σ_i w T β_i ρ_i p_i`` (N, nwl) with the phase values
    ``P`` (N, n_sc) and the tabulated sun transmittance ``sun_t`` over the samples with
    weight (``keep``).  One compiled pass where available (in NumPy temporaries, which
    hold the GIL, order 1 took a fifth of the default field's build on the 2-core
    machine); ``use_kernel=False``: NumPy."""
    kern = _ms_kernel("order1_path") if use_kernel else None
    if kern is None:
        mc = _march_sun(vm, s)
        # Σ_m Σ_i w T p_i, as (N, M, nwl) products then a BLAS-free sum over the
        # samples (a three-operand einsum here is several times slower)
        wp = np.einsum("nmiw,ni->nmw", mc.wt, P, optimize=True)
        # the sun's transmittance where a sample has weight (0 elsewhere, as its
        # product with wp already was)
        tsun = np.zeros_like(wp)
        tsun[keep] = sun_t(mc.h[keep], mc.mus[keep])
        return mc, np.einsum("nmw,nmw->nw", wp, tsun)
    N, M = vm.h.shape
    nu, mus_end = _sun_at_ends(vm, s)
    mus, cphi = np.empty((N, M)), np.empty((N, M))
    path = np.empty((N, vm.wt.shape[-1]))
    kern(vm.sigma, vm.rr, vm.s0, float(vm.r0), float(s[2]), nu, vm.mu, vm.h, vm.wt,
         np.ascontiguousarray(P, dtype=float), keep, sun_t.h_nodes, sun_t.tau, float(sun_t.R),
         float(sun_t.top), mus, cphi, path)
    return _March(vm.wt, vm.h, vm.mu, mus, cphi, vm.ground, vm.t_end, mus_end), path


def _march(atm: qd.PreparedAtmosphere, r0: float, v: np.ndarray, s: np.ndarray, q: int,
           use_kernel: bool = True) -> _March:
    """Nodes, weights and geometry of view rays ``v`` from radius ``r0`` for the sun ``s``."""
    return _march_sun(_march_view(atm, r0, v, q, use_kernel), s)


class _SunTransmittance:
    """Transmittance of the sun ray ``T(h, θ_s)`` per wavelength, from a table.

    The atmosphere is horizontally uniform and the sun at infinity, so the sun's
    transmittance at a point depends only on its altitude ``h`` and local solar zenith
    cosine ``μ_s``.  The optical depth of *upward* rays ``τ↑(h, μ)`` (``μ ≥ 0``) is
    tabulated with the exact graded rule on quadratically clustered altitudes × nodes
    uniform in ``√μ`` (dense toward the horizontal, where it changes fastest) and
    interpolated bilinearly.  A sun below the local horizontal (``μ_s < 0``) shines
    along a ray through its perigee at radius ``r_p = r sin θ_s``: it is in the planet's
    shadow if ``r_p < R``, and otherwise by symmetry about the perigee
    ``τ = 2 τ↑(h_p, 0) − τ↑(h, −μ_s)`` — both terms smooth, so no table has to follow
    the abrupt change of ``T`` along the terminator.  Used for the order-1 field at the
    grid nodes and the direct sun on the ground; the caller's own order 1 is
    :func:`single_scattering` (exact).  Measured error of ``τ``: ≤ 1e-4 relative.
    """

    def __init__(self, atm: qd.PreparedAtmosphere, n_h: int = 128, n_x: int = 193):
        self.R, self.top = atm.planet_radius, atm.top_radius
        thick = self.top - self.R
        nodes = [thick * (np.arange(n_h) / (n_h - 1)) ** 2]
        # profile breakpoints put kinks (and √-type derivative singularities for grazing
        # rays) into τ↑(h, μ): make them nodes, with nodes clustered on both sides
        for bp in atm.breakpoints:
            for b in np.asarray(bp, dtype=float):
                nodes.append(b + np.array([-1.0, 1.0])[:, None] * np.geomspace(3.0, 3000.0, 8))
                nodes.append([b])
        h = np.unique(np.clip(np.concatenate([np.ravel(n) for n in nodes]), 0.0, thick))
        self.h_nodes = h
        self.x_nodes = np.linspace(0.0, 1.0, n_x)
        hh, xx = np.meshgrid(self.h_nodes, self.x_nodes, indexing="ij")
        r = self.R + hh
        mu = xx * xx
        p2 = r * r * (1.0 - mu) * (1.0 + mu)
        tau = np.zeros(hh.shape + (atm.n_wavelengths,))
        for g in range(len(atm.profiles)):
            tau += qd.optical_length_to_top(atm, g, p2, r * mu, 6, 2)[..., None] * atm.extinction[g]
        self.tau = tau

    def _tau_up(self, h, mu):
        hn, xn = self.h_nodes, self.x_nodes
        hc = np.clip(h, 0.0, hn[-1])
        i = np.clip(np.searchsorted(hn, hc, side="right") - 1, 0, hn.size - 2)
        fi = ((hc - hn[i]) / (hn[i + 1] - hn[i]))[..., None]
        x = np.sqrt(np.clip(mu, 0.0, 1.0)) * (xn.size - 1)
        j = np.clip(x.astype(np.intp), 0, xn.size - 2)
        fj = (x - j)[..., None]
        t = self.tau
        return ((1 - fi) * ((1 - fj) * t[i, j] + fj * t[i, j + 1])
                + fi * ((1 - fj) * t[i + 1, j] + fj * t[i + 1, j + 1]))

    def __call__(self, h: np.ndarray, mus: np.ndarray, use_kernel: bool = True) -> np.ndarray:
        """``T`` (..., nwl) at altitudes ``h`` [m] and sun zenith cosines ``mus`` (the
        compiled kernel where available; ``use_kernel=False``: the NumPy version, which
        the tests compare it with)."""
        h, mus = np.broadcast_arrays(np.asarray(h, dtype=float), np.asarray(mus, dtype=float))
        kern = _ms_kernel("sun_transmittance") if use_kernel else None
        if kern is not None:
            out = np.empty(h.shape + (self.tau.shape[-1],))
            kern(self.h_nodes, self.tau, float(self.R), float(self.top),
                 np.ascontiguousarray(h).reshape(-1), np.ascontiguousarray(mus).reshape(-1),
                 out.reshape(-1, self.tau.shape[-1]))
            return out
        mus = np.clip(mus, -1.0, 1.0)
        r = self.R + np.clip(h, 0.0, self.top - self.R)
        rp = r * np.sqrt((1.0 - mus) * (1.0 + mus))
        below = mus < 0.0
        up = self._tau_up(h, np.abs(mus))
        tau = np.where(below[..., None], 2.0 * self._tau_up(rp - self.R, 0.0 * mus) - up, up)
        lit = ~(below & (rp < self.R))
        return np.where(lit[..., None], np.exp(-np.maximum(tau, 0.0)), 0.0)


# ----------------------------------------------------------------------------------------
# the grid
# ----------------------------------------------------------------------------------------
class _Field:
    """Node sets of the field: altitude × solar zenith × direction.

    The radiance ``L`` of an order lives at the quadrature directions (Gauss nodes in ``μ``
    × uniform ``φ``); the source ``S = ∫ L p dω′`` is evaluated at fixed output nodes
    ``mu_out`` (double Gauss plus the zenith and the nadir), so that the interpolation in
    ``μ`` spans [−1, 1] without clamping.

    The ``μ`` quadrature of each altitude is split where the radiance is discontinuous:
    at the horizontal and at the horizon ``μ_h = −√(1 − (R/r)²)`` of that altitude, below
    which rays end on the ground (Gauss nodes on [μ_h, 0] — the limb, which at twilight is
    the brightest part of the sky seen from above — and on [−1, μ_h]).  On the ground, and
    where the limb band is narrower than ``μ = 0.02`` (below ~1.3 km), it is double Gauss.
    """

    def __init__(self, atm: qd.PreparedAtmosphere, grid: MultipleScatteringGrid):
        self.atm, self.grid = atm, grid
        self.h_nodes = _altitude_nodes(atm, grid.n_altitude)
        self.ths = grid.sun_zenith_nodes()
        self.th_max = float(self.ths[-1])
        n = grid.n_mu
        self.mu_nodes, self.mu_w = _gauss_split([-1.0, 0.0, 1.0], [n // 2, n // 2])
        self.mu_out = np.concatenate([[-1.0], self.mu_nodes, [1.0]])
        R = atm.planet_radius
        qs = []
        for h in self.h_nodes:
            mu_h = -np.sqrt(max(0.0, 1.0 - (R / (R + h)) ** 2))
            n_limb = n // 4 if (_HORIZON_SPLIT and -mu_h >= 0.02 and n >= 8) else 0
            if n_limb:
                qs.append(_gauss_split([-1.0, mu_h, 0.0, 1.0], [n // 2 - n_limb, n_limb, n // 2]))
            else:
                qs.append((self.mu_nodes, self.mu_w))
        self.mu_q = np.array([q[0] for q in qs])  # (n_alt, n_mu) quadrature nodes
        self.mu_wq = np.array([q[1] for q in qs])  # their weights (∫dμ: sum 2 per altitude)
        self.phi_nodes = np.linspace(0.0, np.pi, grid.n_phi)
        self.shape = (grid.n_altitude, grid.n_sun, grid.n_mu, grid.n_phi)
        self.shape_out = (grid.n_altitude, grid.n_sun, grid.n_mu + 2, grid.n_phi)
        # the gather reads log S on a finer altitude axis: altitude_refine − 1 points
        # inserted in every interval (:func:`_refine_log`)
        h, r = self.h_nodes, grid.altitude_refine
        t = np.arange(r) / r
        self.h_fine = np.concatenate([(h[:-1, None] + t * np.diff(h)[:, None]).ravel(), h[-1:]])
        self.shape_fine = (self.h_fine.size,) + self.shape_out[1:]
        self.band = self._band_nodes()

    def _band_nodes(self):
        """Indices of the solar-zenith nodes where orders ≥ ``grid.band_orders_from`` are
        computed (within ``band_width`` — or ``sun_width`` — of the sun, and one node beyond on each side), or
        ``None``: every node (see :class:`MultipleScatteringGrid`)."""
        g = self.grid
        if (g.band_orders_from is None or g.sun_nodes != "scene" or g.sun_zenith is None
                or g.high_orders is not None):
            return None
        th = np.degrees(self.ths)
        inside = np.flatnonzero(np.abs(th - g.sun_zenith) <= g._band_width())
        lo, hi = max(int(inside[0]) - 1, 0), min(int(inside[-1]) + 1, th.size - 1)
        return None if (lo == 0 and hi == th.size - 1) else np.arange(lo, hi + 1)

    def directions(self, mu=None) -> np.ndarray:
        """Directions (μ-major, φ-minor) in a frame with the sun in the x–z plane."""
        mu = self.mu_nodes if mu is None else mu
        mm, pp = np.meshgrid(mu, self.phi_nodes, indexing="ij")
        st = np.sqrt(np.maximum(1.0 - mm * mm, 0.0))
        return np.stack([st * np.cos(pp), st * np.sin(pp), mm], axis=-1).reshape(-1, 3)

    def _phase_rows(self, i: int) -> np.ndarray:
        """(n_sc, n_out, n_mu, 2(n_phi − 1)) the normalised phase weights of altitude
        ``i``'s quadrature: ``p[c, a, b, D]`` from output direction ``(μ_a, φ_m)`` to
        quadrature direction ``(μ_b, φ_m + D π/(n_phi − 1))``, for any ``m``.

        The scattering angle between the two depends on the azimuth difference only
        (uniform azimuths over the circle), so each phase function is evaluated once per
        ``(a, b, D)``, times the quadrature weight of ``μ_b``; every row (an output
        direction) is normalised to sum to one over the full circle of quadrature
        directions, so that an isotropic field is reproduced exactly (the discrete
        operator conserves energy)."""
        nphi = self.grid.n_phi
        n2 = 2 * (nphi - 1)  # azimuths of the full circle
        mu_o, mu_q, w_q = self.mu_out, self.mu_q[i], self.mu_wq[i]
        s_o = np.sqrt(np.maximum(1.0 - mu_o * mu_o, 0.0))
        s_q = np.sqrt(np.maximum(1.0 - mu_q * mu_q, 0.0))
        cos_d = np.cos(np.pi * np.arange(n2) / (nphi - 1))  # cos Δφ, Δφ = 0 … 2π − π/(nphi−1)
        cos = np.clip(mu_o[:, None, None] * mu_q[None, :, None]
                      + (s_o[:, None] * s_q[None, :])[:, :, None] * cos_d, -1.0, 1.0)
        out = np.empty((len(self.atm.scatterers),) + cos.shape)
        for c, (_, _, phase) in enumerate(self.atm.scatterers):
            p = np.asarray(phase(cos), dtype=float) * w_q[None, :, None]  # (n_out, n_mu, n2)
            p /= np.sum(p, axis=(1, 2), keepdims=True)
            out[c] = p
        return out

    def _distinct_quadratures(self):
        """``(first, same)``: the altitudes whose μ quadrature is the first of its kind
        (altitudes below the limb split share the double Gauss one) and, per altitude, the
        altitude whose operator it shares."""
        keys = {}
        for i, mu_q in enumerate(self.mu_q):
            keys.setdefault(mu_q.tobytes(), i)
        return list(keys.values()), [keys[mu_q.tobytes()] for mu_q in self.mu_q]

    def phase_matrices(self) -> np.ndarray:
        """(n_alt, n_sc, n_out, n_dir) row-normalised discrete phase operators.

        Row ``a`` integrates over the full circle of an altitude's quadrature directions
        (folded onto the half circle 0–π by the symmetry of the field about the solar
        vertical) for the output direction ``a`` of ``mu_out`` × ``phi_nodes``
        (:meth:`_phase_rows`).  The field build applies them in azimuthal Fourier space
        (:meth:`phase_spectra`); this explicit form is the tests' reference.
        """
        nphi = self.grid.n_phi
        n2 = 2 * (nphi - 1)
        # column m′ of output azimuth m sits at Δφ = φ_m′ − φ_m: (m′ − m) mod n2
        shift = (np.arange(n2)[None, :] - np.arange(nphi)[:, None]) % n2  # (nphi, n2)
        n_mu, n_out = self.grid.n_mu, self.mu_out.size
        first, same = self._distinct_quadratures()
        W = np.empty((len(self.mu_q), len(self.atm.scatterers), n_out * nphi, n_mu * nphi))

        def one(i):  # each operator written by one thread only
            for c, p in enumerate(self._phase_rows(i)):
                full = p[:, :, shift].transpose(0, 2, 1, 3)  # (n_out, nphi, n_mu, n2)
                # fold φ and 2π − φ onto the half circle
                folded = W[i, c].reshape(n_out, nphi, n_mu, nphi)
                folded[...] = full[..., :nphi]
                folded[..., 1 : nphi - 1] += full[..., : nphi - 1 : -1]

        _run_cells(one, first, "multiple scattering: phase operators")
        for i, k in enumerate(same):
            if k != i:
                W[i] = W[k]
        return W

    def phase_spectra(self) -> np.ndarray:
        """(n_phi, n_alt, n_sc, n_out, n_mu) the phase operators of :meth:`phase_matrices`
        in azimuthal Fourier space: ``P[κ, i, c, a, b]`` the real discrete Fourier
        coefficient ``κ`` of :meth:`_phase_rows` over the azimuth difference (real: the
        weights are even in it).  The operator is a circular correlation in azimuth, so
        mode ``κ`` of the source is ``Σ_b P[…, κ, a, b]`` times mode ``κ`` of the field
        (:meth:`_FieldState._source`): the same operator as the explicit matrices, to
        round-off, for ``n_phi`` times fewer operations and 1/``n_phi`` of the memory."""
        nphi = self.grid.n_phi
        n_mu, n_out = self.grid.n_mu, self.mu_out.size
        first, same = self._distinct_quadratures()
        P = np.empty((nphi, len(self.mu_q), len(self.atm.scatterers), n_out, n_mu))

        def one(i):
            spec = np.fft.rfft(self._phase_rows(i), axis=-1).real  # (n_sc, n_out, n_mu, nphi)
            P[:, i] = spec.transpose(3, 0, 1, 2)

        _run_cells(one, first, "multiple scattering: phase operators")
        for i, k in enumerate(same):
            if k != i:
                P[:, i] = P[:, k]
        return P


def _gauss_split(edges, counts):
    """Composite Gauss–Legendre nodes/weights on consecutive intervals of ``edges`` (μ),
    ``counts[k]`` nodes on ``[edges[k], edges[k+1]]``; the weights integrate ``dμ`` (they
    sum to 2 over [−1, 1]: ``_ground_irradiance`` relies on it)."""
    nodes, weights = [], []
    for a, b, n in zip(edges[:-1], edges[1:], counts, strict=True):
        if n <= 0:
            continue
        x, w = np.polynomial.legendre.leggauss(int(n))
        nodes.append(a + (b - a) * 0.5 * (x + 1.0))
        weights.append(0.5 * (b - a) * w)
    return np.concatenate(nodes), np.concatenate(weights)


def _altitude_nodes(atm: qd.PreparedAtmosphere, n: int, tau0: float = 0.05) -> np.ndarray:
    """Altitude nodes [m] of the field, equidistributed in a mix of geometry and optics.

    The coordinate ``F(h) = ½ √(h/H) + ½ (1 − ξ(h)/ξ(0))`` with ``H`` the atmosphere's
    thickness and ``ξ(h) = ln(1 + τ(h)/τ₀)``, ``τ(h)`` the vertical optical depth above
    ``h`` (largest over the wavelengths) and ``τ₀ = 0.05``, is sampled uniformly.  The
    first half gives the quadratic clustering toward the ground that suits an Earth-like
    exponential atmosphere (and keeps the thin upper layers, which are what twilight
    lights, resolved); the second follows the optical depth, so an optically thick
    layer gets nodes where its radiance field changes — within the first optical depths
    below its top and near its base — whatever its density profile.
    """
    R, top = atm.planet_radius, atm.top_radius
    thick = top - R
    h = thick * np.linspace(0.0, 1.0, 4001) ** 2
    k = np.zeros_like(h)
    for g in range(len(atm.profiles)):
        k = k + atm.density(g, h) * float(np.max(atm.extinction[g]))
    seg = 0.5 * (k[1:] + k[:-1]) * np.diff(h)
    tau = np.concatenate([np.cumsum(seg[::-1])[::-1], [0.0]])  # optical depth above h
    xi = np.log1p(tau / tau0)
    F = 0.5 * np.sqrt(h / thick)
    if xi[0] > 0:
        F = F + 0.5 * (1.0 - xi / xi[0])
    else:
        F = 2.0 * F
    nodes = np.interp(np.linspace(0.0, F[-1], n), F, h)
    nodes[0], nodes[-1] = 0.0, thick
    return nodes


def _ground_irradiance(field: _Field, L: np.ndarray) -> np.ndarray:
    """Irradiance on the ground per solar zenith node, (n_sun, nwl), from a field L."""
    nphi = field.grid.n_phi
    wphi = np.full(nphi, 2.0 * np.pi / (nphi - 1))  # full circle from the folded half
    wphi[[0, -1]] *= 0.5
    up = field.mu_nodes > 0
    w = (field.mu_nodes[up] * field.mu_w[up])[:, None] * wphi[None, :]
    return np.einsum("skpw,kp->sw", L[0][:, up], w)


def _interp_e(field: _Field, E: np.ndarray, mus: np.ndarray) -> np.ndarray:
    """Ground irradiance at solar zenith ``acos(mus)``: log-linear between the nodes."""
    th = np.clip(np.arccos(np.clip(mus, -1.0, 1.0)), 0.0, field.th_max)
    j = np.clip(np.searchsorted(field.ths, th, side="right") - 1, 0, field.ths.size - 2)
    f = ((th - field.ths[j]) / (field.ths[j + 1] - field.ths[j]))[:, None]
    a0, a1 = E[j], E[j + 1]
    pos = (a0 > 0) & (a1 > 0)
    with np.errstate(divide="ignore", invalid="ignore"):
        geo = a0 * np.exp(f * np.log(np.where(pos, a1, 1.0) / np.where(pos, a0, 1.0)))
    return np.where(pos, geo, (1 - f) * a0 + f * a1)


def _refine_log(field: _Field, logt: np.ndarray, out: np.ndarray | None = None) -> np.ndarray:
    """``log S`` on the node altitudes (n_r, ...) → on :attr:`_Field.h_fine`: between the
    nodes the cubic through the four nearest (shifted inward at the ends), limited to the
    range of the two bracketing values.

    The gather interpolates ``log S`` linearly in altitude, which is exact for a source
    falling exponentially with depth but biased low wherever ``log S`` is concave — e.g.
    in an optically thick conservative layer, whose source is nearly linear in optical
    depth: every order then lost a little energy, and the losses compounded over the
    many orders of such a layer (DISORT case 2D: 6–8 % low at the bottom with 20
    altitudes).  The inserted points from the cubic shorten the span of the linear step
    (its error falls with the square of the refinement) without marching any more
    rays; the limiter keeps them between their neighbours (no overshoot at floored
    "dark" values or at the terminator's steep edge).

    ``out``: an array of the result's shape and dtype to write into (the field state
    reuses one for the table of every order); compiled where numba is available (the
    same sums in the same order as the NumPy lines below).
    """
    h = field.h_nodes
    n, r = h.size, field.grid.altitude_refine
    shape = field.shape_fine + logt.shape[len(field.shape_out):]
    if out is None or out.shape != shape or out.dtype != logt.dtype:
        out = np.empty(shape, dtype=logt.dtype)
    nodes = out[0::r]
    if not (logt.__array_interface__["data"][0] == nodes.__array_interface__["data"][0]
            and logt.strides == nodes.strides and logt.shape == nodes.shape):
        nodes[...] = logt  # (else logt is the node rows themselves: _log_source)
    if r == 1:
        return out
    i0, w = _refine_weights(field)
    kern = _ms_kernel("refine_intervals") if logt.dtype == np.float64 else None
    if kern is not None:
        flat_in = nodes.reshape(n, -1)  # the node rows (a view)
        flat_out = out.reshape(out.shape[0], -1)
        step = max(1, -(-(n - 1) // (2 * _THREADS)))
        _run_cells(lambda a: kern(flat_in, a, min(a + step, n - 1), i0, w, r, flat_out),
                   list(range(0, n - 1, step)))
        return out

    def interval(i):  # the values inserted between nodes i and i + 1 (one thread each)
        a, b = logt[i], logt[i + 1]
        lo, hi = np.minimum(a, b), np.maximum(a, b)
        q0 = i0[i]
        for k in range(1, r):
            if q0 < 0:  # too few nodes for a cubic: the linear step
                mid = a + (b - a) * (k / r)
            else:
                mid = sum(w[i, k - 1, q] * logt[q0 + q] for q in range(4))
            np.clip(mid, lo, hi, out=out[r * i + k])

    _run_cells(interval, list(range(n - 1)))
    return out


def _refine_weights(field: _Field):
    """``(i0, w)`` of :func:`_refine_log`'s cubic per altitude interval: the first of the
    four nodes (``−1``: fewer than four nodes, the linear step) and the Lagrange weights
    (n − 1, r − 1, 4) of the inserted points (kept on the field: computed once)."""
    got = getattr(field, "_refine_w", None)
    if got is not None:
        return got
    h = field.h_nodes
    n, r = h.size, field.grid.altitude_refine
    i0 = np.full(n - 1, -1, dtype=np.int64)
    w = np.zeros((n - 1, max(r - 1, 1), 4))
    for i in range(n - 1):
        if n < 4:
            continue
        i0[i] = min(max(i - 1, 0), n - 4)
        xs = h[i0[i] : i0[i] + 4]
        for k in range(1, r):
            x = h[i] + (h[i + 1] - h[i]) * k / r
            for q in range(4):
                w[i, k - 1, q] = np.prod([(x - xs[m]) / (xs[q] - xs[m]) for m in range(4) if m != q])
    field._refine_w = (i0, w)
    return field._refine_w


def _log_source(field: _Field, S_flat: np.ndarray, out: np.ndarray | None = None) -> np.ndarray:
    """The table the gather reads: ``log S`` (floored, :func:`._ms_gather.log_table`) of a
    source on the node grid ``field.shape_out + (C,)``, refined in altitude
    (:func:`_refine_log`); ``out``: a buffer of the table's shape to write into, whose
    node rows take the logarithms directly."""
    shape = field.shape_fine + S_flat.shape[len(field.shape_out):]
    if out is None or out.shape != shape or out.dtype != np.float64:
        out = np.empty(shape)
    nodes = out[0 :: field.grid.altitude_refine]
    S_flat = np.ascontiguousarray(S_flat)
    floor = _log_floor(S_flat)  # the whole table's, for each part (by altitudes, in threads)

    def part(a):
        sl = slice(a, a + step)
        _log_table(S_flat[sl], out=nodes[sl], floor=floor)

    step = max(1, -(-S_flat.shape[0] // (2 * _THREADS)))
    _run_cells(part, list(range(0, S_flat.shape[0], step)))
    return _refine_log(field, nodes, out)


def _gather_table(field: _Field, S: np.ndarray, out: np.ndarray | None = None):
    """The table the gather reads for a source ``S`` (``field.shape_out + (n_sc, nwl)``):
    :func:`_log_source` prepared as a :class:`._ms_gather.LogTable` (for more than six
    channels the NumPy table is dropped as soon as its slabs exist; ``out``: a buffer
    for the refined table, see :func:`_refine_log`)."""
    return _LogTable(_log_source(field, S.reshape(field.shape_out + (-1,)), out))


def _gather(field: _Field, march: _March, logt: np.ndarray, nsc: int, nwl: int,
            threads: int = 1) -> np.ndarray:
    """Σ_samples w T Σ_i β_i ρ_i S_i → (N, nwl), with ``logt`` = :func:`_log_source` of
    the source S (n_r, n_s, n_out, n_phi, n_sc·nwl)."""
    N, M = march.h.shape
    vals = _gather_kernel(
        logt, field.h_fine, field.ths, field.mu_out,
        march.h, march.mus, march.mu, march.cphi, march.wt.reshape(N, M, nsc * nwl),
        threads=threads, logt=logt,
    )
    return vals.reshape(N, nsc, nwl).sum(axis=1)


class _SourceDropped(LookupError):
    """A field state was asked for a sum that needs a source it dropped (``_SOURCES_BYTES``)."""


#: the largest growth of the brightest source from one order to the next that the checks
#: of :meth:`_FieldState._check_growth` let pass [-].  Physics allows none: the phase
#: operators are row-normalised, so each order's source is at most the brightest radiance
#: of the previous order's field, which is at most the brightest source of that order
#: (times the probability of scattering again before the ray leaves, < 1).  Round-off,
#: quadrature and smooth interpolation error stay far below this margin.
_MAX_ORDER_GROWTH = 1.5


class GridTooCoarseError(ValueError):
    """The field grid of :func:`multiple_scattering` cannot resolve the scene: a
    higher order came out brighter than the one before it, which physics forbids (see
    :meth:`_FieldState._check_growth`)."""


class _FieldState:
    """Successive orders on the grid, extended on demand and cached per atmosphere."""

    #: the largest growth of the brightest source between two successive orders so far
    #: (:meth:`_check_growth`; below 1 in a correct field)
    growth = 0.0

    def __init__(self, atm: qd.PreparedAtmosphere, grid: MultipleScatteringGrid, albedo: float,
                 use_kernel: bool = True):
        self.atm, self.albedo = atm, albedo
        self.use_kernel = use_kernel  # False: order 1 in NumPy (the tests' check)
        self.field = field = _Field(atm, grid)
        nwl = atm.n_wavelengths
        n_r, n_s, n_mu, n_phi = field.shape
        self.marches = {}
        self.rays = {}  # per altitude: the kept node rays of the slice gather (_NodeRays)
        # the marched rays are kept between orders (decided below, from their size)
        self.keep = _have_kernel()
        # kept node rays are gathered by slices (_NodeRays) where the compiled kernels do
        # order 1 (use_kernel=False keeps the per-cell gather of located samples)
        self.slices = self.keep and use_kernel and _SLICE_GATHER and n_s >= 4
        L = np.zeros(field.shape + (nwl,))
        cells = [(i, j) for i in range(n_r) for j in range(n_s)]

        self.sun_t = sun_t = _SunTransmittance(atm)

        # the node rays at one altitude are the same for every solar zenith angle: their
        # march (nodes, weights, view transmittance) is done once per altitude, and so is
        # the packing of the weights that later orders keep
        views = {}

        def view(i):
            dirs = field.directions(field.mu_q[i])
            vm = _march_view(atm, atm.planet_radius + field.h_nodes[i], dirs, grid.order)
            # samples with weight (the rest of the (N, M) batch pads the shorter rays)
            keep = np.any(vm.wt != 0, axis=(-2, -1))
            packed = None
            if self.keep and not self.slices:  # the slice gather keeps its own (_NodeRays)
                N, M = vm.h.shape
                packed = _pack_weights(np.asarray(vm.wt, dtype=np.float32), N, M,
                                       key=_node_sample_order(field, vm.h, vm.mu))
            views[i] = (dirs, vm, keep, packed)

        _run_cells(view, list(range(n_r)), "multiple scattering: view rays")
        if self.keep:
            # kept: per cell the located samples (int32 row + 4 float32 fractions), per
            # altitude the packed float32 weights (shared by the cells of the altitude);
            # with slices, per sample, solar zenith and azimuth two int16 and two float32
            # (the weights and the (altitude, μ) stencil once per view zenith).
            # Beyond the budget the rays are marched again for every order instead.
            k_alt = [int(np.count_nonzero(views[i][2])) for i in range(n_r)]
            size = ((12 if self.slices else 20) * n_s * sum(k_alt)
                    + 4 * sum(k_alt) * nwl * len(atm.scatterers))
            self.keep = size <= _KEEP_BYTES
            if not self.keep:
                self.slices = False
                for i in range(n_r):
                    views[i] = views[i][:3] + (None,)
            if self.slices:
                for i in range(n_r):
                    self.rays[i] = _NodeRays(field, views[i][1], views[i][2])

        def first(cell):
            i, j = cell
            th = field.ths[j]
            s = np.array([np.sin(th), 0.0, np.cos(th)])
            dirs, vm, keep, packed = views[i]
            # order 1: single scattering of the tabulated sun transmittance (the phase
            # function is constant along a straight ray) + ground-reflected direct sun
            P = np.stack([np.asarray(ph(np.clip(dirs @ s, -1.0, 1.0)), dtype=float)
                          for _, _, ph in atm.scatterers], axis=-1)  # (N, n_sc)
            if self.slices:  # order 1 and the stencils of the slice gather, one kernel call
                path, mus_end = self.rays[i].order1(j, vm, s, P, keep, sun_t)
            else:
                mc, path = _order1(vm, s, P, keep, sun_t, self.use_kernel)
                mus_end = mc.mus_end
                if self.keep:
                    self.marches[i, j] = _compact(field, mc, packed)
            if albedo > 0:
                e0 = np.maximum(mus_end, 0.0)[:, None] * sun_t(np.zeros_like(mus_end), mus_end)
                path += np.where(vm.ground[:, None], vm.t_end * albedo / np.pi * e0, 0.0)
            L[i, j] = path.reshape(n_mu, n_phi, nwl)

        _run_cells(first, cells, "multiple scattering: order 1")
        views.clear()  # the packed weights live on in the kept marches
        self.P = field.phase_spectra()  # (n_phi, n_alt, nsc, n_out, n_mu)
        self.L = L  # field of the highest order computed so far
        self._L_prev = None  # the order before it
        self.L_field = field  # the grid it lives on
        self.S: list[np.ndarray] = []  # S^1, S^2, ... (S^k on high_orders for k ≥ K)
        self.high = None  # _HighOrders, made when the first high order is asked for
        self._sums: dict = {}  # running sums of the sources (:meth:`_prefix`)
        self._brightest: dict = {}  # per order, its source's maximum (:meth:`_check_growth`)
        self._table = None  # the buffer of each order's gather table (:meth:`_next_field`)
        self._outs = None  # the buffers of the slice gather's sums (:meth:`_slice_orders`)
        self._spare = None  # a field no order reads any more: the next order's buffer

    def drop_buffers(self):
        """Let go of the working buffers kept between orders (the gather table, the slice
        gather's sums, the spare field): made again if the state is extended."""
        self._table = self._outs = self._spare = None
        self._scaled = None  # (band, outside slices, factors) of the order just extrapolated

    def _high_from(self):
        """The first order K on the grid's ``high_orders`` (``None``: no such grid)."""
        g = self.field.grid
        return None if g.high_orders is None else g.high_orders_from

    def _source(self, L, f=None, P=None, cols=None):
        """``S = ∫ L p dω′`` at the output nodes of ``f`` (``field.shape_out + (n_sc,
        nwl)``) for a field ``L`` on its quadrature, with the phase operators in
        azimuthal Fourier space ``P`` (:meth:`_Field.phase_spectra`): the field extended
        to the full circle by its symmetry about the solar vertical, its real Fourier
        modes over azimuth, per mode and altitude one matrix product over the view
        zeniths, and back (cosine transforms).  Equal to round-off to the explicit operator
        (:meth:`_Field.phase_matrices`; ``tests/test_multiple.py``); values below zero
        by round-off (a dark column) are set to zero.  ``cols``: ``(j_lo, j_hi)``, only
        these solar-zenith nodes are formed (the rest of the result is left unset)."""
        f = self.field if f is None else f
        P = self.P if P is None else P
        n_r, n_s, n_mu, n_phi = f.shape
        nsc, nwl = len(self.atm.scatterers), self.atm.n_wavelengths
        n_out = P.shape[3]
        # the modes of a field even in φ over the full circle (a cosine transform of the
        # half circle, as one matrix product: faster here than an FFT along a middle axis)
        c = np.cos(np.pi * np.outer(np.arange(n_phi), np.arange(n_phi)) / (n_phi - 1))
        w = np.full(n_phi, 2.0)
        w[[0, -1]] = 1.0  # φ = 0 and π appear once on the circle, the others twice
        fwd, back = c * w, c * (w / (2 * (n_phi - 1)))
        S = np.empty(f.shape_out + (nsc, nwl))
        j_lo, j_hi = (0, n_s) if cols is None else cols
        nc = j_hi - j_lo

        def part(a):  # altitude a (one per task: the temporaries stay small, about 1 MB,
            # and are reused from one task to the next; parts of several altitudes made
            # 10–50 MB of fresh temporaries each, whose page faults cost 0.5 s per order of
            # a T 10 sunset on the 2-core virtual machine)
            b = a + 1
            modes = np.tensordot(fwd, L[a:b, j_lo:j_hi], axes=([1], [3]))  # (n_phi, b−a, nc, n_mu, nwl)
            modes = modes.transpose(0, 1, 3, 2, 4).reshape(n_phi, b - a, 1, n_mu, nc * nwl)
            Sm = np.matmul(P[:, a:b], modes)  # (n_phi, b−a, nsc, n_out, nc·nwl): the mode
            # axis first, so that the way back is one matrix product over a contiguous array
            Sa = np.tensordot(back, Sm, axes=([1], [0]))  # (n_phi, …)
            Sa = Sa.reshape(n_phi, b - a, nsc, n_out, nc, nwl).transpose(1, 4, 3, 0, 2, 5)
            np.maximum(Sa, 0.0, out=S[a:b, j_lo:j_hi])

        _run_cells(part, list(range(n_r)))
        return S

    def _next_field(self, S):
        f = self.field
        E = _ground_irradiance(f, self.L) if self.albedo > 0 else None
        # the field two orders back, which nothing reads any more, takes the new one (a
        # fresh array per order cost its page faults each time)
        Lnew, self._spare = self._spare, None
        if Lnew is None or Lnew.shape != self.L.shape or Lnew.dtype != self.L.dtype:
            Lnew = np.zeros_like(self.L)
        else:
            Lnew.fill(0.0)
        n_mu, n_phi = f.shape[2:]
        nsc, nwl = S.shape[-2:]
        # once per order, into one buffer reused by every order (a fresh 0.1 GB table per
        # order cost its page faults each time); no table of an earlier order is read again
        if self._table is None:
            self._table = np.empty(f.shape_fine + (nsc * nwl,))
        logS = _gather_table(f, S, self._table)

        def cell(ij):
            i, j = ij
            mc = self.marches.get((i, j))
            if mc is None:
                th = f.ths[j]
                s = np.array([np.sin(th), 0.0, np.cos(th)])
                mc = _march(self.atm, self.atm.planet_radius + f.h_nodes[i],
                            f.directions(f.mu_q[i]), s, f.grid.order)
            if not isinstance(mc, _Compact):
                path = _gather(f, mc, logS, nsc, nwl)
            else:
                path = mc.loc.gather(logS).reshape(-1, nsc, nwl).sum(axis=1)
            if E is not None:
                e = _interp_e(f, E, mc.mus_end)
                path += np.where(mc.ground[:, None], mc.t_end * self.albedo / np.pi * e, 0.0)
            Lnew[i, j] = path.reshape(n_mu, n_phi, -1)

        k = len(self.S) + 1  # the order computed
        band = f.band if (f.band is not None and k >= f.grid.band_orders_from) else None
        cols = range(f.shape[1]) if band is None else band
        if self.rays:
            self._slice_orders(logS, Lnew, int(cols[0]), int(cols[-1]) + 1, E,
                               f"multiple scattering: order {k}")
        else:
            _run_cells(cell, [(i, j) for i in range(f.shape[0]) for j in cols],
                       f"multiple scattering: order {k}")
        if band is not None:
            # the new source outside the band follows by the same factors (:meth:`_extend`)
            self._scaled = (band,) + self._extrapolate_outside(Lnew, band)
        return Lnew

    def _slice_orders(self, logS, Lnew, j_lo, j_hi, E, stage):
        """The next order's field ``Lnew`` at the solar-zenith nodes ``j_lo``–``j_hi``
        (exclusive) from the kept node rays by the slice gather (:class:`_NodeRays`), in
        work units of a few view zeniths of one altitude over the thread pool, each also
        summing its rays over the scatterers and adding the ground's reflection of
        ``E``."""
        f = self.field
        n_r, n_s, n_mu, n_phi = f.shape
        nsc, nwl = len(self.atm.scatterers), self.atm.n_wavelengths
        nj = j_hi - j_lo
        # per altitude, one array per slab of channels of the table (six at a time), kept
        # for every order: each unit zeroes the part it adds to (fresh arrays, 46 MB per
        # order from space, cost more in page faults than the zeroing)
        shapes = [(n_s, n_mu, n_phi, c1 - c0) for c0, c1, _ in logS.blocks]
        if self._outs is None or [b.shape for b in self._outs[0]] != shapes:
            self._outs = [[np.empty(sh) for sh in shapes] for _ in range(n_r)]
        outs = self._outs
        step = max(1, n_mu // 4)
        units = [(i, k) for i in range(n_r) for k in range(0, n_mu, step)]

        def unit(ik):
            i, k0 = ik
            k1 = min(k0 + step, n_mu)
            rays = self.rays[i]
            for b in outs[i]:
                b[j_lo:j_hi, k0:k1] = 0.0
            rays.gather(logS, k0, k1, j_lo, j_hi, outs[i])
            o = np.concatenate([b[j_lo:j_hi, k0:k1] for b in outs[i]], axis=-1)
            o = o.reshape(nj, k1 - k0, n_phi, nsc, nwl)
            path = o[..., 0, :].copy()
            for c in range(1, nsc):  # the scatterers in turn (as a sum over their axis)
                path += o[..., c, :]
            if E is not None:
                rs = slice(k0 * n_phi, k1 * n_phi)  # these view zeniths' rays
                for j in range(j_lo, j_hi):
                    e = _interp_e(f, E, rays.mus_end[j, rs])
                    path[j - j_lo] += np.where(rays.ground[rs, None],
                                               rays.t_end[rs] * self.albedo / np.pi * e,
                                               0.0).reshape(k1 - k0, n_phi, nwl)
            Lnew[i, j_lo:j_hi, k0:k1] = path

        _run_cells(unit, units, stage)

    def _extrapolate_outside(self, Lnew, band):
        """Fill the solar-zenith nodes outside ``band`` of the order being computed
        (``Lnew``) from the two previous orders: each cell (altitude × solar zenith) and
        wavelength times the ratio of its summed radiance in the last two orders, capped
        at the largest such ratio in the band and at 0.98 (a cell dark in an early order,
        e.g. in the planet's shadow, would otherwise keep a ratio above 1)."""
        a, b = self.L, self._L_prev
        sa, sb = (np.einsum("ijmpw->ijw", x) for x in (a, b))  # (n_r, n_s, nwl)
        with np.errstate(divide="ignore", invalid="ignore"):
            r = np.where(sb > 0, sa / np.where(sb > 0, sb, 1.0), 0.0)
        cap = np.minimum(np.max(r[:, band], axis=(0, 1)), 0.98)  # (nwl,)
        r = np.clip(r, 0.0, cap)  # (read outside the band only)
        outside = _outside(band, Lnew.shape[1])
        for sl in outside:  # two runs of nodes (slices: no fancy-index copies)
            np.multiply(a[:, sl], r[:, sl, None, None, :], out=Lnew[:, sl])
        return outside, r

    def _split(self, n: int, copy: bool = True):
        """``(Σ of the sources S^1..S^n on this grid, Σ of those on high_orders or None)``,
        from running sums kept per order (added in order, as a sum over the list would:
        the same values, without forming every sum anew in each order of the
        automatic loop; ``copy=False``: the kept sums themselves)."""
        K = self._high_from()
        n_low = n if K is None else min(n, K - 1)
        return (self._prefix(0, n_low, copy),
                self._prefix(n_low, n, copy) if n > n_low else None)

    def _prefix(self, a: int, b: int, copy: bool = True) -> np.ndarray:
        """``S^{a+1} + … + S^b`` (a fresh array; ``copy=False``: the kept one), from
        ``self._sums[(a, b - 1)]``.

        Raises :class:`_SourceDropped` where it needs a source dropped to keep the state
        within ``_SOURCES_BYTES``."""
        sums = self._sums
        if (a, b) not in sums:
            if b - a <= 1:
                sums[(a, b)] = self._order(a) if b > a else np.zeros_like(self._order(0))
            else:
                prev = self._prefix(a, b - 1, copy=False)
                # only the last two are read again: the sum before them gives its memory
                # to the new one (a 24 MB array per order of the default grid), unless it
                # is a source itself (a sum of one order)
                old = sums.pop((a, b - 2), None)
                if old is None or old.shape != prev.shape or any(old is x for x in self.S):
                    old = None
                sums[(a, b)] = np.add(prev, self._order(b - 1), out=old)
        return sums[(a, b)].copy() if copy else sums[(a, b)]

    def _order(self, k: int) -> np.ndarray:
        """``S^{k+1}`` (``self.S[k]``), or :class:`_SourceDropped` if it was dropped."""
        if self.S[k] is None:
            raise _SourceDropped(k + 1)
        return self.S[k]

    def _drop_old(self):
        """Hold the kept sources to ``_SOURCES_BYTES``: drop the oldest but the last two
        (the decay test reads only those), once the running sums include the newest."""
        kept = [k for k, S in enumerate(self.S) if S is not None]
        size = sum(self.S[k].nbytes for k in kept)
        if size <= _SOURCES_BYTES:
            return
        self._split(len(self.S), copy=False)  # the sums hold every source before any goes
        for k in kept[:-2]:
            if size <= _SOURCES_BYTES:
                break
            size -= self.S[k].nbytes
            self.S[k] = None

    def _on_grid(self, low, high):
        """A split sum (:meth:`_split`) as one source on this grid's nodes."""
        return low if high is None else low + self.high.to_fine(high)

    def source_sum(self, orders: int) -> np.ndarray:
        """Σ_{k=1}^{orders-1} S^k (on this grid's nodes)."""
        while len(self.S) < orders - 1:
            self._extend()
        return self._on_grid(*self._split(orders - 1))

    def _extend(self):
        K = self._high_from()
        k = len(self.S) + 1  # the order of the field computed now
        if self.S and K is not None and k >= K:
            if self.high is None:
                self.high = _HighOrders(self.atm, self.field.grid.high_orders, self.albedo,
                                        self.field)
            E = (_ground_irradiance(self.L_field, self.L), self.L_field) if self.albedo > 0 else None
            src = self.field if k == K else self.high.field
            self.L = self.high.next_field(self.S[-1], src, E, first=(k == K))
            self.L_field = self.high.field
            self.S.append(self._source(self.L, self.high.field, self.high.P))
            self._drop_old()
            self._check_growth()
            return
        self._scaled = None
        if self.S:
            new = self._next_field(self.S[-1])
            # _extrapolate_outside reads both; the one before them is read no more
            self._spare = self._L_prev
            self._L_prev, self.L = self.L, new
        if self._scaled is None or self.S[-1] is None:
            S = self._source(self.L)
        else:
            # outside the band the new field is the previous one times a factor per cell
            # (altitude × solar zenith) and wavelength, constant over its directions, so its
            # source is the previous source times the same factor (the phase operator acts
            # on the directions of a cell): formed only in the band
            band, outside, r = self._scaled
            S = self._source(self.L, cols=(int(band[0]), int(band[-1]) + 1))
            for sl in outside:
                np.multiply(self.S[-1][:, sl], r[:, sl, None, None, None, :], out=S[:, sl])
        self.S.append(S)
        self._drop_old()
        self._check_growth()

    def _check_growth(self):
        """Raise :class:`GridTooCoarseError` where the newest order's brightest source (per
        wavelength, over the whole grid) exceeds the previous order's by more than
        :data:`_MAX_ORDER_GROWTH`.

        Each order's source is at most the previous one's maximum (the phase operators are
        row-normalised and a ray's scattering weights sum to at most one), so growth means
        the gather's interpolation went wrong: on a grid whose solar-zenith nodes are
        several degrees apart across the terminator, the cubic in ``log S`` along the solar
        zenith overshoots by orders of magnitude between a lit node and a dark one (a quick
        test grid with 10 nodes at sun −6° grew by 1e10 in order 2).  The check costs one
        maximum per order; it does not catch small local errors, only the catastrophic
        ones, which would otherwise be returned as radiance.  The bound holds for the
        whole grid, not for a part of it (the air near a sun deep below the horizon is lit
        by light scattered elsewhere), so the check reads every node."""
        if len(self.S) < 2 or self.S[-2] is None:
            return
        n = len(self.S)

        def brightest(k):  # per wavelength, over the whole grid, of S^{k+1} (once each)
            if k not in self._brightest:
                self._brightest[k] = _channel_max(self.S[k])
            return self._brightest[k]

        m_new, m_old = brightest(n - 1), brightest(n - 2)
        ratio = m_new / np.maximum(m_old, 1e-300)
        self.growth = max(self.growth, float(np.max(ratio)))
        bad = m_new > _MAX_ORDER_GROWTH * m_old
        if np.any(bad) or not np.all(np.isfinite(m_new)):
            c = int(np.argmax(~np.isfinite(m_new) | bad))
            g = self.field.grid
            raise GridTooCoarseError(
                f"grid: order {len(self.S)} of the multiple-scattering field came out "
                f"{ratio[c]:.3g} times as bright as order {len(self.S) - 1} "
                f"(wavelength index {c}; no order can be brighter than the one before): the "
                f"grid (n_sun={g.n_sun}, n_altitude={g.n_altitude}"
                + ("" if g.sun_zenith is None else f", centred on solar zenith {g.sun_zenith:.4g} deg")
                + ") is too coarse for "
                "this scene, its interpolation between solar-zenith nodes overshoots across "
                "the terminator; use more solar-zenith nodes (n_sun, horizon_n_sun) or a "
                "named grid")

    def _floor(self, total: np.ndarray, top: float, field: _Field):
        """Sources below this are left out of the decay test of :meth:`converged_sum`.

        On a grid centred on the scene's sun, ``1e-6`` of the brightest source of the
        node's own solar-zenith column or of the scene's column, whichever is brighter, per
        wavelength: every source the scene's rays read brighter than a millionth of the
        scene's own is tested.  Until version 2 of the rule (:data:`_SUM_RULE`) the floor
        was ``1e-6`` of the brightest source anywhere on the grid, which at twilight lies
        in the sunlit columns, thousands of times brighter than the scene's: the air the
        scene saw was not tested, and the summed multiple-scattering part was up to
        2.6e-3 off at ``order_tolerance=1e-3`` (T 10, sun −10°, default grid; 7e-3 on a
        coarse grid at T 1.5, sun −16°).  On a grid over every sun every column may be a
        scene's: the floor stays ``1e-6`` of the grid's brightest source (``top``).
        ``field``: the grid ``total`` lives on (``high_orders`` from its first order)."""
        g = field.grid
        if g.sun_zenith is None:
            return 1e-6 * top
        # the largest value per solar-zenith column and wavelength: (1, n_sun, 1, …, 1, nwl)
        n_r, n_s, nwl = total.shape[0], total.shape[1], total.shape[-1]
        col = np.max(total.reshape(n_r, n_s, -1), axis=0).reshape(n_s, -1, nwl).max(axis=1)
        col = col.reshape((1, n_s) + (1,) * (total.ndim - 3) + (nwl,))
        j = int(np.argmin(np.abs(np.degrees(field.ths) - g.sun_zenith)))
        return 1e-6 * np.maximum(col, col[:, j:j + 1])

    def converged_sum(self, tol: float, max_orders: int, accelerate: float = _ACCELERATION):
        """Σ S^k over all orders, to relative accuracy ``tol``.

        Successive orders decay geometrically once the field has its asymptotic shape:
        ``S^{k+1} ≈ r S^k`` element by element, with ``r = S^k / S^{k−1}`` (where
        ``S^{k−1}`` is below 1e-6 of the largest value, the ratio of the maxima is used;
        ``r`` is capped at 0.98).  After each order the omitted tail is estimated as
        ``T = S^k r/(1 − r)``; the sum stops at the first order whose tail, relative to
        the accumulated source, is below ``accelerate · tol`` and the estimated tail is
        *added* (a geometric, Aitken-type extrapolation).  The extrapolation's own error
        is the tail times the relative change of ``r/(1 − r)`` between the last two
        orders, which is required to be below ``tol`` as well; ``accelerate=1`` recovers
        plain summation to ``tol`` (without the tail).

        With a band (``grid.band_orders_from``, :meth:`_Field._band_nodes`) the test runs
        on the band's solar-zenith nodes, which are all the scene reads; the tail is added
        everywhere.

        Returns ``(S_sum, orders, tail)``: the summed source, the number of orders
        computed (``orders − 1`` sources) and the relative tail estimate at the stop
        (``orders`` is capped at ``max_orders``; then ``tail`` says what was reached).
        """
        k = 2
        g_prev = None
        spare = None  # the decay test's other buffer for g (_decay_test's out)
        K = self._high_from()
        band = self.field.band
        # the nodes the test looks at (a band exists only without high_orders, and is a
        # contiguous run of solar-zenith nodes: a view, no copy)
        test = slice(None) if band is None else slice(int(band[0]), int(band[-1]) + 1)
        while True:
            while len(self.S) < k - 1:  # (source_sum without its copy of the sum)
                self._extend()
            # the kept running sums themselves (no copy: only read here); the sum returned
            # is a fresh array on this grid
            low, high = self._split(k - 1, copy=False)
            # the decay test runs on the grid of the last order (on high_orders, the sum
            # and the previous order resampled there)
            on_high = high is not None
            total = low if not on_high else self.high.from_fine(low) + high
            top = float(np.max(total[:, test])) if total.size else 0.0
            if top <= 0.0:  # nothing scatters twice
                return self._on_grid(*self._split(k - 1)), k, 0.0
            if len(self.S) >= 2:
                last, prev = self._order(k - 2), self._order(k - 3)
                if on_high and k - 2 == K - 1:  # the first high order: prev on this grid
                    prev = self.high.from_fine(prev)
                    g_prev = None
                floor = self._floor(total, top, self.high.field if on_high else self.field)
                m_prev = float(np.max(prev[:, test]))
                r_all = float(np.max(last[:, test])) / m_prev if m_prev > 0 else 0.0

                # the test reads the band only: r, g and the tail are formed there (the
                # same values, elementwise, as over the whole grid); the tail added to the
                # sum is formed everywhere, once, at the stop
                # two buffers for g, taken in turn (g_prev is the other one)
                g, rel, drift = _decay_test(last, prev, total, floor, r_all, test, g_prev,
                                            out=spare)
                if accelerate <= 1.0:
                    if rel <= tol or k >= max_orders:
                        return self._on_grid(*self._split(k - 1)), k, rel
                else:
                    if (rel <= accelerate * tol and rel * drift <= tol) or rel <= tol:
                        # the tail lives on the grid of the last order
                        low, high = self._split(k - 1)  # (fresh arrays: added to in place)
                        if band is not None:  # g over every node, by the same compiled pass
                            g = _decay_test(last, prev, total, floor, r_all, slice(None), None)[0]
                        tail = np.multiply(last, g, out=g)
                        np.add(high if on_high else low, tail, out=high if on_high else low)
                        return self._on_grid(low, high), k, rel * min(drift, 1.0)
                    if k >= max_orders:
                        return self._on_grid(*self._split(k - 1)), k, rel
                spare, g_prev = g_prev, g
            k += 1


def _outside(band: np.ndarray, n: int) -> tuple[slice, slice]:
    """The solar-zenith nodes of ``n`` outside a band (a contiguous run of nodes), as the
    two slices below and above it."""
    return slice(0, int(band[0])), slice(int(band[-1]) + 1, n)


def _decay_test(last, prev, total, floor, r_all, sl, g_prev, out=None):
    """``(g, rel, drift)`` of :meth:`_FieldState.converged_sum`'s decay test on the
    solar-zenith nodes ``sl``: ``g`` = :func:`_growth`, ``rel`` the largest tail
    relative to the sum, ``last g/(total + floor)``, and ``drift`` the largest relative
    change of ``g`` since ``g_prev`` where ``last`` is above the floor (``inf`` without
    ``g_prev``).  One compiled pass where available (in NumPy these were six passes with
    temporaries over the band, 40 ms per order of the default grid); the same values.
    ``out``: a C-contiguous array of ``g``'s shape to write ``g`` into (not ``g_prev``;
    a fresh array per order cost up to 0.2 s of page faults from space)."""
    kern = _ms_kernel("decay_test")
    if kern is None:
        g = _growth(last, prev, floor, r_all, sl)
        lt, fl = last[:, sl], (floor[:, sl] if np.ndim(floor) else floor)
        rel = float(np.max(lt * g / (total[:, sl] + fl)))
        drift = (float(np.max(np.abs(g - g_prev) / np.maximum(g, 1e-300) * (lt > fl)))
                 if g_prev is not None else np.inf)
        return g, rel, drift
    n_r, nwl = last.shape[0], last.shape[-1]
    lt, pv, tt = (a[:, sl] for a in (last, prev, total))
    nc = lt.shape[1]
    shape3 = (n_r, nc, -1)
    fl = (np.ascontiguousarray(floor[:, sl].reshape(nc, nwl)) if np.ndim(floor)
          else np.full((nc, nwl), float(floor)))
    g = (out if (out is not None and out.shape == lt.shape and out.flags.c_contiguous
                 and out is not g_prev) else np.empty(lt.shape))
    gp = g_prev if g_prev is not None else g
    rel, drift = kern(lt.reshape(shape3), pv.reshape(shape3), tt.reshape(shape3), fl,
                      float(r_all), gp.reshape(shape3), g_prev is not None, g.reshape(shape3))
    return g, float(rel), (float(drift) if g_prev is not None else np.inf)


def _growth(last, prev, floor, r_all, sl):
    """``r/(1 − r)`` of the decay test of :meth:`_FieldState.converged_sum` on the
    solar-zenith nodes ``sl``, elementwise: ``r = last/prev`` where ``prev`` is above the
    floor (scalar or per column, :meth:`_FieldState._floor`), else ``r_all``, capped at
    0.98."""
    pv, fl = prev[:, sl], (floor[:, sl] if np.ndim(floor) else floor)
    with np.errstate(divide="ignore", invalid="ignore"):
        r = np.where(pv > fl, last[:, sl] / np.where(pv > fl, pv, 1.0), r_all)
    r = np.clip(r, 0.0, 0.98)
    return r / (1.0 - r)


def _node_sample_order(field: _Field, h: np.ndarray, mu: np.ndarray) -> np.ndarray:
    """Sort key (N, M) of node-ray samples at altitudes ``h`` and view cosines ``mu``: the
    (refined altitude, ``μ``) interval of the source table each one reads.  Neither
    depends on the sun, so one order serves every cell of an altitude (the packed weights
    are shared).  Gathered in this order, a cell reads the table nearly in sequence
    instead of jumping across it ray by ray: the same sums (in another order: round-off),
    faster on the 2-core machine, whose cores share their last-level cache with other
    work (``benchmarks/bench_multiple.py::test_first_call_earth_rgb``; CHANGELOG)."""
    i = np.clip(np.searchsorted(field.h_fine, h, side="right") - 1, 0, field.h_fine.size - 2)
    k = np.clip(np.searchsorted(field.mu_out, mu, side="right") - 1, 0, field.mu_out.size - 2)
    return i * field.mu_out.size + k


def _resample(src: _Field, S: np.ndarray, dst: _Field, threads: int = 1) -> np.ndarray:
    """A source ``S`` on ``src``'s output nodes (``src.shape_out + (n_sc, nwl)``) at
    ``dst``'s output nodes, by the interpolation every ray sample uses (:mod:`._ms_gather`:
    ``log S`` cubic in solar zenith, linear in the refined altitude, ``μ`` and ``φ``)."""
    hh, tt, mm, pp = np.meshgrid(dst.h_nodes, dst.ths, dst.mu_out, dst.phi_nodes, indexing="ij")
    n = hh.size
    C = S.shape[-2] * S.shape[-1]
    table = _gather_table(src, S)
    vals = _gather_kernel(
        table, src.h_fine, src.ths, src.mu_out, hh.reshape(n, 1), np.cos(tt).reshape(n, 1),
        mm.reshape(n, 1), np.cos(pp).reshape(n, 1), np.ones((n, 1, C)), threads=threads,
        logt=table,
    )
    return vals.reshape(dst.shape_out + S.shape[-2:])


class _HighOrders:
    """The orders from ``grid.high_orders_from`` on, on the coarser grid ``grid.high_orders``.

    Its node rays are marched once (per altitude; completed per solar zenith) and located
    twice: in the fine grid's table, for the first high order (whose source is the last
    fine order's), and in their own table for the orders after it.  The sources are
    brought back to the fine grid's nodes by :meth:`to_fine` before they are summed, so the
    summed source, its table and everything downstream keep the fine grid's layout.
    """

    def __init__(self, atm: qd.PreparedAtmosphere, grid: MultipleScatteringGrid, albedo: float,
                 fine: _Field):
        self.atm, self.albedo, self.fine = atm, albedo, fine
        self.field = f = _Field(atm, grid)
        self.P = f.phase_spectra()
        n_r, n_s = f.shape[:2]
        views = {}

        def view(i):
            vm = _march_view(atm, atm.planet_radius + f.h_nodes[i], f.directions(f.mu_q[i]),
                             grid.order)
            N, M = vm.h.shape
            # float64 weights, as the fine grid's slice gather keeps them (_NodeRays)
            packed = (_pack_weights(np.asarray(vm.wt, dtype=np.float64), N, M,
                                    key=_node_sample_order(f, vm.h, vm.mu))
                      if _have_kernel() else None)
            views[i] = (vm, packed)

        _run_cells(view, list(range(n_r)), "multiple scattering: high-order rays")
        self.marches = {}

        def cell(ij):
            i, j = ij
            th = f.ths[j]
            vm, packed = views[i]
            mc = _march_sun(vm, np.array([np.sin(th), 0.0, np.cos(th)]))
            own = _compact(f, mc, packed)
            first = _compact(fine, mc, packed)
            self.marches[i, j] = (own, first)

        _run_cells(cell, [(i, j) for i in range(n_r) for j in range(n_s)],
                   "multiple scattering: high-order rays")
        views.clear()

    def next_field(self, S: np.ndarray, src: _Field, E, first: bool) -> np.ndarray:
        """The field of the next order on this grid from the source ``S`` on ``src`` (the
        fine grid for the first high order, else this one); ``E``: ``(ground irradiance,
        its grid)`` of the previous order, or ``None`` for a black ground."""
        f = self.field
        nsc, nwl = S.shape[-2:]
        logS = _gather_table(src, S)
        Lnew = np.zeros(f.shape + (nwl,))
        n_mu, n_phi = f.shape[2:]

        def cell(ij):
            own, loc_first = self.marches[ij]
            mc = loc_first if first else own
            if isinstance(mc, _Compact):
                path = mc.loc.gather(logS).reshape(-1, nsc, nwl).sum(axis=1)
            else:
                path = _gather(src, mc, logS, nsc, nwl)
            if E is not None:
                e = _interp_e(E[1], E[0], own.mus_end)
                path += np.where(own.ground[:, None], own.t_end * self.albedo / np.pi * e, 0.0)
            Lnew[ij] = path.reshape(n_mu, n_phi, -1)

        _run_cells(cell, list(self.marches), "multiple scattering: high order")
        if first:  # the rays' location in the fine table is needed once
            self.marches = {ij: (own, None) for ij, (own, _) in self.marches.items()}
        return Lnew

    def to_fine(self, S: np.ndarray) -> np.ndarray:
        """A source on this grid at the fine grid's output nodes."""
        return _resample(self.field, S, self.fine, _THREADS)

    def from_fine(self, S: np.ndarray) -> np.ndarray:
        """A source on the fine grid at this grid's output nodes."""
        return _resample(self.fine, S, self.field, _THREADS)


class _NodeRays:
    """The node rays of one altitude kept between orders for the slice gather
    (:func:`._ms_kernels.gather_slices`).

    The rays of an altitude that share their view zenith share their samples for every
    solar zenith and azimuth, so the samples with weight are kept once per view zenith
    — the (altitude, μ) part of their stencil and their weights (float64: a few MB) —
    and, per
    sample, solar-zenith node and azimuth node, the (θ_s, φ) part of the stencil (int16
    node indices and float32 fractions, filled by order 1: :meth:`order1`), found by
    the same formulas as :class:`._ms_gather.Located`.  About 12 bytes per sample of
    every node ray, against 20 for the located samples of each cell, and a gather that
    reads a quarter of the table values per sample."""

    def __init__(self, field: _Field, vm: _ViewMarch, keep: np.ndarray):
        n_r, n_s, n_mu, n_phi = field.shape
        N, M = vm.h.shape
        # the rays of one view zenith (μ-major, φ-minor) are marched alike: take φ = 0's
        rep = np.arange(n_mu) * n_phi
        kk = keep[rep]  # (n_mu, M)
        counts = np.count_nonzero(kk, axis=1)
        self.starts = np.concatenate([[0], np.cumsum(counts)]).astype(np.int64)
        k_idx, m_idx = np.nonzero(kk)  # along each ray, ray by ray
        K = k_idx.size
        C = vm.wt.shape[-2] * vm.wt.shape[-1]
        h = np.ascontiguousarray(vm.h[rep[k_idx], m_idx], dtype=np.float64)
        mu = np.ascontiguousarray(vm.mu[rep[k_idx], m_idx], dtype=np.float64)
        self.hrow = np.empty(K, dtype=np.int64)
        self.fh, self.fmu = np.empty(K), np.empty(K)
        _ms_kernel("locate_geometry")(field.h_fine, field.mu_out, h, mu, n_s, n_mu + 2, n_phi,
                                      self.hrow, self.fh, self.fmu)
        # the fractions rounded to float32, as the located samples have always kept them
        # (the published accuracy tables were computed so)
        self.fh = self.fh.astype(np.float32).astype(np.float64)
        self.fmu = self.fmu.astype(np.float32).astype(np.float64)
        self.wt = np.ascontiguousarray(vm.wt.reshape(N, M, C)[rep[k_idx], m_idx], dtype=np.float64)
        # the kept sample of each view zenith's node (−1: none)
        self.slot = np.full((n_mu, M), -1, dtype=np.int64)
        self.slot[k_idx, m_idx] = np.arange(K)
        # node indices in one byte where the grid allows (a sixth less memory to fill)
        small = np.int8 if max(n_s, n_phi) <= np.iinfo(np.int8).max else np.int16
        self.jt = np.empty((K, n_s, n_phi), dtype=small)
        self.mp = np.empty((K, n_s, n_phi), dtype=small)
        self.ft = np.empty((K, n_s, n_phi), dtype=np.float32)
        self.fp = np.empty((K, n_s, n_phi), dtype=np.float32)
        self.th_nodes = np.ascontiguousarray(field.ths, dtype=np.float64)
        self.inv = _ms_kernel("lagrange_inverse_denominators")(self.th_nodes)
        self.ground = vm.ground
        self.t_end = vm.t_end
        self.mus_end = np.empty((n_s, N))

    def order1(self, j: int, vm: _ViewMarch, s: np.ndarray, P: np.ndarray, keep: np.ndarray,
               sun_t: _SunTransmittance):
        """Order 1 of solar-zenith node ``j`` (sun ``s``) of these rays — the path of
        :func:`_order1`, (N, nwl) — in one compiled call that also fills the node's
        stencils (:func:`._ms_kernels.order1_located`); returns ``(path, mus_end)``."""
        N, M = vm.h.shape
        nu, mus_end = _sun_at_ends(vm, s)
        path = np.empty((N, vm.wt.shape[-1]))
        _ms_kernel("order1_located")(
            vm.sigma, vm.rr, vm.s0, float(vm.r0), float(s[2]), nu, vm.mu, vm.h, vm.wt,
            np.ascontiguousarray(P, dtype=float), keep, sun_t.h_nodes, sun_t.tau,
            float(sun_t.R), float(sun_t.top), self.slot, self.th_nodes, int(j),
            self.jt, self.ft, self.mp, self.fp, path)
        self.mus_end[j] = mus_end
        return path, mus_end

    def gather(self, logS, k0: int, k1: int, j_lo: int, j_hi: int, outs: list) -> None:
        """Add the paths of view zeniths ``k0``–``k1`` at solar-zenith nodes ``j_lo``–``j_hi``
        for the log table ``logS`` (a :class:`._ms_gather.LogTable`) to ``outs``: one array
        (n_s, n_mu, n_phi, c1 − c0) per slab ``(c0, c1)`` of the table's channels."""
        n_s, _, n_phi, _ = outs[0].shape
        n_out = logS.shape[2]
        for (c0, c1, flat), out in zip(logS.blocks, outs, strict=True):
            kern = _ms_kernel("gather_slices6" if c1 - c0 == 6 else "gather_slices")
            wt = self.wt if len(logS.blocks) == 1 else np.ascontiguousarray(self.wt[:, c0:c1])
            kern(flat, n_s, n_out, n_phi, self.th_nodes, self.inv, self.starts, k0, k1,
                 self.hrow, self.fh, self.fmu, wt, self.jt, self.ft, self.mp, self.fp,
                 j_lo, j_hi, out)


@dataclass
class _Compact:
    """A node ray set kept between orders: located samples with their float32 weights."""

    loc: object  # _ms_gather.Located (holds the packed (K, n_sc * nwl) float32 weights)
    ground: np.ndarray
    t_end: np.ndarray
    mus_end: np.ndarray


def _compact(field: _Field, mc: _March, packed=None):
    """Keep what later orders need of a node march — the located samples with non-zero
    weight (about half of the batch; the rest pads the shorter rays) and their float32
    weights, about 1/6 of the march's memory (``packed``: the weights already packed by
    :func:`._ms_gather.pack_weights`, shared by the cells of one altitude) — or the march
    itself where no compiled kernel is available."""
    if not _have_kernel():
        return mc
    N, M = mc.h.shape
    if packed is None:
        packed = _pack_weights(np.asarray(mc.wt, dtype=np.float32), N, M)
    loc = _Located(field.shape_fine, field.h_fine, field.ths, field.mu_out,
                   mc.h, mc.mus, mc.mu, mc.cphi, None, packed=packed)
    return _Compact(loc, mc.ground, mc.t_end, mc.mus_end)


def _run_cells(fn, cells, stage: str = ""):
    """Apply ``fn`` to every grid cell, over a small thread pool (the kernels and most
    NumPy operations release the GIL); progress is reported as ``stage``
    (:mod:`atmoscatter._progress`; ``""``: not reported, for steps too short to show)."""
    total = len(cells)
    if _THREADS <= 1 or total < 2:
        for k, c in enumerate(cells):
            fn(c)
            if stage:
                _progress.report(stage, k + 1, total)
        return
    from concurrent.futures import ThreadPoolExecutor

    with ThreadPoolExecutor(max_workers=_THREADS) as pool:
        for k, _ in enumerate(pool.map(fn, cells)):
            if stage:
                _progress.report(stage, k + 1, total)


_MAX_AUTO_ORDERS = 200


#: version of the algorithm behind a stored field: bump when the field's values change
_FIELD_VERSION = 5
_RESULTS: dict = {}  # in-process: disk-cache key -> (S_sum, orders, tail)
_RESULTS_MAX = 8


def _warn_tail(n, tail, tol):
    if tail > tol:
        warnings.warn(
            f"multiple_scattering: after {n} orders the estimated remaining orders "
            f"still add {tail:.1e} (relative) of the multiple-scattering source, above "
            f"order_tolerance={tol:g}; the atmosphere is optically thick — pass "
            "orders= explicitly to go further",
            RuntimeWarning,
            stacklevel=4,
        )


def _nbytes(obj, seen=None, depth=0) -> int:
    """Bytes of the NumPy arrays an in-process cache entry holds (arrays, and those in its
    lists, tuples, dicts and plain objects, each counted once; the prepared atmosphere,
    shared by every entry, is not counted)."""
    seen = set() if seen is None else seen
    if id(obj) in seen or depth > 6 or isinstance(obj, (qd.PreparedAtmosphere, str, bytes)):
        return 0
    seen.add(id(obj))
    if isinstance(obj, np.ndarray):
        return int(obj.nbytes)
    if isinstance(obj, dict):
        items = obj.values()
    elif isinstance(obj, (list, tuple)):
        items = obj
    elif hasattr(obj, "__dict__") and not isinstance(obj, type):
        items = vars(obj).values()
    else:
        return 0
    return sum(_nbytes(x, seen, depth + 1) for x in items)


def _trim(cache: dict, max_entries: int, max_bytes: int, keep=None) -> None:
    """Drop the oldest entries of an in-process cache (insertion order) until it holds at
    most ``max_entries`` and ``max_bytes`` (:func:`_nbytes`); the entry ``keep`` (a key)
    and the newest entry always stay."""
    while len(cache) > max_entries or (
            len(cache) > 1 and sum(_nbytes(v) for v in cache.values()) > max_bytes):
        old = next((k for k in cache if k != keep), None)
        if old is None or old == next(reversed(cache)):
            break
        cache.pop(old)


def _state_for(atm_obj, atm, grid, albedo, fresh=False):
    """The in-process field state (successive orders so far) of an atmosphere (``fresh``:
    a new one, replacing it); the caller holds ``_CACHE_LOCK``."""
    try:
        key = (atm_obj, grid, float(albedo))
        hash(key)
    except TypeError:  # unhashable custom atmosphere: no in-process caching
        return _FieldState(atm, grid, albedo)
    if fresh:
        _CACHE.pop(key, None)
    if key not in _CACHE:
        _trim(_CACHE, _CACHE_MAX - 1, _CACHE_BYTES)
        _CACHE[key] = _FieldState(atm, grid, albedo)
    return _CACHE[key]


def _forget_state(atm_obj, grid, albedo) -> None:
    """Drop the in-process field state of :func:`_state_for` (the caller holds
    ``_CACHE_LOCK``)."""
    try:
        _CACHE.pop((atm_obj, grid, float(albedo)), None)
    except TypeError:  # unhashable: never cached
        pass


def _disk_key(atm_obj, grid, albedo, orders, tol):
    """Key of the persistent cache, or ``None`` for objects that cannot be fingerprinted
    (duck-typed custom atmospheres)."""
    from .. import cache

    try:
        return cache.fingerprint(
            "multiple_scattering", _FIELD_VERSION, atm_obj, grid, float(albedo),
            None if orders is None else int(orders),
            None if orders is not None else [float(tol), _ACCELERATION, _MAX_AUTO_ORDERS,
                                             _SUM_RULE],
        )
    except TypeError:
        return None


#: in-process sky tables of the multiple-scattering part, per field (its log S table; an
#: entry goes when the field leaves _RESULTS): a renderer calls once per batch and every
#: batch of one sky shares the table
_MS_TABLES: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()
_MS_TABLES_LOCK = threading.Lock()
_MS_TABLES_PER_FIELD = 4  # observers and suns kept per field (as _single_table's cache)


def _clear_process_caches(single: bool = True) -> None:
    """Forget what this process holds in memory of multiple scattering — the field states,
    the summed sources and the sky tables — and, with ``single``, the single-scattering
    sky tables: what a new process starts with (the persistent cache is untouched).  For
    the tests, benchmarks and studies that time or check a first call."""
    with _CACHE_LOCK:
        _CACHE.clear()
        _RESULTS.clear()
    with _MS_TABLES_LOCK:
        _MS_TABLES.clear()
    if single:
        from . import _single_table

        with _single_table._TABLE_LOCK:
            _single_table._TABLE_CACHE.clear()


def _ms_sky_table(atm_obj, atm, fkey, albedo, field, logS, r0, s, n_mu, n_phi, direct):
    """The :class:`_SkyTable` of the multiple-scattering part for this field (persistent
    key ``fkey``, or ``None``), observer and sun: built once per process (per field), its
    node values read from the persistent cache when a process rendered this sky before
    (bit for bit the computed ones; see :mod:`._disk_memo`)."""
    key = (float(r0), tuple(float(x) for x in s), int(n_mu), int(n_phi), int(field.grid.order))

    def build():
        tkey = None if fkey is None else table_key(
            "multiple_scattering_table", fkey, key[0], list(key[1]), *key[2:])
        return _SkyTable(atm, r0, s, n_mu, n_phi, field.grid.order,
                         values=memo_values("multiple_scattering_table", tkey,
                                            lambda vv: direct(vv)[None],
                                            meta=table_meta(atm_obj, r0, s, albedo=albedo,
                                                            nodes=[int(n_mu), int(n_phi)])),
                         n_values=1, linear=True)

    with _MS_TABLES_LOCK:
        try:
            per_field = _MS_TABLES.setdefault(logS, {})
        except TypeError:  # not weak-referenceable: no in-process reuse
            return build()
        table = per_field.get(key)
        if table is None:
            if len(per_field) >= _MS_TABLES_PER_FIELD:
                per_field.pop(next(iter(per_field)))
            table = per_field[key] = build()
    return table


def _field_for(atm_obj, atm, grid, albedo, orders, tol=None):
    """Field, Σ S^k for ``orders`` orders (or, with ``orders=None``, until ``tol``), its
    gather table and its persistent-cache key (``None``: not fingerprintable).

    Three levels: the summed source of this exact request in the process (``_RESULTS``),
    in the persistent cache (:mod:`atmoscatter.cache`, shared by processes and Dask
    workers; checksummed, written atomically), and else computed from the in-process
    field state of the atmosphere (which keeps the orders already computed, so asking
    for more orders later only adds the missing ones).
    """
    from .. import cache

    field = _Field(atm, grid)
    key = _disk_key(atm_obj, grid, albedo, orders, tol)

    def summed(st):
        if orders is None:
            return st.converged_sum(tol, _MAX_AUTO_ORDERS)
        return st.source_sum(orders), orders, 0.0

    def compute():
        # one lock: renderers call from several threads, and a field state must neither
        # be built twice nor extended by two threads at once
        with _CACHE_LOCK:
            st = _state_for(atm_obj, atm, grid, albedo)
            try:
                try:
                    S_sum, n, tail = summed(st)
                except _SourceDropped:  # an earlier order went for memory: start again
                    st = _state_for(atm_obj, atm, grid, albedo, fresh=True)
                    S_sum, n, tail = summed(st)
            except GridTooCoarseError:
                # the state holds the order that failed the check: never sum it later
                _forget_state(atm_obj, grid, albedo)
                raise
            if grid.sun_nodes == "scene":
                # a field of one sun is rarely extended: its kept node rays (the bulk of
                # the state's memory) go, and are marched again if more orders are asked
                st.marches.clear()
                st.rays.clear()
            st.drop_buffers()
            # the states grew while they computed: hold the caches to their budget
            _trim(_CACHE, _CACHE_MAX, _CACHE_BYTES)
        return {"S_sum": S_sum, "orders": np.array(n), "tail": np.array(tail)}

    if key is None:
        res = compute()
    else:
        with _CACHE_LOCK:
            res = _RESULTS.get(key)
        if res is None:
            meta = {
                "atmosphere": str(getattr(atm_obj, "name", "")),
                "wavelengths": [float(w) for w in np.atleast_1d(getattr(atm_obj, "wavelengths", ()))],
                "ground_albedo": float(albedo),
                "grid": [grid.n_altitude, grid.n_sun, grid.n_mu, grid.n_phi, grid.order],
            }
            res = cache.cached("multiple_scattering", key, compute, meta=meta)
            if res["S_sum"].shape != field.shape_out + (len(atm.scatterers), atm.n_wavelengths):
                res = compute()  # a stale entry of another layout: never trust it
            res = dict(res)
            # the gather reads log S: take the logarithms once per field, not per call
            res["logS"] = _gather_table(field, res["S_sum"])
            with _CACHE_LOCK:
                _RESULTS[key] = res
                _trim(_RESULTS, _RESULTS_MAX, _CACHE_BYTES, keep=key)
    if orders is None:
        _warn_tail(int(res["orders"]), float(res["tail"]), tol)
    logS = res.get("logS")
    if logS is None:
        logS = _gather_table(field, res["S_sum"])
    return field, res["S_sum"], logS, key


def _sun_centre(atm: qd.PreparedAtmosphere, s: np.ndarray, alt: float) -> tuple[float, float]:
    """``(sun zenith, observer dip)`` [deg] that a ``sun_nodes="scene"`` grid centres on:
    the solar zenith at the observer and, above the atmosphere, the angle ``arccos(R/r)``
    to where its lines of sight graze the planet, rounded up to a whole degree (so nearby
    altitudes share one field)."""
    zenith = float(np.degrees(np.arccos(np.clip(s[2], -1.0, 1.0))))
    r0 = atm.planet_radius + float(alt)
    dip = 0.0
    if r0 > atm.top_radius:
        dip = float(np.ceil(np.degrees(np.arccos(atm.planet_radius / r0)) - 1e-9))
    return zenith, dip


def multiple_scattering(
    atmosphere,
    view_directions,
    sun_direction,
    *,
    altitude=0.0,
    orders: int | None = None,
    ground_albedo: float = 0.0,
    order_tolerance: float = DEFAULT_ORDER_TOLERANCE,
    grid: MultipleScatteringGrid | None = None,
    batch_size: int = 2048,
    single_method: str | None = None,
):
    """Sky radiance with ``orders`` orders of scattering, per unit solar irradiance [sr⁻¹].

    Seed 004's successive orders ``I = I¹ + I² + …`` with ``I^{i+1}`` obtained from
    ``I^i`` through the phase integral ``∫ I^i(ω′) β(ω, ω′) dω′`` and the view-path
    integral, including light reflected by a Lambertian ground of albedo
    ``ground_albedo`` (which counts as one order).

    Parameters
    ----------
    atmosphere : Atmosphere
        Planet, atmosphere and constituents.
    view_directions : array_like, shape (..., 3)
        Unit view directions (x east, y north, z up).
    sun_direction : array_like, shape (3,)
        Unit vector toward the sun.
    altitude : float
        Observer altitude [m] (any: ground, inside, top, space).
    orders : int or None
        Number of scattering orders, ≥ 1 (1 = :func:`single_scattering`, default method).
        ``None`` (default): all orders, summed until the estimated remaining tail is below
        ``30 · order_tolerance`` of the multiple-scattering source, and the tail then added
        as a geometric series (its own error, estimated from the change of the decay ratio
        between the last two orders, must be below ``order_tolerance``); at most 200
        orders, with a ``RuntimeWarning`` if that is not enough.  An explicit count sums
        exactly that many orders (fixed small counts are biased low in hazy skies).
    order_tolerance : float
        Target relative error of the summed orders when ``orders=None`` [-], in (0, 1);
        default 1e-3 (measured 2.4e-4 of the source against 50 orders at turbidity 2.5 —
        far below the grid's own error, see ``docs/convergence.md``).
    ground_albedo : float
        Lambertian ground albedo [-], in [0, 1].
    grid : MultipleScatteringGrid, optional
        Resolution of the precomputed field (default :data:`MULTIPLE_SCATTERING_GRID`).
        The field depends only on the atmosphere, albedo, orders and grid, and is cached
        in the process and on disk (the first call for an atmosphere costs seconds —
        ``benchmarks/bench_multiple.py`` — later calls and later processes only the
        view-path gather).  At low sun the azimuth resolution dominates the error (the
        ``n_phi`` row of the study in ``docs/convergence.md``; the default 19 azimuths,
        10° apart, were chosen from it).
    batch_size : int
        Directions per batch of the gather (bounds memory).
    single_method : str or None
        ``method`` of the :func:`single_scattering` call that gives order 1 (``None``: its
        default, which chooses by this call's direction count).  A renderer that
        evaluates one sky in many calls passes ``"table"`` when the whole sky is large
        enough for the table (the table is built once per sky and shared by the calls).

    Returns
    -------
    ndarray, shape (..., n_wavelengths)
        Path radiance per unit extraterrestrial irradiance [sr⁻¹] (ground surface radiance
        at the end of ground-hitting rays excluded), float32 for float32 directions.

    Raises
    ------
    GridTooCoarseError
        (a ``ValueError``) where a user-made ``grid`` cannot resolve the scene: an order of
        the field came out more than 1.5 times as bright as the one before, which physics
        forbids (the cubic interpolation between solar-zenith nodes several degrees apart
        overshoots across the terminator).  The named grids pass this check at every sun
        of the convergence study.

    Notes
    -----
    Order 1 is computed exactly (:func:`single_scattering`); orders ≥ 2 on the grid (see
    the module docstring).  Valid for any sun elevation (twilight included: the field is
    tabulated to 30° below the horizon), any observer altitude and horizontally uniform
    atmospheres.  Accuracy against DISORT, Monte Carlo and a refined grid:
    ``docs/numerical_scattering.md`` and ``docs/convergence.md``.
    """
    tol = float(check_range(order_tolerance, "order_tolerance", 0.0, 1.0, low_inclusive=False))
    n_orders = None if orders is None else int(check_range(orders, "orders", 1, 200))
    albedo = float(check_range(ground_albedo, "ground_albedo", 0.0, 1.0))
    grid = MULTIPLE_SCATTERING_GRID if grid is None else grid
    if not isinstance(grid, MultipleScatteringGrid):
        raise TypeError(f"grid must be a MultipleScatteringGrid, got {type(grid).__name__}")
    single = single_scattering(atmosphere, view_directions, sun_direction, altitude=altitude,
                               method=single_method)
    if n_orders == 1:
        return single
    atm, v, finite, s, alt, out_dtype = _prepare_inputs(
        atmosphere, view_directions, sun_direction, altitude
    )
    if not atm.scatterers:
        return single
    grid = grid.for_sun(*_sun_centre(atm, s, alt))
    field, S_sum, logS, fkey = _field_for(atmosphere, atm, grid, albedo, n_orders, tol)
    vf = v.reshape(-1, 3)
    fin = finite.reshape(-1)
    vf = np.where(fin[:, None], vf, np.array([0.0, 0.0, 1.0]))
    r0 = atm.planet_radius + alt
    # rotate into the grid's frame is unnecessary: the march works in the local frame and
    # only uses local (h, μ, μ_s, cos φ) of every sample.
    def direct(vv):
        out = np.zeros((vv.shape[0], atm.n_wavelengths))
        for i0 in range(0, vv.shape[0], batch_size):
            vb = vv[i0 : i0 + batch_size]
            b = _Batch(atm, r0, vb, s)
            act = np.nonzero(b.sb > b.sa)[0]
            if act.size == 0:
                continue
            mc = _march(atm, r0, vb[act], s, field.grid.order)
            out[i0 + act] = _gather(field, mc, logS, *S_sum.shape[-2:], threads=_THREADS)
        return out

    if vf.shape[0] >= TABLE_THRESHOLD and r0 <= atm.top_radius:
        # the multiple-scattering part is a smooth function of (view zenith, azimuth from
        # the sun), symmetric about the solar vertical: tabulate it like single scattering
        deep = s[2] < np.sin(np.radians(_DEEP_TWILIGHT_ELEVATION))
        n_mu_t, n_phi_t = _MS_TABLE_NODES_DEEP_TWILIGHT if deep else _MS_TABLE_NODES
        n_phi_t = _table_azimuths(n_phi_t, field.grid.n_phi)
        table = _ms_sky_table(atmosphere, atm, fkey, albedo, field, logS, r0, s, n_mu_t,
                              n_phi_t, direct)
        extra = np.concatenate(
            [table.J(vf[i : i + 65536])[0] for i in range(0, vf.shape[0], 65536)], axis=0
        )
    else:
        extra = direct(vf)
    extra = np.where(fin[:, None], np.maximum(extra, 0.0), np.nan)
    out = single.astype(float) + extra.reshape(single.shape)
    return out.astype(out_dtype)

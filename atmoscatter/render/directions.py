"""Direction sets: the view directions a sky map or sky-dome mesh is evaluated at.

Public objects
--------------
:class:`LatLongDirections`
    Equirectangular (lat-long) map with the OpenEXR ``envmap = latlong``
    orientation: north in the centre column, east to the right of it, the
    zenith on the top row.
:class:`CubeMapDirections`
    Six square faces stacked vertically in the OpenEXR ``envmap = cube`` order
    (+X, −X, +Y, −Y, +Z, −Z of the OpenEXR frame) and orientation.
:class:`FisheyeDirections`
    Angular (equidistant, ``r ∝ zenith angle``) all-sky image of the upper
    hemisphere: zenith in the centre, north up, east *left* (as seen looking up).
:class:`~atmoscatter.render.dome.DomeDirections` (in :mod:`atmoscatter.render.dome`)
    A sky-dome mesh (hemisphere, or sphere for an elevated observer) built
    symmetric about the solar vertical and refined adaptively around the sun
    (seed 002 §6: "an adaptive dome mesh which is highly tessellated around the
    sun"); each vertex carries the air optical length of its direction as its
    distance from the observer (seed 000: the mesh "conforms in size to the air
    molecule optical length values in all directions").
:func:`direction_set`
    The direction set of a :class:`~atmoscatter.scene.Scene`.
:func:`local_to_exr`, :func:`exr_to_local`
    Change of frame between the local frame (x = east, y = north, z = up) and
    the OpenEXR environment frame (x = west, y = up, z = north).

Every direction set is evaluated lazily by index range
(:meth:`DirectionSet.directions` ``(start, stop)``), so the full array of
directions never has to exist: memory stays bounded at any resolution.
Pixel directions are taken at pixel *centres*.
"""

from __future__ import annotations

import numpy as np

__all__ = [
    "DirectionSet",
    "LatLongDirections",
    "CubeMapDirections",
    "FisheyeDirections",
    "direction_set",
    "local_to_exr",
    "exr_to_local",
    "mirror_pairs",
    "ArrayDirections",
    "AIR_OPTICAL_LENGTH_ZENITH",
]

#: Air optical length at the zenith [m] (seed 000: "about 8.4 kilometers").
AIR_OPTICAL_LENGTH_ZENITH = 8400.0


def local_to_exr(d):
    """Local (east, north, up) → OpenEXR environment frame (x = west, y = up, z = north).

    Parameters
    ----------
    d : array_like, shape (..., 3)
        Directions in the local frame [-].

    Returns
    -------
    ndarray, shape (..., 3)
        The same directions in the OpenEXR environment frame [-].
    """
    d = np.asarray(d)
    return np.stack([-d[..., 0], d[..., 2], d[..., 1]], axis=-1)


def exr_to_local(d):
    """OpenEXR environment frame (x = west, y = up, z = north) → local (east, north, up).

    Parameters
    ----------
    d : array_like, shape (..., 3)
        Directions in the OpenEXR environment frame [-].

    Returns
    -------
    ndarray, shape (..., 3)
        The same directions in the local frame [-].
    """
    d = np.asarray(d)
    return np.stack([-d[..., 0], d[..., 2], d[..., 1]], axis=-1)


class DirectionSet:
    """Base class: ``size`` directions, laid out as an image of ``shape``."""

    kind = "abstract"
    envmap = None  # OpenEXR envmap attribute ("latlong", "cube") or None

    shape: tuple
    size: int

    def row_length(self) -> int:
        """Batches are aligned to multiples of this (mirror pairs share a row)."""
        return 1

    def batches(self, batch_size: int):
        """``(start, stop)`` index ranges of at most ~``batch_size`` directions."""
        step = max(1, int(batch_size) // self.row_length()) * self.row_length()
        step = max(step, 1)
        return [(s, min(s + step, self.size)) for s in range(0, self.size, step)]

    def directions(self, start: int, stop: int):  # pragma: no cover - abstract
        """Unit directions (k, 3) [local frame] and validity mask (k,) for ``start:stop``."""
        raise NotImplementedError

    def solid_angles(self, start: int, stop: int):  # pragma: no cover - abstract
        """Solid angle [sr] of each pixel/vertex cell in ``start:stop``."""
        raise NotImplementedError

    def up_range(self, start: int, stop: int) -> tuple[float, float] | None:
        """The smallest and largest ``z`` (up component) of the directions ``start:stop``, all
        of them valid, computed exactly as :meth:`directions` computes it; None when not
        cheaply known.

        Lets the evaluator fill a batch that lies wholly below the horizon without generating
        its directions, and skip the horizon test of a batch wholly above it.
        """
        return None

    def all_directions(self):
        """All directions with shape ``shape + (3,)`` (allocates the full array)."""
        d, _ = self.directions(0, self.size)
        return d.reshape(self.shape + (3,))

    def all_valid(self):
        """Validity mask with shape ``shape``."""
        _, v = self.directions(0, self.size)
        return v.reshape(self.shape)

    def describe(self) -> str:
        return f"{self.kind} {self.shape}"


class LatLongDirections(DirectionSet):
    """Equirectangular map of the whole sphere, ``height`` rows × ``width`` columns.

    Row ``r`` has elevation ``π/2 − π (r + ½)/height``; column ``c`` has
    azimuth (from north toward east) ``2π (c + ½)/width − π``: south at both
    edges, north in the centre, east at three quarters of the width.  This is
    the orientation of OpenEXR's ``envmap = latlong`` (``LatLongMap`` in
    ImfEnvmap) with the environment frame's +z = north, +y = up.

    Parameters
    ----------
    width, height : int
        Map size [pixels], ≥ 1.
    """

    kind = "latlong"
    envmap = "latlong"

    def __init__(self, width: int, height: int):
        self.width, self.height = int(width), int(height)
        self.shape = (self.height, self.width)
        self.size = self.width * self.height

    def row_length(self):
        return self.width

    def _angles(self, start, stop):
        idx = np.arange(start, stop, dtype=np.int64)
        r, c = np.divmod(idx, self.width)
        el = 0.5 * np.pi - np.pi * (r + 0.5) / self.height
        az = 2.0 * np.pi * (c + 0.5) / self.width - np.pi
        return el, az, r

    def directions(self, start, stop):
        w = self.width
        if start % w == 0 and stop - start >= w and (stop % w == 0):
            # whole rows: trigonometry per row and per column, then outer products
            rows = np.arange(start // w, stop // w)
            el = 0.5 * np.pi - np.pi * (rows + 0.5) / self.height
            az = 2.0 * np.pi * (np.arange(w) + 0.5) / w - np.pi
            ce = np.cos(el)[:, None]
            d = np.empty((rows.size, w, 3))
            np.multiply(ce, np.sin(az), out=d[..., 0])  # in place: no (rows, w) temporaries
            np.multiply(ce, np.cos(az), out=d[..., 1])
            d[..., 2] = np.sin(el)[:, None]
            return d.reshape(-1, 3), np.ones(rows.size * w, dtype=bool)
        el, az, _ = self._angles(start, stop)
        ce = np.cos(el)
        d = np.empty((el.size, 3))
        d[:, 0] = ce * np.sin(az)
        d[:, 1] = ce * np.cos(az)
        d[:, 2] = np.sin(el)
        return d, np.ones(el.size, dtype=bool)

    def up_range(self, start, stop):
        if stop <= start:
            return None
        w = self.width
        rows = np.arange(start // w, (stop - 1) // w + 1)
        # the same expressions as directions(): z = sin(el) of each row in the range
        z = np.sin(0.5 * np.pi - np.pi * (rows + 0.5) / self.height)
        return float(z.min()), float(z.max())

    def solid_angles(self, start, stop):
        _, _, r = self._angles(start, stop)
        top = 0.5 * np.pi - np.pi * r / self.height
        bot = 0.5 * np.pi - np.pi * (r + 1) / self.height
        return (2.0 * np.pi / self.width) * (np.sin(top) - np.sin(bot))


def _cube_face_uv(face, px, py, s):
    """OpenEXR cube face pixel → in-face coordinates (a, b) in (−1, 1) at pixel centres.

    Follows the face orientations of OpenEXR's ``CubeMap::pixelPosition``.
    """
    flip_x = (s - 1) - px
    flip_y = (s - 1) - py
    # (position-in-face x, position-in-face y) for each face
    if face == 0:  # +X
        u, v = flip_y, px
    elif face == 1:  # -X
        u, v = flip_y, flip_x
    elif face == 2:  # +Y
        u, v = px, flip_y
    elif face == 3:  # -Y
        u, v = px, py
    elif face == 4:  # +Z
        u, v = flip_x, flip_y
    else:  # -Z
        u, v = px, flip_y
    return u, v


def _face_dir(face, a, b):
    one = np.ones_like(a)
    if face == 0:
        return np.stack([one, a, b], -1)
    if face == 1:
        return np.stack([-one, a, b], -1)
    if face == 2:
        return np.stack([a, one, b], -1)
    if face == 3:
        return np.stack([a, -one, b], -1)
    if face == 4:
        return np.stack([a, b, one], -1)
    return np.stack([a, b, -one], -1)


class CubeMapDirections(DirectionSet):
    """Cube map: six ``face × face`` squares stacked vertically (image ``6·face × face``).

    Face order and orientation are OpenEXR's (``envmap = cube``, ImfEnvmap
    ``CubeMap``): +X, −X, +Y, −Y, +Z, −Z of the environment frame
    (x = west, y = up, z = north), so +Y is the zenith face.  Directions are at
    pixel centres (OpenEXR's own helper puts samples on the face edges).

    Parameters
    ----------
    face : int
        Edge length of one face [pixels], ≥ 1.
    """

    kind = "cubemap"
    envmap = "cube"

    def __init__(self, face: int):
        self.face = int(face)
        self.shape = (6 * self.face, self.face)
        self.size = 6 * self.face * self.face

    def row_length(self):
        return self.face

    def _uv(self, start, stop):
        s = self.face
        idx = np.arange(start, stop, dtype=np.int64)
        row, px = np.divmod(idx, s)
        f, py = np.divmod(row, s)
        a = np.empty(idx.size)
        b = np.empty(idx.size)
        for face in np.unique(f):
            m = f == face
            u, v = _cube_face_uv(int(face), px[m], py[m], s)
            a[m] = u
            b[m] = v
        return f, a, b

    def directions(self, start, stop):
        s = self.face
        f, u, v = self._uv(start, stop)
        a = (u + 0.5) / s * 2.0 - 1.0
        b = (v + 0.5) / s * 2.0 - 1.0
        d = np.empty((f.size, 3))
        for face in np.unique(f):
            m = f == face
            d[m] = _face_dir(int(face), a[m], b[m])
        d /= np.linalg.norm(d, axis=-1, keepdims=True)
        return exr_to_local(d), np.ones(f.size, dtype=bool)

    def solid_angles(self, start, stop):
        s = self.face
        _, u, v = self._uv(start, stop)

        def F(x, y):  # solid angle of [0,x]×[0,y] on the plane at unit distance
            return np.arctan2(x * y, np.sqrt(1.0 + x * x + y * y))

        a0, a1 = u / s * 2 - 1, (u + 1) / s * 2 - 1
        b0, b1 = v / s * 2 - 1, (v + 1) / s * 2 - 1
        return F(a1, b1) - F(a0, b1) - F(a1, b0) + F(a0, b0)


class FisheyeDirections(DirectionSet):
    """Angular (equidistant) fisheye of the upper hemisphere, as an all-sky camera sees it.

    The horizon is the circle inscribed in the image (radius ``min(width,
    height)/2`` pixels), the zenith angle grows linearly with the distance from
    the centre, north is up and east is to the *left* (looking up at the sky).
    Pixels outside the circle are invalid: they are not evaluated and get
    alpha 0.

    Parameters
    ----------
    width, height : int
        Image size [pixels], ≥ 1.
    """

    kind = "fisheye"

    def __init__(self, width: int, height: int):
        self.width, self.height = int(width), int(height)
        self.shape = (self.height, self.width)
        self.size = self.width * self.height
        self.radius = 0.5 * min(self.width, self.height)

    def row_length(self):
        return self.width

    def _polar(self, start, stop):
        idx = np.arange(start, stop, dtype=np.int64)
        r, c = np.divmod(idx, self.width)
        dx = (c + 0.5 - 0.5 * self.width) / self.radius
        dy = (r + 0.5 - 0.5 * self.height) / self.radius
        rho = np.hypot(dx, dy)
        return dx, dy, rho

    def directions(self, start, stop):
        dx, dy, rho = self._polar(start, stop)
        valid = rho <= 1.0
        theta = 0.5 * np.pi * np.minimum(rho, 1.0)
        # sin(theta)/rho, finite at rho = 0 (= pi/2)
        s_over_rho = 0.5 * np.pi * np.sinc(theta / np.pi)
        d = np.empty((rho.size, 3))
        d[:, 0] = -dx * s_over_rho
        d[:, 1] = -dy * s_over_rho
        d[:, 2] = np.cos(theta)
        # outside the circle: a harmless unit direction (never evaluated)
        d[~valid] = (0.0, 0.0, 1.0)
        return d, valid

    def solid_angles(self, start, stop):
        _, _, rho = self._polar(start, stop)
        theta = 0.5 * np.pi * np.minimum(rho, 1.0)
        # dΩ = sinθ dθ dφ = (π/2) (sinθ/ρ) dA for the equidistant projection
        omega = 0.5 * np.pi * (0.5 * np.pi * np.sinc(theta / np.pi)) / self.radius**2
        return np.where(rho <= 1.0, omega, 0.0)


def _first_non_unit_numpy(d, tol):
    n2 = d[:, 0] * d[:, 0]
    n2 += d[:, 1] * d[:, 1]
    n2 += d[:, 2] * d[:, 2]
    bad = ~(np.abs(n2 - 1.0) <= tol)  # NaN fails the test too
    return int(np.flatnonzero(bad)[0]) if bad.any() else -1


def _first_non_unit(d, tol):
    """Index of the first row of ``d`` that is not a finite unit vector, or −1.

    One fused compiled pass (the evaluator's overhead budget is a few ms per 10⁶ directions);
    the kernel is imported on first use so that ``import atmoscatter`` does not import numba.
    """
    from .._lazy import kernels  # noqa: PLC0415

    k = kernels("atmoscatter.render._direction_kernels")
    if k is None:  # pragma: no cover
        return _first_non_unit_numpy(d, tol)
    return int(k._first_non_unit_numba(np.ascontiguousarray(d, dtype=np.float64), tol))


class ArrayDirections(DirectionSet):
    """Arbitrary unit directions (..., 3) given by the caller (e.g. a mesh's vertices).

    Parameters
    ----------
    directions : array_like, shape (..., 3)
        Unit vectors in the local frame (x = east, y = north, z = up) [-].
    """

    kind = "directions"

    def __init__(self, directions):
        d = np.asarray(directions, dtype=float)
        if d.ndim < 1 or d.shape[-1] != 3:
            raise ValueError(f"directions must have shape (..., 3), got {d.shape}")
        self.shape = d.shape[:-1]
        self._flat = d.reshape(-1, 3)
        self.size = self._flat.shape[0]

    def directions(self, start, stop):
        """The given directions; checked per batch: finite unit vectors (|d|² = 1 ± 2e-6)."""
        d = self._flat[start:stop]
        first = _first_non_unit(d, 2e-6)
        if first >= 0:
            bad = first + start
            raise ValueError(
                f"directions must be finite unit vectors (|d| = 1 within 1e-6), got "
                f"{self._flat[bad].tolist()} at index {bad}")
        return d, np.ones(stop - start, dtype=bool)

    def solid_angles(self, start, stop):
        return np.full(stop - start, 4.0 * np.pi / max(self.size, 1))



def direction_set(scene, plan=None) -> DirectionSet:
    """The direction set of ``scene`` (uses ``plan`` for the sun and the hemisphere).

    Parameters
    ----------
    scene : Scene
        Its ``projection``, ``width``, ``height`` (and, for the dome, ``refinement``) are used.
    plan : Plan, optional
        The scene's plan; for the dome mesh it gives the sun direction and whether the lower
        hemisphere is needed (default: from the scene, upper hemisphere only).

    Returns
    -------
    DirectionSet
        ``LatLongDirections``, ``CubeMapDirections``, ``FisheyeDirections`` or
        ``DomeDirections``.
    """
    if scene.projection == "latlong":
        return LatLongDirections(scene.width, scene.height)
    if scene.projection == "cubemap":
        return CubeMapDirections(scene.width)
    if scene.projection == "fisheye":
        return FisheyeDirections(scene.width, scene.height)
    if scene.projection == "dome":
        sun = plan.sun_direction if plan is not None else scene.sun_direction()
        sphere = plan is not None and not plan.skip_below_horizon
        from .dome import DomeDirections  # noqa: PLC0415  (the dome builds on this module)

        return DomeDirections(scene.width, scene.height, sun, scene.refinement, sphere=sphere)
    raise ValueError(f"projection={scene.projection!r} is not valid")  # pragma: no cover


def mirror_pairs(directions, sun_direction, *, decimals=11):
    """Fold directions onto one side of the solar vertical and find duplicates.

    A horizontally uniform sky is symmetric under the reflection through the
    vertical plane containing the sun.  Each direction is replaced by its
    representative on the side ``d · p ≥ 0`` (``p`` the horizontal normal of
    the solar vertical), rounded to ``decimals`` decimals; identical
    representatives are evaluated once.

    Parameters
    ----------
    directions : array_like, shape (n, 3)
        Unit view directions in the local frame [-].
    sun_direction : array_like, shape (3,)
        Unit vector toward the sun [-].
    decimals : int
        Rounding of the folded directions used to find duplicates.

    Returns
    -------
    unique : ndarray (m, 3)
        Representative directions to evaluate (m ≤ n).
    inverse : ndarray (n,)
        ``values[inverse]`` maps the m results back to the n input directions.
    """
    d = np.asarray(directions, dtype=float)
    sun = np.asarray(sun_direction, dtype=float)
    p = np.array([sun[1], -sun[0], 0.0])
    norm = np.hypot(p[0], p[1])
    if norm < 1e-12:  # sun at the zenith/nadir: any vertical plane; use east-west
        p = np.array([1.0, 0.0, 0.0])
    else:
        p /= norm
    s = d @ p
    folded = d - 2.0 * np.minimum(s, 0.0)[:, None] * p
    key = np.round(folded, decimals) + 0.0  # +0.0 turns -0.0 into 0.0
    void = np.ascontiguousarray(key).view(np.dtype((np.void, key.dtype.itemsize * 3))).ravel()
    _, first, inverse = np.unique(void, return_index=True, return_inverse=True)
    return folded[first], inverse.ravel()

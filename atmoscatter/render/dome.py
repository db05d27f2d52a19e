"""The sky-dome mesh: a hemisphere (or a sphere, for an elevated observer) of vertices built
symmetric about the solar vertical and refined adaptively around the sun (seed 002 §6: "an
adaptive dome mesh which is highly tessellated around the sun"); each vertex carries the air
optical length of its direction as its distance from the observer (seed 000: the mesh
"conforms in size to the air molecule optical length values in all directions").

The map projections (lat-long, cube map, fisheye) and the :class:`DirectionSet` interface
the dome implements live in :mod:`atmoscatter.render.directions`.
"""

from __future__ import annotations

import math

import numpy as np

from .directions import AIR_OPTICAL_LENGTH_ZENITH, DirectionSet

__all__ = ["DomeDirections"]


def _rotation_to(direction):
    """Rotation matrix taking +z to ``direction`` and the +y axis to the zenith side."""
    d = np.asarray(direction, dtype=float)
    d = d / np.linalg.norm(d)
    up = np.array([0.0, 0.0, 1.0])
    # "toward the zenith" axis in the plane of d and up (the solar vertical)
    t = up - d * d[2]
    if np.linalg.norm(t) < 1e-12:
        t = np.array([0.0, 1.0, 0.0])
    t /= np.linalg.norm(t)
    s = np.cross(t, d)  # perpendicular to the solar vertical
    return np.stack([s, t, d], axis=1)


class DomeDirections(DirectionSet):
    """Sky-dome mesh, symmetric about the solar vertical, refined around the sun.

    Parameters
    ----------
    segments : int
        Vertices per elevation ring (azimuth segments), ≥ 3.
    rings : int
        Rings from the horizon to the zenith (exclusive); the elevation step is
        ``90°/rings``.
    sun_direction : array_like (3,)
        Unit vector toward the sun (local frame).  Ring azimuths are measured
        from the sun's azimuth so that the mesh is mirror-symmetric about the
        solar vertical.
    refinement : int
        Levels of adaptive refinement: level k adds rings of vertices around
        the sun at angular radii 2h and 3h with spacing h = step/2^k.
    sphere : bool
        Cover the whole sphere (elevated observer) rather than the upper
        hemisphere.

    Notes
    -----
    The triangles (:attr:`faces`) are the convex hull of the vertices (a
    spherical Delaunay triangulation), computed with :class:`scipy.spatial.ConvexHull`.
    :attr:`radii` are the vertex distances of seed 000's sky mesh: the air
    optical length [m] in each direction, ``8.4 km × m(θ)`` with the relative
    optical length of Kasten (1966) in the Iqbal form (seed 000 Eq. 5,
    :func:`atmoscatter.relative_optical_length`); below the horizon (sphere
    mode) the horizon value is used.
    """

    kind = "dome"

    def __init__(self, segments, rings, sun_direction, refinement=2, sphere=False):
        from scipy.spatial import ConvexHull  # noqa: PLC0415

        self.segments, self.rings = int(segments), int(rings)
        self.refinement = int(refinement)
        self.sphere = bool(sphere)
        sun = np.asarray(sun_direction, dtype=float)
        sun = sun / np.linalg.norm(sun)
        sun_az = math.atan2(sun[0], sun[1])
        step = 0.5 * np.pi / self.rings
        lo = -self.rings if self.sphere else 0
        pts = [np.array([[0.0, 0.0, 1.0]])]
        if self.sphere:
            pts.append(np.array([[0.0, 0.0, -1.0]]))
        az = sun_az + 2.0 * np.pi * np.arange(self.segments) / self.segments
        for k in range(lo + (1 if self.sphere else 0), self.rings):
            el = k * step
            ring = np.stack([np.cos(el) * np.sin(az), np.cos(el) * np.cos(az),
                             np.full(az.shape, np.sin(el))], -1)
            pts.append(ring)
        # adaptive refinement around the sun (polar rings about the sun direction)
        rot = _rotation_to(sun)
        local = [np.array([[0.0, 0.0, 1.0]])] if self.refinement > 0 else []
        for level in range(1, self.refinement + 1):
            h = step / 2**level
            for j in (2, 3):
                radius = j * h
                n = max(6, 2 * math.ceil(math.pi * radius / h))
                ang = 2.0 * np.pi * np.arange(n) / n  # symmetric set: ang ↔ −ang
                local.append(np.stack([np.sin(radius) * np.sin(ang),
                                       np.sin(radius) * np.cos(ang),
                                       np.full(n, np.cos(radius))], -1))
        if local:
            ref = np.concatenate(local) @ rot.T
            if not self.sphere:
                ref = ref[ref[:, 2] >= 0.0]
            pts.append(ref)
        verts = np.concatenate(pts)
        verts /= np.linalg.norm(verts, axis=-1, keepdims=True)
        verts = _dedupe_points(verts)
        if self.sphere:
            hull = ConvexHull(verts)
            faces = hull.simplices
        else:
            closed = np.concatenate([verts, [[0.0, 0.0, -1.0]]])
            hull = ConvexHull(closed)
            faces = hull.simplices[np.all(hull.simplices < len(verts), axis=1)]
        # consistent outward orientation (normals away from the centre)
        a, b, c = verts[faces[:, 0]], verts[faces[:, 1]], verts[faces[:, 2]]
        flip = np.einsum("ij,ij->i", np.cross(b - a, c - a), a + b + c) < 0
        faces[flip] = faces[flip][:, [0, 2, 1]]
        self.vertices = verts
        self.faces = faces.astype(np.int64)
        self.shape = (len(verts),)
        self.size = len(verts)
        self.sun_direction = sun

    @property
    def radii(self):
        """Vertex distance [m]: air optical length in the vertex direction (seed 000)."""
        from ..optical_length import relative_optical_length  # noqa: PLC0415

        zen = np.arccos(np.clip(self.vertices[:, 2], 0.0, 1.0))
        return AIR_OPTICAL_LENGTH_ZENITH * relative_optical_length(zen, method="iqbal")

    def directions(self, start, stop):
        return self.vertices[start:stop].copy(), np.ones(stop - start, dtype=bool)

    def solid_angles(self, start, stop):
        """Solid angle of each vertex's cell: a third of its adjacent triangles' solid angles."""
        v, f = self.vertices, self.faces
        a, b, c = v[f[:, 0]], v[f[:, 1]], v[f[:, 2]]
        # Van Oosterom & Strackee (1983) solid angle of a spherical triangle
        num = np.abs(np.einsum("ij,ij->i", a, np.cross(b, c)))
        den = 1.0 + np.einsum("ij,ij->i", a, b) + np.einsum("ij,ij->i", b, c) + np.einsum(
            "ij,ij->i", c, a)
        tri = 2.0 * np.arctan2(num, den)
        omega = np.zeros(len(v))
        for k in range(3):
            np.add.at(omega, f[:, k], tri / 3.0)
        return omega[start:stop]




def _dedupe_points(p, tol=1e-9):
    key = np.round(p / tol).astype(np.int64)
    _, idx = np.unique(key, axis=0, return_index=True)
    return p[np.sort(idx)]


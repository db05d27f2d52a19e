"""Direction sets: orientation conventions, solid angles, the dome mesh, mirror pairs."""

import math

import numpy as np
import pytest

from atmoscatter.optical_length import relative_optical_length
from atmoscatter.render.directions import (
    ArrayDirections,
    CubeMapDirections,
    FisheyeDirections,
    LatLongDirections,
    exr_to_local,
    local_to_exr,
    mirror_pairs,
)
from atmoscatter.render.dome import DomeDirections


def _unit(d):
    return np.allclose(np.linalg.norm(d, axis=-1), 1.0, atol=1e-12)


def sun_dir(el_deg, az_deg):
    el, az = math.radians(el_deg), math.radians(az_deg)
    return np.array([math.cos(el) * math.sin(az), math.cos(el) * math.cos(az), math.sin(el)])


class TestFrames:
    def test_round_trip(self):
        d = np.random.default_rng(1).normal(size=(20, 3))
        np.testing.assert_array_equal(exr_to_local(local_to_exr(d)), d)

    def test_axes(self):
        # east -> EXR -x (west is +x), north -> EXR +z, up -> EXR +y
        np.testing.assert_array_equal(local_to_exr([1.0, 0, 0]), [-1.0, 0, 0])
        np.testing.assert_array_equal(local_to_exr([0, 1.0, 0]), [0, 0, 1.0])
        np.testing.assert_array_equal(local_to_exr([0, 0, 1.0]), [0, 1.0, 0])
        # the EXR frame is right-handed like the local one
        x, y, z = (local_to_exr(v) for v in np.eye(3))
        assert np.linalg.det(np.stack([local_to_exr([1.0, 0, 0]), local_to_exr([0, 1.0, 0]),
                                       local_to_exr([0, 0, 1.0])])) == pytest.approx(1.0)


class TestLatLong:
    def test_orientation(self):
        w, h = 64, 32
        ds = LatLongDirections(w, h)
        d = ds.all_directions()
        assert d.shape == (h, w, 3) and _unit(d)
        assert d[0, 0, 2] > 0.99 and d[-1, 0, 2] < -0.99  # zenith on top
        mid = h // 2
        centre = d[mid, w // 2]  # just right of the centre column: north
        assert centre[1] > 0.99
        east = d[mid, 3 * w // 4]
        assert east[0] > 0.99
        west = d[mid, w // 4]
        assert west[0] < -0.99

    def test_matches_openexr_latlong_orientation(self):
        # OpenEXR ImfEnvmap LatLongMap (frame x, y up, z): latitude = asin(y),
        # longitude = atan2(x, z); pixel x = (lon/(-2 pi) + 0.5)(W - 1),
        # y = (lat/(-pi) + 0.5)(H - 1).  Our pixel centres must land within one pixel.
        w, h = 40, 20
        d = local_to_exr(LatLongDirections(w, h).all_directions())
        lat = np.arcsin(d[..., 1])
        lon = np.arctan2(d[..., 0], d[..., 2])
        px = (lon / (-2 * np.pi) + 0.5) * (w - 1)
        py = (lat / (-np.pi) + 0.5) * (h - 1)
        cols, rows = np.meshgrid(np.arange(w), np.arange(h))
        assert np.max(np.abs(px - cols)) < 1.0 and np.max(np.abs(py - rows)) < 1.0

    def test_row_fast_path_matches_general_path(self):
        ds = LatLongDirections(16, 8)
        full, _ = ds.directions(0, ds.size)
        part, _ = ds.directions(5, 70)  # not aligned to rows
        np.testing.assert_allclose(part, full[5:70], atol=1e-15)
        rows, _ = ds.directions(16, 48)  # aligned
        el = 0.5 * np.pi - np.pi * (np.arange(1, 3) + 0.5) / 8
        np.testing.assert_allclose(rows[:, 2], np.repeat(np.sin(el), 16), atol=1e-15)

    def test_solid_angles_sum_to_sphere(self):
        ds = LatLongDirections(37, 19)
        assert ds.solid_angles(0, ds.size).sum() == pytest.approx(4 * np.pi, rel=1e-12)

    def test_batches_align_to_rows(self):
        ds = LatLongDirections(100, 10)
        b = ds.batches(250)
        assert b[0] == (0, 200) and b[-1][1] == 1000
        assert all((s % 100 == 0) for s, _ in b)


def _openexr_cube_pixel(d_exr, s):
    """Independent transcription of OpenEXR ImfEnvmap CubeMap::faceAndPixelPosition +
    pixelPosition (BSD-3, conventions only): direction -> (face, x, y_in_face)."""
    x, y, z = d_exr
    ax, ay, az = abs(x), abs(y), abs(z)
    if ax >= ay and ax >= az:
        u, v = (y / ax + 1) / 2 * (s - 1), (z / ax + 1) / 2 * (s - 1)
        face = 0 if x > 0 else 1
    elif ay >= az:
        u, v = (x / ay + 1) / 2 * (s - 1), (z / ay + 1) / 2 * (s - 1)
        face = 2 if y > 0 else 3
    else:
        u, v = (x / az + 1) / 2 * (s - 1), (y / az + 1) / 2 * (s - 1)
        face = 4 if z > 0 else 5
    lo, hi = 0, s - 1
    px, py = {
        0: (lo + v, hi - u), 1: (hi - v, hi - u), 2: (lo + u, hi - v),
        3: (lo + u, lo + v), 4: (hi - u, hi - v), 5: (lo + u, hi - v),
    }[face]
    return face, px, py


class TestCubeMap:
    def test_layout_matches_openexr(self):
        s = 8
        ds = CubeMapDirections(s)
        d = ds.all_directions()
        assert d.shape == (6 * s, s, 3) and _unit(d)
        de = local_to_exr(d)
        for row in range(6 * s):
            for col in range(s):
                face, px, py = _openexr_cube_pixel(de[row, col], s)
                assert face == row // s
                # OpenEXR samples face edges, we sample pixel centres: within one pixel
                assert abs(px - col) < 1.0 and abs(py - row % s) < 1.0

    def test_zenith_face_and_solid_angles(self):
        s = 6
        ds = CubeMapDirections(s)
        d = ds.all_directions()
        assert np.all(d[2 * s:3 * s, :, 2] > 0.5)  # +Y (EXR up) face looks up
        assert ds.solid_angles(0, ds.size).sum() == pytest.approx(4 * np.pi, rel=1e-12)
        om = ds.solid_angles(0, ds.size).reshape(6 * s, s)
        assert om[2 * s + s // 2, s // 2] > om[2 * s, 0]  # centre pixels subtend more


class TestFisheye:
    def test_orientation_and_mask(self):
        w = h = 65
        ds = FisheyeDirections(w, h)
        d = ds.all_directions()
        valid = ds.all_valid()
        assert _unit(d)
        np.testing.assert_allclose(d[32, 32], [0, 0, 1], atol=1e-12)  # zenith in the centre
        assert d[0, 32, 1] > 0.99  # top edge: north horizon
        assert d[32, 0, 0] > 0.99  # left edge: east (looking up)
        assert not valid[0, 0] and valid[32, 32]
        assert np.all(d[valid][:, 2] >= -1e-12)

    def test_equidistant(self):
        ds = FisheyeDirections(101, 101)
        d = ds.all_directions()
        # zenith angle grows linearly with the radius: at r = R/2 it is 45 deg
        r = (np.arange(101) + 0.5 - 50.5) / 50.5
        row = d[50, :, 2]
        zen = np.degrees(np.arccos(np.clip(row, -1, 1)))
        np.testing.assert_allclose(zen[np.abs(r) <= 1], 90 * np.abs(r[np.abs(r) <= 1]), atol=1e-9)

    def test_solid_angle_of_hemisphere(self):
        ds = FisheyeDirections(400, 400)
        assert ds.solid_angles(0, ds.size).sum() == pytest.approx(2 * np.pi, rel=5e-3)


def _tri_solid_angles(v, f):
    a, b, c = v[f[:, 0]], v[f[:, 1]], v[f[:, 2]]
    num = np.abs(np.einsum("ij,ij->i", a, np.cross(b, c)))
    den = 1 + (a * b).sum(1) + (b * c).sum(1) + (c * a).sum(1)
    return 2 * np.arctan2(num, den)


class TestDome:
    def test_covers_hemisphere(self):
        ds = DomeDirections(24, 8, sun_dir(30, 120), refinement=2)
        assert _unit(ds.vertices) and np.all(ds.vertices[:, 2] >= -1e-12)
        assert _tri_solid_angles(ds.vertices, ds.faces).sum() == pytest.approx(2 * np.pi, rel=1e-9)
        assert ds.solid_angles(0, ds.size).sum() == pytest.approx(2 * np.pi, rel=1e-9)
        # every vertex is used by a face
        assert np.unique(ds.faces).size == ds.size

    def test_sphere(self):
        ds = DomeDirections(16, 6, sun_dir(30, 120), refinement=1, sphere=True)
        assert _tri_solid_angles(ds.vertices, ds.faces).sum() == pytest.approx(4 * np.pi, rel=1e-9)
        assert ds.vertices[:, 2].min() == pytest.approx(-1.0)

    def test_refinement_around_the_sun(self):
        sun = sun_dir(25, 200)

        def near(ds, deg):
            return int(np.sum(ds.vertices @ sun > math.cos(math.radians(deg))))

        counts = [near(DomeDirections(24, 8, sun, refinement=r), 8.0) for r in range(4)]
        assert counts == sorted(counts) and counts[3] > 4 * counts[0]
        # far from the sun the mesh is unchanged
        far = [int(np.sum(DomeDirections(24, 8, sun, refinement=r).vertices @ sun < 0.5))
               for r in (0, 3)]
        assert far[0] == far[1]

    def test_mirror_symmetric(self):
        sun = sun_dir(20, 75)
        ds = DomeDirections(20, 6, sun, refinement=2)
        p = np.array([sun[1], -sun[0], 0.0])
        p /= np.linalg.norm(p)
        mirrored = ds.vertices - 2 * (ds.vertices @ p)[:, None] * p
        # each mirrored vertex is a vertex
        dist = np.min(np.linalg.norm(mirrored[:, None, :] - ds.vertices[None], axis=-1), axis=1)
        assert dist.max() < 1e-9

    def test_radii_are_air_optical_lengths(self):
        ds = DomeDirections(12, 4, sun_dir(40, 10), refinement=0)
        zen = np.arccos(np.clip(ds.vertices[:, 2], 0, 1))
        np.testing.assert_allclose(ds.radii, 8400.0 * relative_optical_length(zen), rtol=1e-12)
        # seed 000 Eq. 5 at the zenith: 1 / (1 + 0.15 * 93.885^-1.253)
        zenith_value = 8400.0 / (1.0 + 0.15 * 93.885**-1.253)
        assert ds.radii[np.argmax(ds.vertices[:, 2])] == pytest.approx(zenith_value, rel=1e-9)


class TestMirrorPairs:
    def test_pairs_are_found_and_mapped_back(self):
        rng = np.random.default_rng(3)
        sun = sun_dir(30, 40)
        d = rng.normal(size=(500, 3))
        d /= np.linalg.norm(d, axis=1, keepdims=True)
        p = np.array([sun[1], -sun[0], 0.0]) / np.hypot(sun[0], sun[1])
        mirrored = d - 2 * (d @ p)[:, None] * p
        both = np.concatenate([d, mirrored])
        uniq, inv = mirror_pairs(both, sun)
        assert len(uniq) <= 500 + 5  # nearly every pair collapses (rounding may split a few)
        # a symmetric function evaluated on the representatives, mapped back
        f = lambda x: (x @ sun) ** 3 + x[:, 2]  # noqa: E731 - depends on symmetric invariants
        np.testing.assert_allclose(f(uniq)[inv], f(both), atol=1e-10)

    def test_sun_at_zenith(self):
        uniq, inv = mirror_pairs(np.array([[1.0, 0, 0], [-1.0, 0, 0], [0, 1.0, 0]]), [0, 0, 1.0])
        assert len(uniq) == 2 and inv[0] == inv[1]


class TestArrayDirections:
    def test_shape_and_validation(self):
        d = np.zeros((4, 5, 3))
        d[..., 2] = 1
        ds = ArrayDirections(d)
        assert ds.shape == (4, 5) and ds.size == 20
        with pytest.raises(ValueError, match=r"unit vectors.*at index 0"):
            ArrayDirections(np.ones((3, 3))).directions(0, 3)
        bad = np.tile([0.0, 0.0, 1.0], (4, 1))
        bad[2, 0] = np.nan
        with pytest.raises(ValueError, match="at index 2"):
            ArrayDirections(bad).directions(0, 4)
        with pytest.raises(ValueError, match=r"shape \(\.\.\., 3\)"):
            ArrayDirections(np.ones((3, 2)))


def test_unit_vector_check_compiled_and_numpy_agree():
    # the compiled per-batch check must flag exactly what the NumPy expression flags
    from atmoscatter.render.directions import _first_non_unit, _first_non_unit_numpy

    rng = np.random.default_rng(5)
    d = rng.normal(size=(1000, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    assert _first_non_unit(d, 2e-6) == _first_non_unit_numpy(d, 2e-6) == -1
    for idx, bad in [(17, [np.nan, 0.0, 1.0]), (3, [0.0, 0.0, 1.00001]), (999, [np.inf, 0, 0]),
                     (0, [0.0, 0.0, 0.0])]:
        e = d.copy()
        e[idx] = bad
        assert _first_non_unit(e, 2e-6) == _first_non_unit_numpy(e, 2e-6) == idx
    # float32 input is checked too (converted, not rejected)
    assert _first_non_unit(d.astype(np.float32), 2e-6) == -1

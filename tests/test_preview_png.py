"""PNG row filters of :func:`atmoscatter.preview.write_png`.

Decoded with Pillow (an independent PNG implementation; skipped without it) and with the
byte-by-byte decoder of ``tests/test_exr.py`` there; here: exact round trips of images that
exercise every filter type, and the size gain on a smooth sky-like gradient.
"""

from __future__ import annotations

import zlib

import numpy as np
import pytest

from atmoscatter.preview import _filter_rows, write_png

PIL = pytest.importorskip("PIL.Image")


def gradient(h, w):
    """A smooth 8-bit gradient with noise-free structure (like a tone-mapped sky)."""
    y, x = np.mgrid[0:h, 0:w] / np.array([h, w])[:, None, None]
    rgb = np.stack([0.3 + 0.5 * y, 0.4 + 0.3 * x * y, 0.9 - 0.4 * y + 0.05 * np.sin(7 * x)], -1)
    return np.round(np.clip(rgb, 0, 1) * 255).astype(np.uint8)


@pytest.mark.parametrize("channels", [1, 3, 4])
def test_round_trip_through_pillow(tmp_path, channels):
    rng = np.random.default_rng(3)
    img = gradient(40, 33)
    img[::7] = rng.integers(0, 256, size=img[::7].shape, dtype=np.uint8)  # noisy rows too
    if channels == 1:
        px = img[..., 0]
    elif channels == 4:
        px = np.concatenate([img, img[..., :1]], axis=-1)
    else:
        px = img
    path = write_png(tmp_path / "a.png", px)
    with PIL.open(path) as im:
        back = np.asarray(im)
    np.testing.assert_array_equal(back, px)


def test_all_filter_types_are_used_and_undone(tmp_path):
    # rows built so that each filter type wins somewhere: constant rows (Up), horizontal
    # ramps (Sub), noise (None), and smooth 2-D gradients (Average / Paeth)
    rng = np.random.default_rng(5)
    img = gradient(64, 64).astype(np.int32)
    img[10:14] = img[9]  # identical rows: Up gives zeros
    img[20:24] = (np.arange(64)[None, :, None] * 3) % 256  # ramps: Sub gives constants
    img[30:34] = rng.integers(0, 256, size=(4, 64, 3))
    px = img.astype(np.uint8)
    kinds = set(_filter_rows(px.reshape(64, -1), 3)[:, 0].tolist())
    assert {0, 1, 2} <= kinds and kinds & {3, 4}
    with PIL.open(write_png(tmp_path / "b.png", px)) as im:
        np.testing.assert_array_equal(np.asarray(im), px)


def test_filters_shrink_a_smooth_sky(tmp_path):
    px = gradient(256, 512)
    size = (tmp_path / "c.png").stat().st_size if write_png(tmp_path / "c.png", px) else 0
    unfiltered = np.concatenate([np.zeros((256, 1), np.uint8), px.reshape(256, -1)], axis=1)
    plain = len(zlib.compress(unfiltered.tobytes(), 6))
    # measured: 0.57 of the unfiltered size (Pillow's own filtering gives about the same);
    # 0.7 leaves room for zlib versions while failing if the filters stop working
    assert size < 0.7 * plain, (size, plain)


def test_row_blocks_give_the_same_file(tmp_path, monkeypatch):
    """The filter runs in blocks of rows (bounded memory for big previews); each block sees
    the row above it, so the bytes equal a one-block run."""
    from atmoscatter import preview as P

    rng = np.random.default_rng(4)
    yy, xx = np.mgrid[0:61, 0:23]
    px = np.stack([(xx * 3 + yy) % 256, (2 * yy) % 256, rng.integers(0, 256, (61, 23))],
                  axis=-1).astype(np.uint8)
    monkeypatch.setattr(P, "_FILTER_BLOCK_ROWS", 10**6)
    whole = open(P.write_png(tmp_path / "whole.png", px), "rb").read()
    monkeypatch.setattr(P, "_FILTER_BLOCK_ROWS", 7)
    blocked = open(P.write_png(tmp_path / "blocked.png", px), "rb").read()
    assert blocked == whole

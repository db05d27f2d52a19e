"""A minimal PNG decoder for the tests, independent of the package's writer."""

from __future__ import annotations

import struct
import zlib

import numpy as np


def read_png(path):
    """Minimal independent PNG decoder for 8-bit images with any of the five row filters
    (PNG specification, 2nd ed., section 9.2; undone byte by byte as written there)."""
    data = open(path, "rb").read()
    assert data[:8] == b"\x89PNG\r\n\x1a\n"
    pos, chunks = 8, {}
    while pos < len(data):
        n = struct.unpack(">I", data[pos:pos + 4])[0]
        tag = data[pos + 4:pos + 8]
        body = data[pos + 8:pos + 8 + n]
        crc = struct.unpack(">I", data[pos + 8 + n:pos + 12 + n])[0]
        assert crc == zlib.crc32(tag + body) & 0xFFFFFFFF
        chunks.setdefault(tag, b"")
        chunks[tag] += body
        pos += 12 + n
    w, h, depth, ctype = struct.unpack(">IIBB", chunks[b"IHDR"][:10])
    c = {0: 1, 2: 3, 6: 4}[ctype]
    raw = np.frombuffer(zlib.decompress(chunks[b"IDAT"]), dtype=np.uint8).reshape(h, 1 + w * c)
    assert np.all(raw[:, 0] <= 4)
    out = [[0] * (w * c) for _ in range(h)]
    for y in range(h):
        kind, row = int(raw[y, 0]), raw[y, 1:].tolist()
        for i in range(w * c):
            a = out[y][i - c] if i >= c else 0
            b = out[y - 1][i] if y > 0 else 0
            cc = out[y - 1][i - c] if (y > 0 and i >= c) else 0
            if kind == 0:
                pred = 0
            elif kind == 1:
                pred = a
            elif kind == 2:
                pred = b
            elif kind == 3:
                pred = (a + b) // 2
            else:
                p = a + b - cc
                pa, pb, pc = abs(p - a), abs(p - b), abs(p - cc)
                pred = a if pa <= pb and pa <= pc else (b if pb <= pc else cc)
            out[y][i] = (row[i] + pred) % 256
    return np.array(out, dtype=np.uint8).reshape(h, w, c)

"""A render's peak memory grows like its output, not like a multiple of it (issue 11).

Measured, not timed: the peak resident set size (``ru_maxrss`` of ``os.wait4``) of
``atmoscatter render`` in child processes at two map sizes.  The difference of the two peaks
over the difference of the two outputs cancels what does not depend on the size (interpreter,
NumPy, numba kernels, OpenEXR, the bounded per-batch working set: both sizes run several
batches on the same two workers) and leaves the bytes a render holds per pixel against the
bytes its output needs.

Expected: 13/12 = 1.08 for RGB (three float32 planes, 12 bytes a pixel, handed to OpenEXR
without copies, plus the 1-byte mask of evaluated sky) and 17/16 = 1.06 for RGBA (the alpha
plane is output too); measured 1.08–1.11 and 1.09 (two runs each on the shared 2-core
machine).  Bound 1.25: ~15 % above that for page and allocator granularity, and below the
1.42 that one more full-size float32 plane would give (4/12 more), so interleaved storage
with per-channel copies (measured 2.37 RGB, 2.03 RGBA before the planar layout) or a float32
alpha kept next to its mask fail.
"""

from __future__ import annotations

import os
import subprocess
import sys
import tempfile

import pytest

import atmoscatter as ac

pytestmark = pytest.mark.skipif(not hasattr(os, "wait4"),
                                reason="needs os.wait4 (POSIX) for a child's peak RSS")

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(ac.__file__)))
SMALL, LARGE = (1024, 512), (3072, 1536)
BOUND = 1.25


def _peak_rss(width, height, sets):
    """Peak RSS [bytes] of ``atmoscatter render`` at ``width`` × ``height`` in a child."""
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([ROOT, os.environ.get("PYTHONPATH", "")]))
    args = [sys.executable, "-m", "atmoscatter", "render", "--quiet", "--workers", "2",
            "--set", f"width={width}", "--set", f"height={height}"]
    for s in sets:
        args += ["--set", s]
    with tempfile.TemporaryDirectory() as tmp:
        proc = subprocess.Popen([*args, "-o", os.path.join(tmp, "map.exr")], env=env, cwd=tmp,
                                stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
        _, status, ru = os.wait4(proc.pid, 0)
        proc.returncode = os.waitstatus_to_exitcode(status)
        err = proc.stderr.read().decode(errors="replace")
        proc.stderr.close()
    assert proc.returncode == 0, err
    return int(ru.ru_maxrss) * (1 if sys.platform == "darwin" else 1024)


@pytest.fixture(scope="module", autouse=True)
def _kernels_cached():
    """One tiny render first, so that neither measured child compiles numba kernels."""
    _peak_rss(64, 32, [])


@pytest.mark.parametrize("sets,channels", [([], 3), (["alpha=true"], 4)], ids=["rgb", "rgba"])
def test_peak_memory_grows_like_the_output(sets, channels):
    small = _peak_rss(*SMALL, sets)
    large = _peak_rss(*LARGE, sets)
    d_output = (LARGE[0] * LARGE[1] - SMALL[0] * SMALL[1]) * channels * 4  # float32 planes
    ratio = (large - small) / d_output
    assert ratio < BOUND, (f"peak RSS grew {ratio:.2f}× the output ({small / 2**20:.0f} MiB at "
                           f"{SMALL}, {large / 2**20:.0f} MiB at {LARGE})")

"""Regenerate ``atmoscatter/data/cie1931_2deg_cmf.csv`` from colour-science.

The CIE 1931 2° standard observer's colour-matching functions, 360–830 nm at 1 nm, as
colour-science distributes them (``colour.MSDS_CMFS["CIE 1931 2 Degree Standard
Observer"]``, from the CIE's own data tables: CIE 018:2019 / CIE 15:2018; colour-science
is BSD-3-Clause).  Shipping them lets the physical models' colour conversion run without
importing colour-science (about a second: SciPy and Matplotlib come with it).  No value
is hand-copied: the file is written by this script, and ``tests/test_colour.py`` checks
it against the installed colour-science.

Run:  PYTHONPATH=. python scripts/make_cmf_table.py
"""

import os

import colour
import numpy as np

from atmoscatter.exr import atomic_write

NAME = "CIE 1931 2 Degree Standard Observer"
OUT = os.path.join(os.path.dirname(__file__), "..", "atmoscatter", "data", "cie1931_2deg_cmf.csv")


def main(argv=None) -> None:
    """Write the table to ``--out`` (default: the shipped file)."""
    import argparse

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default=OUT, help="output file (default: the shipped data file)")
    args = ap.parse_args(argv)
    cmfs = colour.MSDS_CMFS[NAME]
    wl = np.asarray(cmfs.wavelengths, dtype=float)
    v = np.asarray(cmfs.values, dtype=float)
    out = os.path.abspath(args.out)
    with atomic_write(out) as tmp, open(tmp, "w", encoding="utf-8") as f:
        f.write(f"# {NAME}: colour-matching functions x_bar, y_bar, z_bar [-]\n")
        f.write(f"# source: colour-science {colour.__version__}, colour.MSDS_CMFS (CIE data; "
                "colour-science BSD-3-Clause); written by scripts/make_cmf_table.py\n")
        f.write("wavelength_nm,x_bar,y_bar,z_bar\n")
        for w, (x, y, z) in zip(wl, v, strict=True):
            f.write(f"{w!r},{x!r},{y!r},{z!r}\n")
    print(f"wrote {out}: {wl.size} wavelengths {wl[0]:g}-{wl[-1]:g} nm")


if __name__ == "__main__":
    main()

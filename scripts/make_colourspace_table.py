"""Regenerate ``atmoscatter/data/colourspaces.json`` from colour-science.

The table lets ``import atmoscatter``, scene validation and the default render know the RGB
colourspaces (names and the aliases colour-science accepts, XYZ → RGB matrices, primaries and
whitepoints) without importing colour-science, whose import pulls in SciPy and Matplotlib and
takes about a second.  No value is hand-copied: everything is written from
``colour.RGB_COLOURSPACES`` by this script, and ``tests/test_colour.py`` checks the table
against the installed colour-science whenever it is importable.

Run:  PYTHONPATH=. python scripts/make_colourspace_table.py
"""

import json
import os

import colour
import numpy as np

from atmoscatter.exr import atomic_write

OUT = os.path.join(os.path.dirname(__file__), "..", "atmoscatter", "data", "colourspaces.json")


def build() -> dict:
    """The table as a JSON-ready dict (floats written with repr: exact round trip)."""
    cs = colour.RGB_COLOURSPACES
    names = list(cs.keys())
    spaces = {}
    for name in names:
        c = cs[name]
        spaces[name] = {
            "matrix_XYZ_to_RGB": np.asarray(c.matrix_XYZ_to_RGB, dtype=float).tolist(),
            "primaries": np.asarray(c.primaries, dtype=float).tolist(),
            "whitepoint": np.asarray(c.whitepoint, dtype=float).tolist(),
        }
    return {
        "source": f"colour-science {colour.__version__}: colour.RGB_COLOURSPACES "
                  "(scripts/make_colourspace_table.py)",
        "colour_science_version": colour.__version__,
        # colour's CanonicalMapping lookups, in its order: exact, lower-case, slugified, canonical
        "lower": dict(zip(cs.lower_keys(), names, strict=True)),
        "slugified": dict(zip(cs.slugified_keys(), names, strict=True)),
        "canonical": dict(zip(cs.canonical_keys(), names, strict=True)),
        "colourspaces": spaces,
    }


def main(argv=None) -> None:
    """Write the table to ``--out`` (default: the shipped file)."""
    import argparse

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default=OUT, help="output file (default: the shipped data file)")
    args = ap.parse_args(argv)
    table = build()
    out = os.path.abspath(args.out)
    with atomic_write(out) as tmp, open(tmp, "w", encoding="utf-8") as f:
        json.dump(table, f, indent=1, sort_keys=False)
        f.write("\n")
    print(f"wrote {out}: {len(table['colourspaces'])} colourspaces")


if __name__ == "__main__":
    main()

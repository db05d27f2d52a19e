"""Render the pictures of ``docs/user_guide.md`` with the package's current defaults.

Usage (from the repository root; ``scripts/make_docs_data.py --only user_guide_images``)::

    PYTHONPATH=. python scripts/user_guide_images.py                     # docs/images/*.png
    PYTHONPATH=. python scripts/user_guide_images.py --quick --out DIR   # CI: tiny, no MS

Every picture is ``atmoscatter.render`` of a :class:`~atmoscatter.Scene` followed by
``atmoscatter.write_preview`` — the Python equivalent of the ``atmoscatter render`` /
``atmoscatter preview`` commands printed under each picture on the page (same scene fields,
same exposure).  The quick mode renders at an eighth of the size and leaves out
``multiple_scattering`` (its first call computes the scattering field: minutes); its images
are not for publishing.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

import atmoscatter as ac  # noqa: E402

#: the model comparison of the page: one scene, one exposure [m² cd⁻¹] for every model
MODEL_SCENE = {"width": 384, "height": 192, "sun_elevation_deg": 25.0, "sun_azimuth_deg": 180.0,
               "turbidity": 3.0, "time": "2024-06-21T12:00:00Z"}
MODEL_EXPOSURE = 1.2e-4
MODELS = ("preetham", "hoffman_preetham", "cie_clear", "cie_overcast", "single_scattering",
          "multiple_scattering")

#: (file, scene fields, preview keyword arguments)
PICTURES = [
    ("default_latlong.png", {"width": 512, "height": 256}, {}),
    ("default_cubemap.png", {"projection": "cubemap", "width": 96}, {}),
    ("sunset_fisheye.png", {"projection": "fisheye", "width": 256, "height": 256,
                            "time": "2024-06-21T19:45:00Z", "turbidity": 4.0, "alpha": True},
     {"alpha": "mask"}),
] + [(f"model_{m}.png", {**MODEL_SCENE, "model": m}, {"exposure": MODEL_EXPOSURE})
     for m in MODELS]


def _scaled(fields: dict, scale: float) -> dict:
    out = dict(fields)
    for k in ("width", "height"):
        if k in out:
            out[k] = max(8, int(round(out[k] * scale)))
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default=str(ROOT / "docs" / "images"), help="output directory")
    ap.add_argument("--quick", action="store_true",
                    help="an eighth of the size, without multiple_scattering (CI smoke run)")
    args = ap.parse_args(argv)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    for name, fields, preview in PICTURES:
        if args.quick and fields.get("model") == "multiple_scattering":
            continue
        scene = ac.Scene(**(_scaled(fields, 0.125) if args.quick else fields))
        t0 = time.perf_counter()
        img = ac.render(scene)
        ac.write_preview(img, out / name, **preview)
        size = (out / name).stat().st_size
        print(f"{name}: {scene.width}x{scene.height} {scene.model}, "
              f"{time.perf_counter() - t0:.1f} s, {size / 1024:.0f} KiB", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())

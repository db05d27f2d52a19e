"""Render the documentation gallery with the package itself.

Usage::

    PYTHONPATH=. python scripts/gallery.py [--out docs] [--scale 1.0]

Writes small PNG previews to ``docs/gallery/*.png`` (256 × 128 lat-long maps and 128 × 128
all-sky fisheyes at ``--scale 1``) and the page ``docs/gallery.md`` listing them with the
scene of each image.  Every image is a :func:`atmoscatter.render` of a :class:`Scene`;
images whose model is not available in this checkout are listed as missing, never faked.
"""

from __future__ import annotations

import argparse
import os
import sys
import time

sys.path.insert(0, os.path.join(os.path.dirname(__file__), os.pardir))

import atmoscatter as ac  # noqa: E402

SITE = {"latitude": 39.742, "longitude": -105.179}  # NREL, Golden, Colorado
DAY = "2024-06-21"
MODEL_PREFERENCE = ("multiple_scattering", "single_scattering", "preetham")


def available_models() -> list[str]:
    try:
        from atmoscatter.render.models import MODELS
    except ImportError:  # the renderer has not landed in this checkout
        return []
    return sorted(MODELS)


def physical_model(models) -> str | None:
    for m in ("multiple_scattering", "single_scattering"):
        if m in models:
            return m
    return None


def gallery_items(models):
    """(section, file stem, caption, scene fields or None, reason if skipped)."""
    best = next((m for m in MODEL_PREFERENCE if m in models), None)
    phys = physical_model(models)
    items = []
    # a day of skies (all-sky fisheye, as an all-sky camera sees it)
    for hour in (12, 14, 16, 18, 20, 22, 24):  # UTC; local solar time ≈ UTC − 7 h
        hh = hour % 24
        day = DAY if hour < 24 else "2024-06-22"
        t = f"{day}T{hh:02d}:00:00Z"
        items.append(("A day of skies", f"day_{hour:02d}utc",
                      f"{hh:02d}:00 UTC ≈ {(hour - 7) % 24:02d}:00 local solar time",
                      None if best is None else dict(
                          model=best, time=t, turbidity=2.5, projection="fisheye",
                          width=128, height=128, **SITE), None if best else "no sky model"))
    # sunset sequence (physical models only: Preetham is not defined below the horizon)
    for el in (10.0, 4.0, 1.0, -1.0, -3.0, -6.0):
        items.append(("Sunset sequence", f"sunset_{el:+.0f}deg".replace("+", "p").replace("-", "m"),
                      f"sun elevation {el:g}°, looking around the whole horizon",
                      None if phys is None else dict(
                          model=phys, sun_elevation_deg=el, sun_azimuth_deg=295.0,
                          turbidity=2.5, projection="latlong", width=256, height=128),
                      None if phys else "needs single_scattering or multiple_scattering"))
    # haze and fog
    for T, label in ((2.0, "clear (T = 2)"), (6.0, "hazy (T = 6)"), (20.0, "heavy haze / fog (T = 20)")):
        items.append(("Haze and fog", f"haze_T{T:g}", label,
                      None if phys is None else dict(
                          model=phys, sun_elevation_deg=35.0, sun_azimuth_deg=180.0,
                          turbidity=T, projection="latlong", width=256, height=128),
                      None if phys else "needs a physical model"))
    # Mars
    items.append(("Mars-like sky", "mars_noon", "Mars preset atmosphere, sun 40° high",
                  None if phys is None else dict(
                      model=phys, atmosphere="mars", sun_elevation_deg=40.0,
                      sun_azimuth_deg=180.0, projection="latlong", width=256, height=128),
                  None if phys else "needs a physical model"))
    items.append(("Mars-like sky", "mars_sunset", "Mars preset atmosphere, sun 2° high",
                  None if phys is None else dict(
                      model=phys, atmosphere="mars", sun_elevation_deg=2.0,
                      sun_azimuth_deg=270.0, projection="latlong", width=256, height=128),
                  None if phys else "needs a physical model"))
    # planet from space
    items.append(("The planet seen from space", "space_1000km",
                  "observer 1000 km above the ground, the whole sphere of directions "
                  "(the planet, 60° in angular radius, fills the bottom of the map)",
                  None if phys is None else dict(
                      model=phys, altitude=1.0e6, sun_elevation_deg=30.0,
                      sun_azimuth_deg=180.0, projection="latlong", width=256, height=128),
                  None if phys else "needs a physical model"))
    return items


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default=os.path.join(os.path.dirname(__file__), os.pardir, "docs"))
    ap.add_argument("--scale", type=float, default=1.0, help="resolution factor (tests: 0.25)")
    ap.add_argument("--only", default=None, help="render only stems containing this text")
    args = ap.parse_args(argv)
    out_dir = os.path.join(args.out, "gallery")
    os.makedirs(out_dir, exist_ok=True)
    models = available_models()
    lines = [
        "# Gallery",
        "",
        "Rendered by the package itself with `scripts/gallery.py` (re-run it to regenerate; "
        "every image is `atmoscatter.render(Scene(...))` tone-mapped by "
        "`atmoscatter.preview.preview_array` with automatic exposure per image; lat-long maps "
        "of a ground observer show their upper (sky) half, zenith on top, north in the "
        "centre; fisheyes look up with north up and east left).",
        "",
        f"Models available when this page was generated: {', '.join(models) or 'none'}.",
        "",
    ]
    missing = [m for m in ("preetham", "single_scattering", "multiple_scattering") if m not in models]
    if missing:
        lines += [f"**Not available** in this build, so not shown: {', '.join(missing)}.", ""]
    sections: dict[str, list] = {}
    for sec, stem, caption, fields, reason in gallery_items(models):
        if args.only and args.only not in stem:
            continue
        entries = sections.setdefault(sec, [])
        if fields is None:
            entries.append((None, caption, f"not rendered ({reason})"))
            continue
        if args.scale != 1.0:
            for k in ("width", "height"):
                fields[k] = max(4, int(round(fields[k] * args.scale / 2)) * 2)
        scene = ac.Scene(name=stem, sun_disc=False, **fields)
        t0 = time.perf_counter()
        try:
            img = ac.render(scene)
        except Exception as exc:  # report, keep going: one scene must not lose the others
            entries.append((None, caption, f"rendering failed: `{' '.join(str(exc).split())}`"))
            print(f"{stem}: FAILED {exc}", file=sys.stderr)
            continue
        dt = time.perf_counter() - t0
        from atmoscatter.preview import preview_array, write_png

        rgb, lum = img.rgb, img.luminance
        ground = fields["projection"] == "latlong" and fields.get("altitude", 0.0) < 1e4
        if ground:
            # a ground observer's lower half is the (uniform) ground fill: keep the sky
            h = rgb.shape[0] // 2
            rgb, lum = rgb[:h], lum[:h]
        write_png(os.path.join(out_dir, f"{stem}.png"), preview_array(rgb, luminance=lum))
        desc = ", ".join(f"{k}={v}" for k, v in fields.items()
                         if k not in ("width", "height", "projection"))
        shown = "upper half of a " if ground else ""
        entries.append((f"gallery/{stem}.png", caption,
                        f"{shown}{fields['projection']} {fields['width']}×{fields['height']}, "
                        f"{desc}; rendered in {dt:.1f} s"))
        print(f"{stem}: {dt:.1f} s")
    for sec, entries in sections.items():
        lines += [f"## {sec}", ""]
        shown = [e for e in entries if e[0] is not None]
        per_row = 4 if shown and "fisheye" in shown[0][2] else 3
        for k in range(0, len(shown), per_row):
            row = shown[k:k + per_row]
            lines += ["| " + " | ".join(f"![{c}]({src})" for src, c, _ in row) + " |",
                      "|" + "---|" * len(row),
                      "| " + " | ".join(c for _, c, _ in row) + " |", ""]
        lines += [f"- *{c}*: {d}." for _, c, d in entries] + [""]
    with open(os.path.join(args.out, "gallery.md"), "w", encoding="utf-8") as fh:
        fh.write("\n".join(lines).rstrip() + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())

"""Render the documentation gallery with the package itself, at physical exposure.

Usage::

    PYTHONPATH=. python scripts/gallery.py [--out docs]      # full: docs/gallery.md + PNGs
    PYTHONPATH=. python scripts/gallery.py --quick --out DIR  # smoke test: one tiny frame per
                                                             # series, same code path

Every image is ``atmoscatter.render(Scene(...))`` with the model's defaults (the spectral
sampling is the plan's ``sampling="auto"`` choice, reported per image), written with
:func:`atmoscatter.preview.preview_array` and the hue-preserving ``luminance`` tone curve.
Each *series* has one fixed exposure, set from its reference frame (``ln 2 / median sky
luminance``: that frame's median maps to display value 0.5), so a day or a twilight sequence
gets darker as it does to the eye of a camera that keeps its settings; twilight frames are
shown a second time at a stated number of stops more.  Captions give absolute luminances
[cd m⁻²] measured on the rendered map.  Lat-long maps of a ground observer are cropped to
their upper (sky) half.

Full run: 512 × 256 lat-long maps (shown 512 × 128) and 512 × 512 fisheyes; the first run on
a machine also builds the multiple-scattering fields (one per atmosphere and spectral
sampling, cached on disk by :mod:`atmoscatter.cache`).  The page records the CPU time.
"""

from __future__ import annotations

import argparse
import math
import os
import platform
import sys
import time
from dataclasses import dataclass, field

sys.path.insert(0, os.path.join(os.path.dirname(__file__), os.pardir))

import numpy as np  # noqa: E402

import atmoscatter as ac  # noqa: E402

SITE = {"latitude": 39.742, "longitude": -105.179}  # NREL, Golden, Colorado
MODEL = "multiple_scattering"
LATLONG = {"projection": "latlong", "width": 512, "height": 256}
FISHEYE = {"projection": "fisheye", "width": 512, "height": 512}
QUICK = {"latlong": (32, 16), "fisheye": (24, 24)}
HORIZON_BAND_DEG = (1.0, 3.0)  # elevations [deg] whose luminance the captions call "horizon"


@dataclass
class Frame:
    stem: str
    label: str
    fields: dict


@dataclass
class Series:
    title: str
    intro: str
    frames: list
    reference: str  # stem of the frame that sets the series exposure
    second: tuple = ()  # stems shown again at a second exposure (twilight)
    per_row: int = 3
    rendered: dict = field(default_factory=dict)


def series_list() -> list[Series]:
    day = []
    for hour, label in ((11, "04:00"), (12, "05:00"), (13, "06:00"), (15, "08:00"),
                        (19, "12:00"), (23, "16:00"), (25, "18:00"), (27, "20:00")):
        date = "2024-06-21" if hour < 24 else "2024-06-22"
        day.append(Frame(f"day_{hour % 24:02d}utc",
                         f"{label} local solar time ({hour % 24:02d}:00 UTC)",
                         dict(model=MODEL, time=f"{date}T{hour % 24:02d}:00:00Z",
                              turbidity=2.5, **FISHEYE, **SITE)))
    sunset = [Frame(f"sunset_{'p' if el >= 0 else 'm'}{abs(el):g}deg", f"sun {el:g}°",
                    dict(model=MODEL, sun_elevation_deg=el, sun_azimuth_deg=295.0,
                         turbidity=2.5, **LATLONG))
              for el in (10.0, 4.0, 1.0, -1.0, -3.0, -6.0)]
    haze = [Frame(f"haze_T{T:g}", label,
                  dict(model=MODEL, sun_elevation_deg=35.0, sun_azimuth_deg=180.0,
                       turbidity=T, **LATLONG))
            for T, label in ((2.5, "clear (T = 2.5)"), (6.0, "hazy (T = 6)"),
                             (20.0, "heavy haze (T = 20)"))]
    mars = [Frame("mars_noon", "sun 40°", dict(model=MODEL, atmosphere="mars",
                                             sun_elevation_deg=40.0, sun_azimuth_deg=180.0,
                                             **LATLONG)),
            Frame("mars_sunset", "sun 2°", dict(model=MODEL, atmosphere="mars",
                                              sun_elevation_deg=2.0, sun_azimuth_deg=270.0,
                                              **LATLONG))]
    space = [Frame("space_1000km", "1000 km up, sun 30°",
                   dict(model=MODEL, altitude=1.0e6, sun_elevation_deg=30.0,
                        sun_azimuth_deg=180.0, turbidity=2.5, **LATLONG))]
    return [
        Series("A day of skies",
               "All-sky fisheyes (looking up, north up, east left) over Golden, Colorado "
               "(39.742° N, 105.179° W) on 21 June 2024, turbidity 2.5.", day,
               reference="day_19utc", second=("day_11utc", "day_03utc"), per_row=4),
        Series("Sunset sequence",
               "The whole horizon (lat-long, sky half; north in the centre, the sun at "
               "azimuth 295°), turbidity 2.5.", sunset, reference="sunset_p10deg",
               second=("sunset_m1deg", "sunset_m3deg", "sunset_m6deg")),
        Series("Haze and fog", "Sun 35° high in the south; only the turbidity changes.", haze,
               reference="haze_T2.5"),
        Series("Mars-like sky", "The `mars` preset atmosphere (CO₂ and dust).", mars,
               reference="mars_noon", per_row=2),
        Series("The planet seen from space",
               "The whole sphere of directions from 1000 km above the ground (the planet, "
               "60° in angular radius, fills the bottom of the map).", space,
               reference="space_1000km", per_row=1),
    ]


# --------------------------------------------------------------------------- measuring
def sky_statistics(img) -> dict:
    """Luminances [cd m⁻²] of the rendered map: zenith, horizon band, max, median (sky only)."""
    lum = np.asarray(img.luminance, dtype=float)
    sky = np.asarray(img.alpha) > 0 if img.alpha is not None else np.isfinite(lum)
    d = np.asarray(img.directions, dtype=float)
    elev = np.degrees(np.arcsin(np.clip(d[..., 2], -1.0, 1.0)))
    vals = lum[sky]
    lit = vals[vals > 0]  # (black space around a planet is not part of the median)
    out = {"median": float(np.median(lit)) if lit.size else 0.0, "max": float(vals.max())}
    if img.scene.altitude < 1.0e4:  # a ground observer: zenith and horizon are meaningful
        zi = np.unravel_index(np.argmax(np.where(sky, elev, -90.0)), elev.shape)
        out["zenith"], out["zenith_elev"] = float(lum[zi]), float(elev[zi])
        band = sky & (elev >= HORIZON_BAND_DEG[0]) & (elev <= HORIZON_BAND_DEG[1])
        if band.any():
            out["horizon"] = (float(lum[band].min()), float(lum[band].max()))
    return out


def fmt_l(v: float) -> str:
    """A luminance [cd m⁻²] to 3 significant digits, without exponent notation."""
    if v <= 0:
        return "0"
    digits = max(0, 2 - int(math.floor(math.log10(v))))
    r = round(v, digits)
    return f"{r:,.{digits}f}".replace(",", " ")


def exposure_for(stats: dict) -> float:
    """Exposure [m² cd⁻¹] mapping the frame's median (lit) sky luminance to display value
    0.5 (1 for a black frame)."""
    return math.log(2.0) / stats["median"] if stats["median"] > 0 else 1.0


def second_stops(reference_median: float, medians: list) -> int:
    """Whole stops (≥ 1) of the twilight row: they bring the geometric mean of the twilight
    frames' median luminances to display value 0.25 — one stop under the series' mid-grey,
    so dusk still reads as dusk — with one exposure for all of them."""
    mean = sum(math.log2(reference_median / m) for m in medians) / len(medians)
    return max(1, round(mean - 1.0))


def tone_to_png(img, exposure: float, path: str, crop: bool) -> None:
    from atmoscatter.preview import preview_array, write_png

    rgb, lum = np.asarray(img.rgb), np.asarray(img.luminance)
    if crop:  # a ground observer's lower half is the ground fill: keep the sky
        h = rgb.shape[0] // 2
        rgb, lum = rgb[:h], lum[:h]
    px = preview_array(rgb, exposure=exposure, tone="luminance", luminance=lum,
                       colourspace=img.scene.colourspace)
    write_png(path, px)


def caption(stats: dict) -> str:
    parts = []
    if "zenith" in stats:
        parts.append(f"zenith {fmt_l(stats['zenith'])}")
        if "horizon" in stats:
            lo, hi = stats["horizon"]
            parts.append(f"horizon {fmt_l(lo)}–{fmt_l(hi)}")
    else:
        parts.append(f"median {fmt_l(stats['median'])}")
    parts.append(f"max {fmt_l(stats['max'])} cd m⁻²")
    return ", ".join(parts)


def exposure_text(e: float) -> str:
    return (f"{e:.3g} m² cd⁻¹ (display value 0.5 at {fmt_l(math.log(2.0) / e)} cd m⁻², "
            "white above ~5× that)")


# --------------------------------------------------------------------------- running
def render_frame(frame: Frame, quick: bool):
    fields = dict(frame.fields)
    if quick:
        fields["width"], fields["height"] = QUICK[fields["projection"]]
    scene = ac.Scene(name=frame.stem, sun_disc=False, alpha=True, **fields)
    c0, t0 = time.process_time(), time.perf_counter()
    img = ac.render(scene)
    return img, time.process_time() - c0, time.perf_counter() - t0


def run(out: str, quick: bool, only: str | None) -> tuple[list[Series], float, float]:
    out_dir = os.path.join(out, "gallery")
    os.makedirs(out_dir, exist_ok=True)
    all_series = series_list()
    cpu_total = wall_total = 0.0
    for s in all_series:
        frames = s.frames
        if quick:  # one tiny frame per series: the reference, through the same code path
            frames = [f for f in frames if f.stem == s.reference]
        if only:
            frames = [f for f in frames if only in f.stem]
        for f in frames:
            img, cpu, wall = render_frame(f, quick)
            cpu_total, wall_total = cpu_total + cpu, wall_total + wall
            stats = sky_statistics(img)
            crop = img.scene.projection == "latlong" and img.scene.altitude < 1.0e4
            s.rendered[f.stem] = dict(img=img, stats=stats, cpu=cpu, wall=wall, crop=crop,
                                      plan=img.plan, fields=f.fields, label=f.label)
            print(f"{f.stem}: {wall:.1f} s wall, {cpu:.1f} s CPU, sampling {img.plan.sampling}, "
                  f"{caption(stats)}", flush=True)
        if not s.rendered:
            continue
        ref = s.rendered.get(s.reference) or next(iter(s.rendered.values()))
        s.exposure = exposure_for(ref["stats"])
        s.stops = None
        dark = [s.rendered[k]["stats"]["median"] for k in s.second if k in s.rendered]
        dark = [m for m in dark if m > 0]
        if dark and s.reference in s.rendered:
            s.stops = second_stops(ref["stats"]["median"], dark)
        for stem, r in s.rendered.items():
            tone_to_png(r["img"], s.exposure, os.path.join(out_dir, f"{stem}.png"), r["crop"])
            r["png"] = f"gallery/{stem}.png"
            if s.stops and stem in s.second:
                name = f"{stem}_plus{s.stops}ev"
                tone_to_png(r["img"], s.exposure * 2.0 ** s.stops,
                            os.path.join(out_dir, f"{name}.png"), r["crop"])
                r["png2"] = f"gallery/{name}.png"
            r.pop("img")  # free the map
    return all_series, cpu_total, wall_total


def table(cells: list[tuple[str, str]], per_row: int) -> list[str]:
    lines = []
    for k in range(0, len(cells), per_row):
        row = cells[k:k + per_row]
        lines += ["| " + " | ".join(f"![{alt}]({src})" for src, alt, _ in row) + " |",
                  "|" + "---|" * len(row),
                  "| " + " | ".join(c for _, _, c in row) + " |", ""]
    return lines


def page(all_series: list[Series], cpu: float, wall: float, command: str) -> str:
    lines = [
        "# Gallery",
        "",
        "<!-- generated by scripts/gallery.py; do not edit by hand -->",
        "",
        "Rendered by the package itself with `scripts/gallery.py` (`python "
        "scripts/make_docs_data.py --only gallery` regenerates this page and its images). "
        f"Every image is `atmoscatter.render(Scene(model=\"{MODEL}\", ...))` with the "
        "model's defaults: the plan chooses the spectral sampling (`sampling=\"auto\"`: a "
        "spectrum where three wavelengths are measurably wrong, i.e. a low or set sun; see "
        "`atmoscatter render --explain` and [spectral sampling](numerical_scattering.md"
        "#spectral-sampling-three-wavelengths-or-a-spectrum)), and the list under each "
        "series says what it chose and why.",
        "",
        "**Exposure.** Each series has *one* fixed exposure, set from its reference frame "
        "(that frame's median sky luminance maps to display value 0.5), so the frames of a "
        "series compare like photographs taken with the same camera settings: twilight is "
        "darker than noon by as much as it really is.  Twilight frames are shown a second "
        "time, a stated whole number of stops brighter: one exposure for all of them (so they "
        "still darken in turn) that brings the geometric mean of their median luminances to "
        "display value 0.25, one stop under the series' mid-grey.  Luminances in the captions are absolute, in cd m⁻², read "
        f"from the rendered map: zenith, the range over the horizon band "
        f"({HORIZON_BAND_DEG[0]:g}–{HORIZON_BAND_DEG[1]:g}° elevation, all azimuths) and "
        "the sky's maximum.",
        "",
        "**Tone curve.** `tone=\"luminance\"` of `atmoscatter.preview.tone_map`: the "
        "exponential curve `1 − e^(−exposure·Y)` is applied to the luminance and the RGB "
        "colour scaled with it; a saturated colour that would exceed full scale is scaled "
        "down as a whole, so every pixel keeps its chromaticity (a red horizon stays red "
        "instead of clipping channel by channel to yellow or white).  sRGB, 8 bit; the sun "
        "disc is not drawn.",
        "",
    ]
    for s in all_series:
        if not s.rendered:
            continue
        lines += [f"## {s.title}", "", s.intro + f" Exposure {exposure_text(s.exposure)}, "
                  f"from the frame *{s.rendered[s.reference]['label'] if s.reference in s.rendered else '?'}*.", ""]
        cells = [(r["png"], r["label"], f"**{r['label']}**: {caption(r['stats'])}")
                 for r in s.rendered.values()]
        lines += table(cells, s.per_row)
        second = [r for stem, r in s.rendered.items() if "png2" in r]
        if second:
            e2 = s.exposure * 2.0 ** s.stops
            lines += [f"The same frames at **+{s.stops} stops** (exposure {exposure_text(e2)}, "
                      "the same for all of them):", ""]
            lines += table([(r["png2"], r["label"] + f" (+{s.stops} stops)",
                             f"**{r['label']}**, +{s.stops} stops") for r in second],
                           max(len(second), 1) if len(second) <= 4 else s.per_row)
        for r in s.rendered.values():
            f = r["fields"]
            desc = ", ".join(f"{k}={v}" for k, v in f.items()
                             if k not in ("width", "height", "projection", "model"))
            p = r["plan"]
            samp = (f"{p.sampling}, {len(p.wavelengths)} wavelengths" if p.sampling
                    else "n/a")
            shown = "sky half of a " if r["crop"] else ""
            lines.append(f"- *{r['label']}*: {shown}{f['projection']} {f['width']}×{f['height']}, "
                         f"{desc}; sampling {samp} (plan: {p.sampling_reason}); "
                         f"rendered in {r['cpu']:.1f} s CPU.")
        lines.append("")
    lines += [
        "## How this page was made",
        "",
        f"`{command}` on {platform.machine()} {platform.system()} "
        f"({os.cpu_count()} cores, shared with other jobs), {time.strftime('%Y-%m-%d')}: "
        f"renders took {cpu / 60:.1f} min CPU ({wall / 60:.1f} min wall), including the "
        "multiple-scattering field builds not already in the disk cache.",
        "",
    ]
    return "\n".join(lines)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default=os.path.join(os.path.dirname(__file__), os.pardir, "docs"))
    ap.add_argument("--quick", action="store_true",
                    help="one tiny frame per series (smoke test of the code path)")
    ap.add_argument("--only", default=None, help="render only stems containing this text")
    args = ap.parse_args(argv)
    if not args.quick and not args.only and os.path.isdir(os.path.join(args.out, "gallery")):
        for name in os.listdir(os.path.join(args.out, "gallery")):  # no stale images
            if name.endswith(".png"):
                os.remove(os.path.join(args.out, "gallery", name))
    all_series, cpu, wall = run(args.out, args.quick, args.only)
    command = "python scripts/gallery.py" + (" --quick" if args.quick else "")
    with open(os.path.join(args.out, "gallery.md"), "w", encoding="utf-8") as fh:
        fh.write(page(all_series, cpu, wall, command).rstrip() + "\n")
    print(f"total: {cpu:.1f} s CPU, {wall:.1f} s wall")
    return 0


if __name__ == "__main__":
    sys.exit(main())

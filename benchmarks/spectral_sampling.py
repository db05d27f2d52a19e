"""Colour error of 3-wavelength ("rgb") sampling against spectral sampling (issue 10, part 6).

For each atmosphere (``earth_turbidity_atmosphere(T)`` with ozone, ground observer) and sun
elevation, renders the physical model on a small upper-hemisphere lat-long map
(:data:`N_AZ` azimuths × :data:`N_EL` elevations, cell centres) with ``sampling="rgb"``
and with ``sampling="spectral"`` at several wavelength steps, and compares each with the
reference (``wavelength_step`` = :data:`REFERENCE_STEP` nm):

* **colour** — CIE ΔE2000 (``colour.delta_E(..., method="CIE 2000")``) of CIE Lab computed
  with the D65 white point (x, y = 0.3127, 0.3290) after dividing XYZ by the *reference
  map's maximum Y* (the brightest pixel of the spectral reference has L* = 100; both renders
  are divided by the same number, so a luminance error shows in L*);
* **luminance** — relative error ``|Y / Y_ref − 1|`` per pixel;
* statistics over the map: the maximum, the 95th percentile and the solid-angle-weighted
  mean (weights cos(elevation));
* **cost** — wall time of the render with the multiple-scattering field computed from
  scratch (``ATMOSCATTER_CACHE_DIR=off``, in-process caches cleared) and of the same render
  again (warm: field cached).

The field does not depend on the sun, so all sun elevations of one atmosphere and one
wavelength set share one precomputation.  The spectral steps coarser than the reference
whose wavelengths are a subset of the reference's (20, 40, 50, 100 nm on a 10 nm
reference) are evaluated from the reference run's per-irradiance radiance at those
wavelengths, integrated by the renderer's own converter for that wavelength set
(:func:`atmoscatter.render.photometry._per_irradiance_converter`, band-averaged ETR of *that* set):
the field is computed independently per wavelength, so this is the render at that step up
to the automatic order count (shared by all wavelengths; ``order_tolerance`` 1e-3).  One
step (:data:`CHECK_STEP`) is also rendered directly (cold and warm) to time it and to check
that equivalence (``subset_check`` in the output).

From the table the script derives the rule of ``sampling="auto"``
(:func:`atmoscatter.render.plan.plan`) and writes it to ``atmoscatter/data/spectral_sampling.json``:

* ``LIMIT`` ΔE2000 (95th percentile over the map, worst atmosphere) is the target;
* the sun-elevation threshold is the lowest measured elevation at and above which rgb
  sampling stays within the target at every measured elevation — below it the plan
  chooses spectral sampling;
* the step is the coarsest measured step within the target at every measured elevation
  below the threshold (every atmosphere).

Run (2-core shared VM; the full run takes ~15-25 minutes, mostly the 41-wavelength fields)::

    PYTHONPATH=. python benchmarks/spectral_sampling.py            # multiple_scattering, writes
                                                                    # docs/convergence/spectral_sampling.{md,csv}
                                                                    # and atmoscatter/data/spectral_sampling.json
    PYTHONPATH=. python benchmarks/spectral_sampling.py --quick    # single_scattering, 16 x 8, temp output
    PYTHONPATH=. python benchmarks/spectral_sampling.py --from-csv docs/convergence/spectral_sampling.csv
                                                                    # re-derive md/json from a CSV
"""

from __future__ import annotations

import argparse
import csv
import datetime
import json
import os
import platform
import sys
import tempfile
import time

import numpy as np

os.environ["ATMOSCATTER_CACHE_DIR"] = "off"  # cold timings: no persistent cache

import atmoscatter as ac  # noqa: E402
from atmoscatter.render import photometry, physical_adapters  # noqa: E402
from atmoscatter.render.plan import plan as make_plan  # noqa: E402
from atmoscatter.scene import Scene  # noqa: E402

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)

N_AZ, N_EL = 32, 16
REFERENCE_STEP = 10.0
SUBSET_STEPS = (100.0, 50.0, 40.0, 20.0)
CHECK_STEP = 20.0
#: ΔE2000 target of the rule (95th percentile over the map).  ΔE2000 ≈ 1 is about one
#: just-noticeable difference side by side; 2 is the tolerance used here for a sky map.
LIMIT = 2.0
RULE_STAT = "dE_p95"
ELEVATIONS = (60.0, 30.0, 15.0, 10.0, 6.0, 4.0, 2.0, 0.0, -2.0, -4.0, -6.0, -8.0, -10.0)
ATMOSPHERES = ((2.5, "earth"), (6.0, "earth"))
D65 = np.array([0.3127, 0.3290])

FIELDS = ["model", "turbidity", "atmosphere", "sun_elevation", "sampling", "step",
          "n_wavelengths", "dE_max", "dE_p95", "dE_mean", "Y_err_max", "Y_err_mean",
          "cold_s", "warm_s", "subset_check"]


def hemisphere(n_az=N_AZ, n_el=N_EL):
    """Cell-centre directions (n_el*n_az, 3) of the upper hemisphere and their weights."""
    el = (np.arange(n_el) + 0.5) * (np.pi / 2) / n_el
    az = (np.arange(n_az) + 0.5) * (2 * np.pi) / n_az
    E, A = np.meshgrid(el, az, indexing="ij")
    d = np.stack([np.cos(E) * np.sin(A), np.cos(E) * np.cos(A), np.sin(E)], -1).reshape(-1, 3)
    w = np.cos(E).reshape(-1)
    return d, w / w.sum()


def _clear_caches():
    import atmoscatter.sky.multiple as msky  # noqa: PLC0415

    msky._clear_process_caches(single=False)


def _scene(model, T, atm, elev, sampling, step):
    return Scene(model=model, turbidity=T, atmosphere=atm, sun_elevation_deg=elev,
                 sun_azimuth_deg=180.0, sampling=sampling, wavelength_step=step,
                 output="xyz", time="2024-03-20T12:00:00Z")


def _render(scene, d):
    t = time.perf_counter()
    xyz = np.asarray(ac.render(scene, directions=d, workers=1).xyz, dtype=float)
    return xyz, time.perf_counter() - t


def _raw(scene, d):
    """Per-irradiance radiance f (n, n_wl) exactly as the renderer evaluates it."""
    p = make_plan(scene)
    atm = physical_adapters._build_atmosphere(scene, p.wavelengths)
    fn = getattr(ac, scene.model)
    kw = {"altitude": scene.altitude}
    if scene.model == "multiple_scattering":
        kw["ground_albedo"] = scene.ground_albedo
    return np.asarray(fn(atm, d, p.sun_direction, **kw), dtype=float), p


def _xyz_from_subset(f_ref, p_ref, scene_sub):
    p = make_plan(scene_sub)
    idx = np.searchsorted(np.asarray(p_ref.wavelengths), np.asarray(p.wavelengths))
    assert np.allclose(np.asarray(p_ref.wavelengths)[idx], p.wavelengths)
    convert = photometry._per_irradiance_converter(np.asarray(p.wavelengths), False, p)
    return convert(f_ref[:, idx])["XYZ"], len(p.wavelengths)


def compare(xyz, ref, w):
    """ΔE2000 and luminance statistics of ``xyz`` against ``ref`` (n, 3) over the map."""
    import colour  # noqa: PLC0415

    yn = float(ref[:, 1].max())
    lab = colour.XYZ_to_Lab(xyz / yn, illuminant=D65)
    lab_ref = colour.XYZ_to_Lab(ref / yn, illuminant=D65)
    de = np.asarray(colour.delta_E(lab, lab_ref, method="CIE 2000"), dtype=float)
    ok = ref[:, 1] > 0
    yerr = np.abs(xyz[ok, 1] / ref[ok, 1] - 1.0)
    return {"dE_max": float(de.max()), "dE_p95": float(np.percentile(de, 95)),
            "dE_mean": float(np.sum(w * de)),
            "Y_err_max": float(yerr.max()) if yerr.size else float("nan"),
            "Y_err_mean": float(np.sum(w[ok] * yerr) / np.sum(w[ok])) if yerr.size else float("nan")}


def measure(model, atmospheres, elevations, steps, check_step, d, w, log=print):
    rows = []
    for k, (T, atm) in enumerate(atmospheres):
        timing = {}
        if k > 0:
            check_step = None  # the direct check (and its 3-minute field) only once
        # cold + warm renders of rgb, the reference and the check step (first elevation)
        # (the reference last: clearing the caches would otherwise evict its field)
        for sampling, step in (("spectral", check_step), ("rgb", REFERENCE_STEP),
                               ("spectral", REFERENCE_STEP)):
            if step is None:
                continue
            _clear_caches()
            sc = _scene(model, T, atm, elevations[0], sampling, step)
            _, cold = _render(sc, d)
            _, warm = _render(sc, d)
            timing[(sampling, step)] = (cold, warm)
            log(f"T={T} {atm} {sampling} {step:g} nm: cold {cold:.2f} s, warm {warm:.3f} s")
        for elev in elevations:
            ref_scene = _scene(model, T, atm, elev, "spectral", REFERENCE_STEP)
            ref, _ = _render(ref_scene, d)
            f_ref, p_ref = _raw(ref_scene, d)
            cases = [("rgb", REFERENCE_STEP)] + [("spectral", s) for s in steps]
            for sampling, step in cases:
                check = ""
                if sampling == "rgb":
                    xyz, _ = _render(_scene(model, T, atm, elev, "rgb", REFERENCE_STEP), d)
                    n = 3
                    cold, warm = timing[("rgb", REFERENCE_STEP)]
                else:
                    sub = _scene(model, T, atm, elev, "spectral", step)
                    xyz, n = _xyz_from_subset(f_ref, p_ref, sub)
                    cold, warm = timing.get(("spectral", step), (float("nan"), float("nan")))
                    if check_step is not None and step == check_step:
                        direct, _ = _render(sub, d)
                        check = f"{compare(direct, xyz, w)['dE_max']:.2e}"
                st = compare(xyz, ref, w)
                rows.append({"model": model, "turbidity": T, "atmosphere": atm,
                             "sun_elevation": elev, "sampling": sampling,
                             "step": "" if sampling == "rgb" else step, "n_wavelengths": n,
                             **st, "cold_s": cold, "warm_s": warm, "subset_check": check})
            rc, rw = timing[("spectral", REFERENCE_STEP)]
            rows.append({"model": model, "turbidity": T, "atmosphere": atm,
                         "sun_elevation": elev, "sampling": "spectral", "step": REFERENCE_STEP,
                         "n_wavelengths": len(p_ref.wavelengths), "dE_max": 0.0, "dE_p95": 0.0,
                         "dE_mean": 0.0, "Y_err_max": 0.0, "Y_err_mean": 0.0,
                         "cold_s": rc, "warm_s": rw, "subset_check": "reference"})
            r = [x for x in rows if x["sun_elevation"] == elev and x["turbidity"] == T]
            log(f"T={T} sun {elev:+5.1f}: " + ", ".join(
                f"{x['sampling'][:4]}{x['n_wavelengths']} {x['dE_p95']:.2f}" for x in r))
    return rows


def reference_check(elevations, atmospheres, d, w):
    """ΔE2000 (max over the map) of the 10 nm reference against 5 nm, single scattering
    (cheap at many wavelengths; the spectral shape of multiple scattering is smoother)."""
    out = []
    for T, atm in atmospheres:
        for e in elevations:
            a, _ = _render(_scene("single_scattering", T, atm, e, "spectral", REFERENCE_STEP), d)
            b, _ = _render(_scene("single_scattering", T, atm, e, "spectral", 5.0), d)
            out.append((T, e, compare(a, b, w)["dE_max"]))
    return out


def derive_rule(rows, limit=LIMIT, stat=RULE_STAT):
    """The ``sampling="auto"`` rule from the measured rows (see module docstring)."""
    elevs = sorted({float(r["sun_elevation"]) for r in rows}, reverse=True)

    def worst(sampling, step, e):
        vals = [float(r[stat]) for r in rows if float(r["sun_elevation"]) == e
                and r["sampling"] == sampling
                and (sampling == "rgb" or float(r["step"]) == step)]
        return max(vals) if vals else float("inf")

    threshold = None  # lowest elevation with rgb within the limit here and everywhere above
    for e in elevs:
        if worst("rgb", None, e) <= limit:
            threshold = e
        else:
            break
    if threshold is None:
        threshold = 90.0
    below = [e for e in elevs if e < threshold]
    steps = sorted({float(r["step"]) for r in rows if r["sampling"] == "spectral"},
                   reverse=True)
    chosen = min(steps)  # coarsest step that passes together with every finer step
    for s in sorted(steps):
        if not all(worst("spectral", s, e) <= limit for e in below):
            break
        chosen = s
    n_wl = int(np.floor((780.0 - 380.0) / chosen + 1e-9)) + 1
    rgb_dE = {f"{e:g}": worst("rgb", None, e) for e in elevs}
    step_dE = {f"{e:g}": worst("spectral", chosen, e) for e in elevs}
    return {"limit_dE2000": limit, "statistic": stat, "elevation_threshold_deg": threshold,
            "wavelength_step_nm": chosen, "n_wavelengths": n_wl,
            "rgb_dE2000_by_elevation": rgb_dE, "spectral_dE2000_by_elevation": step_dE}


def write_csv(rows, path):
    tmp = path + ".tmp"
    with open(tmp, "w", newline="", encoding="utf-8") as fh:
        wr = csv.DictWriter(fh, fieldnames=FIELDS)
        wr.writeheader()
        for r in rows:
            wr.writerow({k: (f"{v:.6g}" if isinstance(v, float) else v) for k, v in r.items()})
    os.replace(tmp, path)


def read_csv(path):
    with open(path, encoding="utf-8") as fh:
        return list(csv.DictReader(fh))


def _f(x, fmt):
    try:
        v = float(x)
    except (TypeError, ValueError):
        return str(x)
    return "–" if not np.isfinite(v) else format(v, fmt)


def markdown(rows, rule, header, refcheck=None):
    out = [header, ""]
    model = rows[0]["model"]
    out.append(f"Model `{model}`; reference: spectral sampling every {REFERENCE_STEP:g} nm. "
               "ΔE2000: CIE Lab with the D65 white point after dividing XYZ by the reference "
               "map's maximum Y; max / 95th percentile / solid-angle mean over the "
               f"{N_AZ}×{N_EL} upper-hemisphere map.  Y error: |Y/Y_ref − 1|.  Steps coarser "
               "than the reference: evaluated at the reference's wavelengths subset "
               "(see the script's docstring).")
    out.append("")
    out.append("| T | sun [deg] | sampling | n_wl | ΔE max | ΔE p95 | ΔE mean | Y err max "
               "| Y err mean |")
    out.append("|---|---|---|---|---|---|---|---|---|")
    for r in rows:
        if r["subset_check"] == "reference":
            continue
        samp = r["sampling"] if r["sampling"] == "rgb" else f"spectral {_f(r['step'], 'g')} nm"
        out.append(f"| {_f(r['turbidity'], 'g')} | {_f(r['sun_elevation'], 'g')} | {samp} "
                   f"| {r['n_wavelengths']} | {_f(r['dE_max'], '.2f')} | {_f(r['dE_p95'], '.2f')} "
                   f"| {_f(r['dE_mean'], '.2f')} | {_f(r['Y_err_max'], '.1%')} "
                   f"| {_f(r['Y_err_mean'], '.1%')} |")
    out += ["", "Cost (wall time of one render of the map; cold = field computed from scratch, "
            "`ATMOSCATTER_CACHE_DIR=off` and in-process caches cleared; warm = the same render "
            "again):", "", "| T | sampling | n_wl | cold [s] | warm [s] |", "|---|---|---|---|---|"]
    out += _cost_rows(rows)
    checks = [r["subset_check"] for r in rows if r["subset_check"] not in ("", "reference")]
    if checks:
        out += ["", f"Subset check: the direct {CHECK_STEP:g} nm render differs from the "
                f"subset evaluation by ΔE2000 ≤ {max(float(c) for c in checks):.2g} (max over "
                "all rows)."]
    if refcheck:
        worst = max(refcheck, key=lambda t: t[2])
        out += ["", f"Reference check: {REFERENCE_STEP:g} nm against 5 nm sampling "
                "(single_scattering, same maps): ΔE2000 ≤ "
                f"{worst[2]:.2f} (max over the map, all listed suns and atmospheres; worst "
                f"at T = {worst[0]:g}, sun {worst[1]:g}°)."]
    out += ["", "Rule of `sampling=\"auto\"` derived from this table "
            f"(target ΔE2000 {rule['statistic']} ≤ {rule['limit_dE2000']:g}, worst atmosphere): "
            f"spectral sampling every {rule['wavelength_step_nm']:g} nm "
            f"({rule['n_wavelengths']} wavelengths) when the sun is below "
            f"{rule['elevation_threshold_deg']:g}°, else rgb.", ""]
    return "\n".join(out)


def _cost_rows(rows):
    """One table row per (turbidity, sampling, wavelengths): cold and warm render time."""
    out, seen = [], set()
    for r in rows:
        key = (r["turbidity"], r["sampling"], r["n_wavelengths"])
        if key in seen or not np.isfinite(float(r["cold_s"])):
            continue
        seen.add(key)
        samp = r["sampling"] if r["sampling"] == "rgb" else f"spectral {_f(r['step'], 'g')} nm"
        out.append(f"| {_f(r['turbidity'], 'g')} | {samp} | {r['n_wavelengths']} "
                   f"| {_f(r['cold_s'], '.1f')} | {_f(r['warm_s'], '.3f')} |")
    return out


DOC_ELEVATIONS = (60.0, 2.0, -6.0, -10.0)
BEGIN, END = "<!-- spectral_sampling:begin (generated) -->", "<!-- spectral_sampling:end -->"


def doc_table(rows, rule):
    """Short table for docs/numerical_scattering.md: rgb and the rule's step at the
    elevations of :data:`DOC_ELEVATIONS`, and the cost."""
    step = float(rule["wavelength_step_nm"])
    out = [BEGIN, "", "| T | sun [deg] | rgb ΔE2000 p95 (max) | rgb Y err max "
           f"| {step:g} nm ΔE2000 p95 (max) | {step:g} nm Y err max |", "|---|---|---|---|---|---|"]
    for T in sorted({float(r["turbidity"]) for r in rows}):
        for e in DOC_ELEVATIONS:
            sel = [r for r in rows if float(r["turbidity"]) == T and float(r["sun_elevation"]) == e]
            rgb = [r for r in sel if r["sampling"] == "rgb"]
            spc = [r for r in sel if r["sampling"] == "spectral" and r["step"] != ""
                   and float(r["step"]) == step]
            if not rgb or not spc:
                continue
            a, b = rgb[0], spc[0]
            out.append(f"| {T:g} | {e:g} | {_f(a['dE_p95'], '.2f')} ({_f(a['dE_max'], '.2f')}) "
                       f"| {_f(a['Y_err_max'], '.1%')} | {_f(b['dE_p95'], '.2f')} "
                       f"({_f(b['dE_max'], '.2f')}) | {_f(b['Y_err_max'], '.1%')} |")
    out += ["", "| T | sampling | wavelengths | first render (field from scratch) [s] "
            "| warm render [s] |", "|---|---|---|---|---|"]
    out += _cost_rows(rows)
    out += ["", f"Rule (from the full table): below {rule['elevation_threshold_deg']:g}° sun "
            f"elevation `sampling=\"auto\"` samples every {step:g} nm "
            f"({rule['n_wavelengths']} wavelengths); target ΔE2000 (95th percentile over the "
            f"sky) ≤ {rule['limit_dE2000']:g}.", "", END]
    return "\n".join(out)


def update_doc(path, block):
    """Replace the generated block between the markers of ``path`` (atomic write)."""
    with open(path, encoding="utf-8") as fh:
        text = fh.read()
    i, j = text.find(BEGIN), text.find(END)
    if i < 0 or j < 0:
        raise SystemExit(f"{path}: markers {BEGIN!r} ... {END!r} not found")
    write_text(path, text[:i] + block + text[j + len(END):])


def write_text(path, text):
    tmp = path + ".tmp"
    with open(tmp, "w", encoding="utf-8") as fh:
        fh.write(text)
    os.replace(tmp, path)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true",
                    help="single_scattering, 16x8 map, 3 elevations; output to a temp dir")
    ap.add_argument("--from-csv", help="re-derive the markdown, JSON and docs section from "
                    "this CSV (of a full run)")
    ap.add_argument("--out", help="output directory (default docs/convergence, or temp with --quick)")
    args = ap.parse_args(argv)
    global N_AZ, N_EL
    if args.quick:
        outdir = args.out or tempfile.mkdtemp(prefix="spectral_sampling_")
        json_path = os.path.join(outdir, "spectral_sampling.json")
    else:
        outdir = args.out or os.path.join(ROOT, "docs", "convergence")
        json_path = os.path.join(ROOT, "atmoscatter", "data", "spectral_sampling.json")
    os.makedirs(outdir, exist_ok=True)
    csv_path = os.path.join(outdir, "spectral_sampling.csv")
    md_path = os.path.join(outdir, "spectral_sampling.md")
    refcheck = None
    if args.from_csv:
        rows = read_csv(args.from_csv)
        # the 5 nm reference check is cheap (single scattering): recomputed, not stored
        d, w = hemisphere(N_AZ, N_EL)
        refcheck = reference_check(
            sorted({float(r["sun_elevation"]) for r in rows}, reverse=True),
            sorted({(float(r["turbidity"]), r["atmosphere"]) for r in rows}), d, w)
        cmd = ("PYTHONPATH=. python benchmarks/spectral_sampling.py` (measurements; the text "
               "re-derived from its CSV with `--from-csv`)")
    else:
        if args.quick:
            N_AZ, N_EL = 16, 8
            model, atms, elevs = "single_scattering", ((2.5, "earth"),), (60.0, 2.0, -6.0)
        else:
            model, atms, elevs = "multiple_scattering", ATMOSPHERES, ELEVATIONS
        d, w = hemisphere(N_AZ, N_EL)
        t0 = time.perf_counter()
        rows = measure(model, atms, elevs, SUBSET_STEPS, CHECK_STEP, d, w)
        refcheck = reference_check(elevs, atms, d, w)
        print(f"total {time.perf_counter() - t0:.0f} s")
        write_csv(rows, csv_path)
        cmd = "PYTHONPATH=. python benchmarks/spectral_sampling.py" + (" --quick" if args.quick else "")
    rule = derive_rule(rows)
    rule["source"] = "docs/convergence/spectral_sampling.md"
    rule["model"] = rows[0]["model"]
    rule["generated"] = datetime.date.today().isoformat()
    if refcheck:
        rule["reference_check_dE2000_max"] = max(t[2] for t in refcheck)
    header = ("# Spectral sampling: 3 wavelengths against a spectrum\n\n"
              f"Generated by `{cmd}{'' if cmd.endswith(')') else '`'} on {rule['generated']} "
              f"({platform.machine()}, {os.cpu_count()} cores, shared/loaded VM; "
              f"Python {sys.version.split()[0]}).  Do not edit by hand.")
    write_text(md_path, markdown(rows, rule, header, refcheck))
    write_text(json_path, json.dumps(rule, indent=1, sort_keys=True) + "\n")
    if not args.quick:
        update_doc(os.path.join(ROOT, "docs", "numerical_scattering.md"), doc_table(rows, rule))
    print(f"wrote {md_path}, {csv_path if not args.from_csv else ''} {json_path}")
    print(json.dumps(rule, indent=1))


if __name__ == "__main__":
    main()

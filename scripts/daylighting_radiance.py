"""Tables of docs/daylighting.md: our daylighting skies against Radiance, and the Perez failure map.

Usage::

    python scripts/daylighting_radiance.py          # print the tables
    python scripts/daylighting_radiance.py --write  # replace them in docs/daylighting.md

Needs ``pyradiance`` (the ``test`` extra) for the Radiance table. Radiance's ``gensky`` /
``gendaylit`` write the sky, ``oconv`` + ``rtrace -ab 0`` evaluate it per direction (ground
reflectance 0, so the horizon blend with the ground is divided out exactly), on 12 elevations
(2°–88°) × 24 azimuths. "shape" is the largest relative difference after scaling Radiance's
values to ours by their median ratio (directions within 1° of the sun and where our luminance
is floored at 0 left out); "level" is Radiance's zenith luminance over ours for the same
(ε, Δ), i.e. the effect of gendaylit's 145-point normalisation alone.
"""

from __future__ import annotations

import argparse
import math
import pathlib
import re
import subprocess
import sys
import tempfile
import warnings

import numpy as np

ROOT = pathlib.Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

import atmoscatter as ac  # noqa: E402
from atmoscatter.sky import cie_standard as cs  # noqa: E402
from atmoscatter.sky import perez_all_weather as paw  # noqa: E402

DOC = ROOT / "docs" / "daylighting.md"
PEREZ_CASES = [(35.0, 0.0, 1.03, 0.25), (50.0, 30.0, 1.15, 0.3), (25.0, -40.0, 1.36, 0.35),
               (60.0, 90.0, 1.72, 0.25), (20.0, 10.0, 2.37, 0.2), (45.0, -120.0, 3.65, 0.15),
               (70.0, 45.0, 5.35, 0.12), (30.0, 160.0, 9.0, 0.1), (8.0, 0.0, 4.0, 0.3)]


def _bin():
    import pyradiance

    return pyradiance.BINPATH


def _run(prog, *args, stdin=None, cwd=None):
    return subprocess.run([str(_bin() / prog), *map(str, args)], input=stdin,
                          capture_output=True, check=True, cwd=cwd).stdout


def _grid():
    el = np.radians(np.linspace(2.0, 88.0, 12))
    az = np.radians(np.arange(24) * 15.0 + 7.0)
    E, A = np.meshgrid(el, az, indexing="ij")
    return np.stack([np.cos(E) * np.sin(A), np.cos(E) * np.cos(A), np.sin(E)], -1).reshape(-1, 3)


def _rtrace(sky, d, tmp):
    glow = b"\nskyfunc glow skyglow\n0\n0\n4 1 1 1 0\nskyglow source sky\n0\n0\n4 0 0 1 180\n"
    (tmp / "sky.rad").write_bytes(sky + glow)
    (tmp / "sky.oct").write_bytes(_run("oconv", "sky.rad", cwd=tmp))
    rays = "".join(f"0 0 0 {x:.10f} {y:.10f} {z:.10f}\n" for x, y, z in d).encode()
    out = _run("rtrace", "-h", "-ab", "0", "-ov", "sky.oct", stdin=rays, cwd=tmp)
    g = np.array(out.split(), dtype=float).reshape(-1, 3)[:, 1]
    dz = d[:, 2]
    return g * ((dz + 1.01) ** 10 + (dz + 1.01) ** -10) / (dz + 1.01) ** 10


def _sun(alt, az):
    a, z = math.radians(alt), math.radians(az)
    return np.array([-math.sin(z) * math.cos(a), -math.cos(z) * math.cos(a), math.sin(a)])


def _shape(rad, ours, keep):
    s = np.median(rad[keep] / ours[keep])
    return float(np.max(np.abs(rad[keep] / (s * ours[keep]) - 1)))


def radiance_table() -> str:
    d = _grid()
    rows = ["| Radiance | ours | sun elevation | shape (max rel. diff.) | level (Radiance/ours) |",
            "|---|---|---|---|---|"]
    with tempfile.TemporaryDirectory() as t:
        tmp = pathlib.Path(t)
        for alt in (15.0, 40.0, 70.0):
            rad = _rtrace(_run("gensky", "-ang", alt, 0, "-s", "-g", 0), d, tmp)
            sun = _sun(alt, 0)
            keep = np.ones(len(d), bool)
            for name, ours in (("`cie_clear_sky`", ac.cie_clear_sky(d, sun, 1.0)),
                               ("CIE type 12", cs.cie_standard_sky(d, sun, 12,
                                                                   zenith_luminance=1.0))):
                rows.append(f"| `gensky -s` | {name} | {alt:g}° | {_shape(rad, ours, keep):.1e} "
                            "| relative only |")
        for alt in (10.0, 45.0):
            rad = _rtrace(_run("gensky", "-ang", alt, 0, "-c", "-g", 0), d, tmp)
            keep = np.ones(len(d), bool)
            for name, ours in (("`cie_overcast_sky`", ac.cie_overcast_sky(d, 1.0)),
                               ("CIE type 1", cs.cie_standard_sky(d, _sun(alt, 0), 1,
                                                                  zenith_luminance=1.0))):
                rows.append(f"| `gensky -c` | {name} | {alt:g}° | {_shape(rad, ours, keep):.1e} "
                            "| relative only |")
        for alt, az, eps, dlt in PEREZ_CASES:
            out = _run("gendaylit", "-ang", alt, az, "-P", eps, dlt, "-g", 0, "-O", 2, "-s")
            rad = _rtrace(out, d, tmp)
            zs = math.radians(90 - alt)
            sun = _sun(alt, az)
            g = 2 * np.arctan2(np.linalg.norm(d - sun, axis=-1), np.linalg.norm(d + sun, axis=-1))
            coef = paw.perez_all_weather_coefficients(zs, eps, dlt)
            lv = paw.perez_all_weather_relative_luminance(np.arccos(d[:, 2]), g, *coef)
            keep = (g > math.radians(1.0)) & (lv > 0)
            # level: Radiance's zenith luminance against ours for the same ε, Δ, efficacy
            text = out.decode().split("perezlum.cal")[1].split("\n")[2].split()
            norm = float(text[1])
            lz_r = norm * float(paw.perez_all_weather_relative_luminance(0.0, zs, *coef))
            integ = paw._hemisphere.horizontal_integral(
                paw._lv_quadrature, [zs], tuple([c] for c in coef), z_breaks=paw._Z_BREAKS)[0]
            # gendaylit's D_v = norm x (its 145-point integral); ours uses the exact integral
            lz_o = lz_r * _tregenza145(coef, zs) / integ
            rows.append(f"| `gendaylit -P {eps:g} {dlt:g}` | `perez_all_weather` (bin "
                        f"{paw.perez_epsilon_bin(eps)}) | {alt:g}° | {_shape(rad, lv, keep):.1e} "
                        f"| {lz_r / lz_o:.4f} |")
    return "\n".join(rows)


def _tregenza145(coef, zs):
    """gendaylit's normalisation rule: Σ lv cos θ · 2π/144 over its 145 patch centres."""
    rings = [(84, 30), (72, 30), (60, 24), (48, 24), (36, 18), (24, 12), (12, 6), (0, 1)]
    total = 0.0
    for theta, n in rings:
        t = math.radians(theta)
        phi = np.radians(np.arange(n) * 360.0 / n)
        cg = np.clip(math.cos(zs) * math.cos(t) + math.sin(zs) * math.sin(t) * np.cos(phi), -1, 1)
        lv = paw.perez_all_weather_relative_luminance(t, np.arccos(cg), *coef)
        total += float(np.sum(lv)) * math.cos(t)
    return total * 2 * math.pi / 144


def failure_table() -> str:
    z = np.radians(np.linspace(0, 90, 46))
    dl = np.linspace(0.01, 0.6, 60)
    zz, dd = np.meshgrid(z, dl, indexing="ij")
    gz = np.radians(np.linspace(0, 90, 91))
    gg = np.radians(np.linspace(0, 180, 181))
    eps_mid = [1.03, 1.15, 1.36, 1.72, 2.37, 3.65, 5.35, 9.0]
    rows = ["| ε bin | b > 0 (with / without the Δ ≥ 0.2 correction) | lv < 0 somewhere "
            "(with / without) |", "|---|---|---|"]
    for i, e in enumerate(eps_mid):
        cells = []
        for corr in (True, False):
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                a, b, c, d, ee = paw.perez_all_weather_coefficients(zz, e, dd,
                                                                    low_delta_correction=corr)
            mu = np.maximum(np.cos(gz), 0.01)
            with np.errstate(over="ignore"):
                grad = 1 + a[..., None] * np.exp(np.clip(b[..., None] / mu, -700, 700))
            ind = 1 + c[..., None] * np.exp(d[..., None] * gg) + ee[..., None] * np.cos(gg) ** 2
            neg = (grad.min(-1) < 0) | (ind.min(-1) < 0)
            cells.append((np.mean(b > 0), np.mean(neg)))
        rows.append(f"| {i + 1} | {cells[0][0]:.0%} / {cells[1][0]:.0%} | "
                    f"{cells[0][1]:.0%} / {cells[1][1]:.0%} |")
    return "\n".join(rows)


def _replace(text, key, body):
    pat = re.compile(rf"(<!-- {key}:begin[^\n]*-->\n).*?(<!-- {key}:end -->)", re.S)
    if not pat.search(text):
        raise SystemExit(f"markers {key}:begin/end not found in {DOC}")
    return pat.sub(lambda m: m.group(1) + body + "\n" + m.group(2), text)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--write", action="store_true", help="update docs/daylighting.md")
    args = ap.parse_args(argv)
    fail = failure_table()
    rad = radiance_table()
    if args.write:
        text = DOC.read_text(encoding="utf-8")
        text = _replace(text, "perez_failure", fail)
        text = _replace(text, "radiance_comparison", rad)
        DOC.write_text(text, encoding="utf-8")
    else:
        print(fail, "", rad, sep="\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

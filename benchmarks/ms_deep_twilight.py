"""Deep twilight: the default grid's solar-zenith nodes near the horizon refined beyond it.

Usage (from the repository root)::

    PYTHONPATH=. python benchmarks/ms_deep_twilight.py           # -> docs/convergence/ms_deep_twilight.md
    PYTHONPATH=. python benchmarks/ms_deep_twilight.py --quick   # tiny grids -> a temp dir

Below sun −10° the sky of a ground observer is lit by the sunlit upper air far toward the
sun, and the field changes fastest with the solar zenith there: the one knob that moves
the error is ``horizon_n_sun``, the solar-zenith nodes of the default grid for a sun near
or below the horizon (:data:`~atmoscatter.sky.multiple.HORIZON_SUN_ELEVATION`).  This
measures the study's twilight scenes (``ms_convergence.py``: −10°, −12°, −15°, −18°,
turbidity 2.5, ground) with ``horizon_n_sun`` from the default's value up to 40 against the
study's reference, read from its store (``docs/convergence/ms_reference_values.npz``; run
``ms_convergence.py`` first when the method changed).  Refining a knob of the default
grid past the reference's own resolution shows where the reference stops being the
better answer: where the finer rows move away from it, the error figure of the default
there is uncertain by about that much.

The study's reference covers every sun, so its solar-zenith nodes at deep twilight are
1.1–2.9° apart, no finer than the default grid's centred on the sun.  The second table
measures the same rows against references *centred on each scene's sun*
(:data:`CENTRED_N_SUN`: ``horizon_n_sun`` 48 and 64, 0.7° and 0.5° apart at the sun, with
the study reference's other knobs and tolerance; kept in the same store), and the two
centred references against each other: that difference is the uncertainty of the
second table.
"""

from __future__ import annotations

import sys
import time
from dataclasses import replace
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

import ms_convergence as mc  # noqa: E402  (sets ATMOSCATTER_CACHE_DIR=off first)

SCENES = ("nautical_twilight", "nautical_twilight_end", "deep_twilight",
          "astronomical_twilight_end")
N_SUN = (16, 24, 32, 40)
#: a grid over every sun (as the reference) with half as many solar-zenith nodes again as
#: the reference and the default's other knobs: the reference refined in the knob that
#: matters here (the reference grid itself refined so costs about twice its build)
ALL_SUNS = replace(mc.REFERENCE[0], n_sun=96, n_altitude=32, n_mu=32, n_phi=19, order=3)
#: scenes measured against references centred on their own sun, and the solar-zenith nodes
#: of those references (the last is the one the second table measures against)
CENTRED_SCENES = ("nautical_twilight_end", "deep_twilight", "astronomical_twilight_end")
CENTRED_N_SUN = (48, 64)
QUICK_SCENES = ("civil_twilight",)
QUICK_CENTRED_N_SUN = (10, 14)
QUICK_N_SUN = (4, 6)
QUICK_ALL_SUNS = replace(mc.QUICK_REFERENCE[0], n_sun=14)


centred = mc.centred


def run(scenes, n_suns, default, reference, store, all_suns, centred_scenes=(),
        centred_n_sun=(), progress=print):
    """``(errors, first, against)``: ``{(scene, row): (e_total, e_ms)}`` against the study's
    reference, ``{(scene, row): first call [s]}``, ``row`` a value of ``horizon_n_sun`` or
    ``"all"`` (the grid ``all_suns``); ``against`` the same errors of the
    ``centred_scenes`` against the reference centred on their sun with the last of
    ``centred_n_sun`` nodes, with the rows ``"reference"`` (the study's) and
    ``("centred", n)`` for the other centred references."""
    mc.warm_up()
    grid0, tol = default
    errors, first, against = {}, {}, {}
    for akey, names in mc.by_atmosphere(scenes).items():
        atm = mc.ATMOSPHERES[akey]()
        # the study's reference of this atmosphere: of every one of its scenes (the store's
        # key), of which these are a part
        every = [s for s in mc.SCENES if mc.SCENES[s][0] == akey]
        # the reference over every sun itself (reference_values swaps in the centred one
        # below mc.CENTRED_BELOW: the second table)
        ref, _, _ = mc._reference_values(atm, every, reference, store, progress)
        single = mc.single_of(atm, names)
        # references centred on each scene's sun (one field per scene and node count,
        # stored like the study's reference)
        cent = {}
        for s in (s for s in names if s in centred_scenes):
            for n in centred_n_sun:
                cent[(s, n)] = mc.reference_values(atm, [s], centred(reference, n), store,
                                                   progress)[0][s]
        rows = [(n, replace(grid0, horizon_n_sun=n)) for n in n_suns] + [("all", all_suns)]
        for row, grid in rows:
            out, build, evals = mc.evaluate(atm, names, (grid, tol))
            for s in names:
                errors[(s, row)] = mc.errors(out[s], ref[s], single[s])
                # a grid over every sun builds one field for every scene
                first[(s, row)] = evals[s] if grid.sun_nodes == "scene" else build
                if (s, centred_n_sun[-1]) in cent:
                    against[(s, row)] = mc.errors(out[s], cent[(s, centred_n_sun[-1])], single[s])
            progress(f"{akey}: {row} done")
        for s in (s for s in names if (s, centred_n_sun[-1]) in cent):
            best = cent[(s, centred_n_sun[-1])]
            against[(s, "reference")] = mc.errors(ref[s], best, single[s])
            for n in centred_n_sun[:-1]:
                against[(s, ("centred", n))] = mc.errors(cent[(s, n)], best, single[s])
    return errors, first, against


def markdown(scenes, n_suns, default, reference, all_suns, errors, first, machine, command,
             against=None, centred_scenes=(), centred_n_sun=()):
    lines = [
        "Max relative error of the total / of the multiple-scattering part of the default "
        f"grid with `horizon_n_sun` changed, against the study's reference "
        f"({mc._grid_text(reference)}); first call [s] in brackets; the default's "
        f"value ({default[0].horizon_n_sun}) in bold.",
        "",
        "| horizon_n_sun | " + " | ".join(f"{s} (sun {mc.SCENES[s][1]:g}°)" for s in scenes) + " |",
        "|---:|" + "---|" * len(scenes),
    ]
    for n in n_suns:
        cells = " | ".join(f"{mc._fmt(errors[(s, n)][0])} / {mc._fmt(errors[(s, n)][1])} "
                           f"({first[(s, n)]:.1f})" for s in scenes)
        label = f"**{n}**" if n == default[0].horizon_n_sun else str(n)
        lines.append(f"| {label} | {cells} |")
    cells = " | ".join(f"{mc._fmt(errors[(s, 'all')][0])} / {mc._fmt(errors[(s, 'all')][1])}"
                       for s in scenes)
    lines.append(f"| over every sun: {mc._grid_text((all_suns, default[1]))} | {cells} |")
    lines += ["", "The last row is a grid over every sun like the reference, with more "
              "solar-zenith nodes than it and the default's other knobs; one field serves "
              f"every scene (built in {first[(scenes[0], 'all')]:.0f} s)."]
    if against:
        lines += centred_table(n_suns, default, reference, all_suns, against,
                               [s for s in scenes if s in centred_scenes], centred_n_sun)
    lines += ["", f"*{machine}, {time.strftime('%Y-%m-%d')}; `{command}`.*"]
    return "\n".join(lines) + "\n"


def centred_table(n_suns, default, reference, all_suns, against, scenes, centred_n_sun):
    """The rows of :func:`markdown` against the references centred on each scene's sun."""
    best = centred_n_sun[-1]
    lines = ["", f"Against references centred on each scene's sun ({mc._grid_text(centred(reference, best))}, "
             "one field per scene; "
             + ", ".join(f"{n} nodes" for n in centred_n_sun[:-1])
             + f" against {best} in the last rows: the uncertainty of this table), max "
             "relative error of the total / of the multiple-scattering part:", "",
             "| grid | " + " | ".join(f"{s} (sun {mc.SCENES[s][1]:g}°)" for s in scenes) + " |",
             "|---|" + "---|" * len(scenes)]

    def row(label, key):
        cells = " | ".join(f"{mc._fmt(against[(s, key)][0])} / {mc._fmt(against[(s, key)][1])}"
                           for s in scenes)
        lines.append(f"| {label} | {cells} |")

    for n in n_suns:
        row(f"**horizon_n_sun {n}** (default)" if n == default[0].horizon_n_sun
            else f"horizon_n_sun {n}", n)
    row(f"over every sun, n_sun {all_suns.n_sun}", "all")
    row(f"the study's reference (over every sun, n_sun {reference[0].n_sun})", "reference")
    for n in centred_n_sun[:-1]:
        row(f"centred reference, {n} nodes", ("centred", n))
    return lines


def main(argv=None) -> int:
    cl = mc.study_command_line(__file__, __doc__, "tiny grids, one scene, temp dir", argv)
    if cl["quick"]:
        scenes, n_suns = QUICK_SCENES, QUICK_N_SUN
        default = (replace(mc.QUICK_DEFAULT[0], horizon_n_sun=QUICK_N_SUN[0]), mc.QUICK_DEFAULT[1])
        reference, all_suns = mc.QUICK_REFERENCE, QUICK_ALL_SUNS
        centred_scenes, centred_n_sun = QUICK_SCENES, QUICK_CENTRED_N_SUN
    else:
        scenes, n_suns, default, reference = SCENES, N_SUN, mc.DEFAULT, mc.REFERENCE
        all_suns, centred_scenes, centred_n_sun = ALL_SUNS, CENTRED_SCENES, CENTRED_N_SUN
    t0 = time.perf_counter()
    errors, first, against = run(list(scenes), n_suns, default, reference, cl["store"], all_suns,
                                 centred_scenes, centred_n_sun)
    text = markdown(scenes, n_suns, default, reference, all_suns, errors, first, mc.machine_text(),
                    cl["command"], against, centred_scenes, centred_n_sun)
    mc.write_study_page(cl["out"], "ms_deep_twilight.md", text, t0)
    return 0


if __name__ == "__main__":
    sys.exit(main())

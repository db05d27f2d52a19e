"""The ``atmoscatter compare OTHER.exr --scene SCENE [-o DIR]`` subcommand.

Public objects
--------------
- :func:`add_compare_parser`: register the subcommand on the ``atmoscatter`` command.
- :func:`run_compare`: its handler (prints the summary, writes the report with ``-o``).
"""

from __future__ import annotations

from .read import FLIPS, LAYOUTS, _read_exr_channels
from .reference import REGIONS, compare_exr
from .stats import SCALE_METHODS

__all__ = ["add_compare_parser", "run_compare"]


# --------------------------------------------------------------------------------------
# command line
# --------------------------------------------------------------------------------------
def add_compare_parser(subparsers):
    """Register ``atmoscatter compare OTHER.exr --scene SCENE [-o DIR]`` on ``subparsers``.

    The handler is :func:`run_compare` (also set as the parser's ``func`` default).

    Parameters
    ----------
    subparsers : argparse._SubParsersAction
        The ``atmoscatter`` command's sub-command registry (``parser.add_subparsers()``).

    Returns
    -------
    argparse.ArgumentParser
        The ``compare`` parser.
    """
    import argparse

    p = subparsers.add_parser(
        "compare",
        help="compare another renderer's EXR sky map with our reference render",
        description=(
            "Render our reference for SCENE at the directions of OTHER.exr and report the "
            "luminance relative error (median, p95, max; no rescaling), the best-fit scale "
            "factor and Delta E 2000 after exposure normalisation.  Assumed layout: OpenEXR "
            "envmap conventions (lat-long: zenith on top, north in the centre column, east at "
            "3/4 width; cube map: +X,-X,+Y,-Y,+Z,-Z faces of the frame x=west, y=up, "
            "z=north); RGB is linear in --colourspace."
        ),
    )
    p.add_argument("other", metavar="OTHER.exr", help="the other renderer's sky map")
    p.add_argument("--scene", default=None,
                   help="scene file (TOML or JSON); default: the atmoscatter scene recorded "
                        "in OTHER.exr's header, if any")
    p.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                   help="override a scene field (repeatable)")
    p.add_argument("-o", "--output", metavar="DIR", default=None,
                   help="write DIR/summary.json, DIR/error_map.png and DIR/delta_e_map.png")
    p.add_argument("--layout", choices=LAYOUTS, default="auto",
                   help="layout of OTHER.exr (default: from its envmap attribute or shape)")
    p.add_argument("--rotate", type=float, default=0.0, metavar="DEG",
                   help="the file's azimuth a is compared with ours at a + DEG")
    p.add_argument("--flip", choices=FLIPS, default="none",
                   help="mirror OTHER.exr's columns (azimuth) and/or rows before rotating")
    p.add_argument("--colourspace", default="sRGB",
                   help="colourspace of OTHER.exr's linear RGB (colour-science name)")
    p.add_argument("--region", choices=REGIONS, default="sky",
                   help="compare the sky above the horizon (default) or all pixels")
    p.add_argument("--sun-exclusion", type=float, default=1.0, metavar="DEG",
                   help="leave out a cone of this radius around the sun (default 1)")
    p.add_argument("--scale-method", choices=sorted(SCALE_METHODS), default="median_log")
    p.add_argument("--debug", action="store_true", default=argparse.SUPPRESS,
                   help="show tracebacks on errors")
    p.set_defaults(func=run_compare)
    return p


def _scene_for_cli(args):
    from ..scene import Scene, load_scene

    if args.scene:
        scene = load_scene(args.scene)
    else:
        _, header = _read_exr_channels(args.other)
        data = {k: v for k, v in header.items()
                if k in Scene.field_names() and isinstance(v, str)}
        if not data:
            raise ValueError(f"{args.other!r} records no atmoscatter scene; pass --scene "
                             "SCENE.toml (the scene the other renderer rendered)")
        scene = Scene.from_dict(data)
    if args.set:
        scene = scene.replace_from_strings(args.set)
    return scene


def run_compare(args, out=None) -> int:
    """Handler of the ``compare`` subcommand: prints the summary (to ``out``, default
    stdout), writes the report if ``-o`` was given and returns the exit status (0).

    Parameters
    ----------
    args : argparse.Namespace
        Parsed arguments of the ``compare`` parser (:func:`add_compare_parser`).
    out : file-like, optional
        Where the summary is printed (default ``sys.stdout``).

    Returns
    -------
    int
        Exit status: 0.
    """
    import sys

    out = sys.stdout if out is None else out
    result = compare_exr(
        args.other, _scene_for_cli(args), layout=args.layout, rotate_deg=args.rotate,
        flip=args.flip, colourspace=args.colourspace, region=args.region,
        sun_exclusion_deg=args.sun_exclusion, scale_method=args.scale_method,
    )
    print(result.summary_text(), file=out)
    if args.output:
        paths = result.write(args.output)
        print("wrote " + ", ".join(paths.values()), file=out)
    return 0

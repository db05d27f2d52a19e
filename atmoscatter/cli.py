"""The ``atmoscatter`` command.

Sub-commands
------------
``atmoscatter render [SCENE] -o sky.exr [--set key=value ...] [--explain] [--preview sky.png]``
    Render one scene (a TOML/JSON file, or the documented default scene).
``atmoscatter batch SCENES -o DIR [--set key=value ...] [--workers N] [--dask | --scheduler ADDRESS]``
    Render many scenes (CSV table or TOML with ``[base]``, ``[[scene]]``, ``[sweep]``).
``atmoscatter batch --weather FILE.epw -o DIR [--hours SPEC] [--every N] [--set ...]``
    One Perez all-weather sky per daylit hour of a weather file
    (:mod:`atmoscatter.batch.weather`).
``atmoscatter info FILE.exr [--json]``
    Show the metadata of a sky map.
``atmoscatter preview FILE.exr -o sky.png [--exposure X] [--tone T] [--alpha A]``
    Write a tone-mapped PNG.
``atmoscatter models``
    List the sky models available in this installation.
``atmoscatter cache list [--kind K] [--json]``, ``cache clear [--kind K]``, ``cache dir``
    Inspect or empty the on-disk cache of precomputed fields (:mod:`atmoscatter.cache`).

Errors are printed as one line (``atmoscatter: error: ...``) with exit status 2
(1 when some scenes of a batch failed); ``--debug`` shows the traceback.
"""

from __future__ import annotations

import argparse
import contextlib
import json
import os
import sys
import threading
import time
import warnings

from .compare import add_compare_parser, run_compare

__all__ = ["main"]


def _count(text: str) -> int:
    """argparse type of ``--workers``/``--batch-size``: an integer >= 1."""
    try:
        value = int(text)
    except ValueError:
        value = None
    if value is None or value < 1:
        raise argparse.ArgumentTypeError(f"must be an integer in [1, inf), got {text!r}")
    return value


class _Parser(argparse.ArgumentParser):
    """argparse with the CLI's one-line errors: ``atmoscatter render: error: … (see
    'atmoscatter render --help')`` instead of the usage block followed by the error."""

    def error(self, message):
        self.exit(2, f"{self.prog}: error: {message} (see '{self.prog} --help')\n")


def _parser() -> argparse.ArgumentParser:
    from . import __version__  # noqa: PLC0415

    p = _Parser(
        prog="atmoscatter",
        description="Sky colour and brightness from atmospheric light-scattering physics.",
    )
    p.add_argument("--version", action="version", version=f"atmoscatter {__version__}")
    p.add_argument("--debug", action="store_true", help="show tracebacks on errors")
    sub = p.add_subparsers(dest="command", metavar="COMMAND")

    def common(sp):
        sp.add_argument("--debug", action="store_true", default=argparse.SUPPRESS,
                        help="show tracebacks on errors")

    r = sub.add_parser("render", help="render one scene to an EXR sky map")
    r.add_argument("scene", nargs="?", help="scene file (.toml or .json); default: the default scene")
    r.add_argument("-o", "--output", help="output EXR file")
    r.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                   help="override a scene field (repeatable)")
    r.add_argument("--explain", action="store_true", help="print the plan (and render if -o is given)")
    r.add_argument("--preview", metavar="PNG", help="also write a tone-mapped PNG preview")
    r.add_argument("--workers", type=_count, default=None, help="threads (default: cores)")
    r.add_argument("--batch-size", type=_count, default=None, help="directions per model call")
    r.add_argument("--quiet", action="store_true",
                   help="no progress bar (shown on a terminal when a render takes over ~2 s)")
    common(r)

    b = sub.add_parser("batch", help="render many scenes (CSV/TOML table, sweep or weather file)")
    b.add_argument("scenes", nargs="?",
                   help="CSV (header: scene fields + name) or TOML batch file (or --weather)")
    w = b.add_argument_group("weather file (one Perez all-weather sky per daylit hour)")
    w.add_argument("--weather", metavar="FILE.epw",
                   help="EnergyPlus weather file instead of SCENES (needs atmoscatter[weather])")
    w.add_argument("--hours", metavar="SPEC",
                   help="rows N, N-M (1-8760) or dates M/D, M/D-M/D, comma-separated")
    w.add_argument("--every", type=_count, default=1, metavar="N",
                   help="every N-th selected hour (default 1)")
    b.add_argument("-o", "--output", required=True, help="output directory")
    b.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                   help="override a field in every scene (repeatable)")
    b.add_argument("--workers", type=_count, default=1, help="local processes (default 1)")
    g = b.add_mutually_exclusive_group()
    g.add_argument("--scheduler", metavar="ADDRESS", help="Dask scheduler address (tcp://host:8786)")
    g.add_argument("--dask", action="store_true",
                   help="start a local Dask cluster with --workers workers")
    b.add_argument("--no-resume", action="store_true", help="re-render complete outputs too")
    b.add_argument("--quiet", action="store_true",
                   help="no progress bar (there is none either when stderr is not a terminal)")
    common(b)

    i = sub.add_parser("info", help="show the metadata of an EXR sky map")
    i.add_argument("file", help="EXR file")
    i.add_argument("--json", action="store_true", help="print the header as JSON")
    common(i)

    v = sub.add_parser("preview", help="write a tone-mapped PNG of an EXR sky map")
    v.add_argument("file", help="EXR sky map")
    v.add_argument("-o", "--output", required=True, help="output PNG file")
    v.add_argument("--exposure", type=float, default=None, help="[m^2/cd]; default automatic")
    v.add_argument("--tone", choices=["exponential", "reinhard", "clip", "luminance"],
                   default=None, help="tone curve (default: the scene's, else exponential; "
                   "luminance keeps each colour's chromaticity)")
    v.add_argument("--alpha", choices=["none", "mask", "sky"], default="none",
                   help="PNG alpha: none, the map's mask, or seed 002's (r+g+b)^transparency")
    v.add_argument("--transparency", type=float, default=0.5,
                   help="exponent of --alpha sky, in (0, inf) (default 0.5)")
    common(v)

    sub.add_parser("models", help="list the available sky models")

    c = sub.add_parser("cache", help="list or clear the cache of precomputed fields")
    csub = c.add_subparsers(dest="cache_command", metavar="ACTION", required=True)
    cl = csub.add_parser("list", help="list the cached entries (most recently used first)")
    cl.add_argument("--kind", default=None, help="only entries of this kind")
    cl.add_argument("--json", action="store_true", help="print the entries as JSON")
    common(cl)
    cc = csub.add_parser("clear", help="remove cached entries")
    cc.add_argument("--kind", default=None, help="only entries of this kind")
    common(cc)
    common(csub.add_parser("dir", help="print the cache directory"))
    add_compare_parser(sub)
    return p


def _scene_from_args(args):
    from .scene import load_scene  # noqa: PLC0415

    return load_scene(args.scene, overrides=args.set)


def _cmd_render(args, out) -> int:
    from .exr import write_exr  # noqa: PLC0415
    from .preview import write_preview  # noqa: PLC0415
    from .render import render  # noqa: PLC0415
    from .render.plan import plan  # noqa: PLC0415

    scene = _scene_from_args(args)
    if args.explain:
        print(plan(scene, batch_size=args.batch_size).explain(), file=out)
        if not args.output:
            return 0
    if not args.output:
        raise ValueError("render needs an output file: -o sky.exr (or --explain to only plan)")
    _check_render_outputs(args)
    t0 = time.perf_counter()
    with _render_progress(quiet=args.quiet) as progress, _precompute_progress(quiet=args.quiet):
        img = render(scene, workers=args.workers, batch_size=args.batch_size, progress=progress)
    write_exr(args.output, img)
    size = "x".join(map(str, img.shape[::-1]))
    print(f"wrote {args.output} ({scene.projection} {size}, "
          f"model {scene.model}, {time.perf_counter() - t0:.2f} s)", file=out)
    if args.preview:
        write_preview(img, args.preview)
        print(f"wrote {args.preview}", file=out)
    return 0


#: A render's progress bar appears only once the render has run this long [s].
PROGRESS_DELAY = 2.0


@contextlib.contextmanager
def _render_progress(*, quiet: bool, stream=None):
    """A ``progress(done, total)`` callback drawing a tqdm bar on ``stream`` (stderr), or None.

    None (no bar, tqdm not imported) under ``--quiet`` or when the stream is not a terminal;
    the bar itself stays hidden for renders shorter than :data:`PROGRESS_DELAY`.
    """
    stream = sys.stderr if stream is None else stream
    isatty = getattr(stream, "isatty", None)
    if quiet or isatty is None or not isatty():
        yield None
        return
    from tqdm import tqdm  # noqa: PLC0415

    bar = None
    t0 = time.monotonic()

    def progress(done, total):
        nonlocal bar
        if bar is None:  # hidden until PROGRESS_DELAY after the start (set-up included)
            wait = max(0.0, PROGRESS_DELAY - (time.monotonic() - t0))
            bar = tqdm(total=total, unit="dir", unit_scale=True, desc="render", file=stream,
                       delay=wait, leave=False, dynamic_ncols=True)
        bar.update(done - bar.n)

    try:
        yield progress
    finally:
        if bar is not None:
            bar.close()


@contextlib.contextmanager
def _precompute_progress(*, quiet: bool, stream=None):
    """A tqdm bar per stage of long precomputations (the multiple-scattering field, one
    stage per scattering order; :mod:`atmoscatter._progress`) on ``stream`` (stderr), under
    the same rules as :func:`_render_progress`."""
    from . import _progress  # noqa: PLC0415

    stream = sys.stderr if stream is None else stream
    isatty = getattr(stream, "isatty", None)
    if quiet or isatty is None or not isatty():
        yield
        return
    from tqdm import tqdm  # noqa: PLC0415

    lock = threading.Lock()
    bars: dict = {}
    t0 = time.monotonic()

    def reporter(stage, done, total):
        with lock:
            bar = bars.get(stage)
            if bar is None:
                for old in bars.values():
                    old.close()
                bars.clear()
                wait = max(0.0, PROGRESS_DELAY - (time.monotonic() - t0))
                bar = bars[stage] = tqdm(total=total, unit="cell", desc=stage, file=stream,
                                         delay=wait, leave=False, dynamic_ncols=True)
            bar.update(done - bar.n)

    try:
        with _progress.reporting(reporter):
            yield
    finally:
        for bar in bars.values():
            bar.close()


def _check_render_outputs(args) -> None:
    """Before rendering: -o must be a writable .exr file, --preview a writable .png file."""
    from ._validate import check_output_file  # noqa: PLC0415

    check_output_file(args.output, suffixes=(".exr",), name="-o/--output",
                      hint=" (render writes OpenEXR; for a PNG add --preview sky.png)")
    if args.preview:
        check_output_file(args.preview, suffixes=(".png",), name="--preview")


def _cmd_batch(args, out) -> int:
    from .batch import BatchInterrupted, load_batch, run_batch  # noqa: PLC0415
    from .scene import _parse_assignments  # noqa: PLC0415

    overrides = _parse_assignments(args.set)
    weather, rejected = None, ()
    if args.weather:
        if args.scenes:
            raise ValueError(f"batch takes SCENES or --weather, not both (got {args.scenes!r} "
                             f"and --weather {args.weather!r})")
        from .batch.weather import weather_batch, write_weather_table  # noqa: PLC0415

        weather = weather_batch(args.weather, hours=args.hours, every=args.every,
                                overrides=overrides)
        for r in weather.rejected:
            print(f"atmoscatter: bad value: {r.error}", file=sys.stderr)
        items, rejected = weather.items, weather.rejected
        if not items and not rejected:
            raise ValueError(f"{args.weather}: no daylit hour in the selection "
                             f"({weather.night} night hours)")
        from ._validate import check_writable_dir  # noqa: PLC0415

        out_dir = check_writable_dir(args.output, name="output directory")
        write_weather_table(weather, os.path.join(out_dir, "weather_hours.csv"))
    else:
        if not args.scenes:
            raise ValueError("batch needs SCENES (a CSV or TOML batch file) or --weather FILE.epw")
        if args.hours or args.every != 1:
            raise ValueError("--hours and --every select hours of a --weather file")
        items = load_batch(args.scenes, overrides=overrides)
    client = None
    cluster = None
    if args.dask:
        try:
            from dask.distributed import Client, LocalCluster  # noqa: PLC0415
        except ImportError as exc:
            raise ImportError("--dask needs the optional extra: pip install 'atmoscatter[dask]'") from exc
        cluster = LocalCluster(n_workers=args.workers, threads_per_worker=1)
        client = Client(cluster)
    try:
        summary = run_batch(items, args.output, workers=args.workers, client=client,
                            scheduler=args.scheduler, resume=not args.no_resume,
                            progress=not args.quiet, rejected=rejected)
    except BatchInterrupted as exc:
        global _INTERRUPTED_BATCH
        _INTERRUPTED_BATCH = True
        print(exc.summary.text(), file=out)
        if weather is not None:
            print(weather.text(), file=out)
        return 143 if exc.signal_name == "SIGTERM" else 130
    finally:
        if client is not None:
            client.close()
            cluster.close()
    print(summary.text(), file=out)
    if weather is not None:
        print(weather.text(), file=out)
    return 0 if summary.ok else 1


def _fmt_header_value(v):
    if isinstance(v, tuple) and len(v) == 2 and hasattr(v[0], "tolist"):
        return f"{v[0].tolist()} - {v[1].tolist()}"
    if hasattr(v, "name") and hasattr(v, "value"):  # OpenEXR enums
        return str(v.name)
    if isinstance(v, tuple) and all(isinstance(x, float) for x in v):
        return "(" + ", ".join(f"{x:.6g}" for x in v) + ")"
    return str(v)


def _cmd_info(args, out) -> int:
    from .exr import read_exr  # noqa: PLC0415
    from .scene import Scene  # noqa: PLC0415

    img = read_exr(args.file)
    hdr = img.header
    if args.json:
        print(json.dumps({k: (v if isinstance(v, str) else _fmt_header_value(v))
                          for k, v in sorted(hdr.items())}, indent=1), file=out)
        return 0
    print(f"{args.file}", file=out)
    print("channels:", file=out)
    for name, arr in sorted(img.channels.items()):
        print(f"  {name:<24} {arr.dtype}  {'x'.join(map(str, arr.shape))}", file=out)
    fields = set(Scene.field_names())
    print("scene:", file=out)
    for k in Scene.field_names():
        if k in hdr:
            print(f"  {k:<18} = {hdr[k]}", file=out)
    print("header:", file=out)
    for k, v in sorted(hdr.items()):
        if k in fields or k in ("atmoscatter:plan", "channels"):
            continue
        print(f"  {k:<28} {_fmt_header_value(v)}", file=out)
    if img.plan is not None:
        print("plan:", file=out)
        try:
            from .render.plan import Plan  # noqa: PLC0415

            d = dict(img.plan)
            d.update(layers=tuple(d["layers"]), wavelengths=tuple(d["wavelengths"]),
                     notes=tuple(d["notes"]), atmosphere=None)
            text = Plan(**d).explain()
        except (TypeError, KeyError):  # a plan written by another version
            text = "\n".join(f"{k:<20} {v}" for k, v in sorted(img.plan.items()))
        for line in text.splitlines():
            print(f"  {line}", file=out)
    return 0


def _cmd_preview(args, out) -> int:
    from ._validate import check_output_file  # noqa: PLC0415
    from .preview import write_preview  # noqa: PLC0415

    check_output_file(args.output, suffixes=(".png",), name="-o/--output",
                      hint=" (preview writes PNG)")
    write_preview(args.file, args.output, exposure=args.exposure, tone=args.tone,
                  alpha=args.alpha, transparency=args.transparency)
    print(f"wrote {args.output}", file=out)
    return 0


def _cmd_models(args, out) -> int:
    from .render.models import MODELS  # noqa: PLC0415

    for name, a in sorted(MODELS.items()):
        print(f"{name:<20} {a.description}", file=out)
    return 0


def _fmt_bytes(n: float) -> str:
    for unit in ("B", "KiB", "MiB", "GiB"):
        if n < 1024 or unit == "GiB":
            return f"{n:.0f} {unit}" if unit == "B" else f"{n:.1f} {unit}"
        n /= 1024
    return f"{n:.1f} GiB"  # pragma: no cover


def _fmt_age(seconds: float) -> str:
    seconds = max(seconds, 0.0)
    for limit, div, unit in ((120, 1, "s"), (7200, 60, "min"), (172800, 3600, "h")):
        if seconds < limit:
            return f"{seconds / div:.0f} {unit}"
    return f"{seconds / 86400:.0f} d"


def _fmt_meta(meta) -> str:
    if meta is None:
        return "(unreadable header)"
    parts = []
    for k, v in meta.items():
        if isinstance(v, list):
            v = ",".join(f"{x:g}" if isinstance(x, float) else str(x) for x in v)
        parts.append(f"{k}={v}")
    text = " ".join(parts)
    return text if len(text) <= 70 else text[:69] + "…"


def _cmd_cache(args, out) -> int:
    from . import cache  # noqa: PLC0415

    root = cache.cache_dir()
    if root is None:
        print(f"atmoscatter: the cache is off ({cache.ENV_DIR}=off)", file=sys.stderr)
        return 1 if args.cache_command == "dir" else 0
    if args.cache_command == "dir":
        print(root, file=out)
        return 0
    if args.cache_command == "clear":
        n = len(cache.entries(args.kind))
        freed = cache.clear(args.kind)
        what = f" of kind {args.kind!r}" if args.kind else ""
        noun = "entry" if n == 1 else "entries"
        print(f"removed {n} {noun}{what} ({_fmt_bytes(freed)}) from {root}", file=out)
        return 0
    items = cache.entries(args.kind)
    if args.json:
        print(json.dumps([{"kind": e.kind, "key": e.key, "size": e.size, "mtime": e.mtime,
                           "last_used": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime(e.mtime)),
                           "meta": e.meta, "path": e.path} for e in items], indent=1), file=out)
        return 0
    now = time.time()
    if items:
        w = max(4, *(len(e.kind) for e in items))
        print(f"{'kind':<{w}}  {'key':<12}  {'size':>10}  {'age':>6}  meta", file=out)
        for e in items:
            print(f"{e.kind:<{w}}  {e.key[:12]:<12}  {_fmt_bytes(e.size):>10}  "
                  f"{_fmt_age(now - e.mtime):>6}  {_fmt_meta(e.meta)}", file=out)
    total = sum(e.size for e in items)
    noun = "entry" if len(items) == 1 else "entries"
    print(f"{len(items)} {noun}, {_fmt_bytes(total)} in {root} "
          f"(cap {_fmt_bytes(cache.max_bytes())}; age = since last use)", file=out)
    return 0


def _show_warning(message, category, filename, lineno, file=None, line=None):
    """Warnings as one line: ``atmoscatter: warning: ...``."""
    text = " ".join(str(message).split())
    print(f"atmoscatter: warning: {text}", file=sys.stderr if file is None else file)


def _silence_stdout() -> None:
    """The reader of stdout went away: point stdout at /dev/null so the interpreter's
    final flush does not print a second BrokenPipeError."""
    import os  # noqa: PLC0415

    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
        os.close(devnull)
    except (OSError, ValueError, AttributeError):  # pragma: no cover - no real stdout
        pass


#: set when a batch was stopped by a signal (see :func:`run`)
_INTERRUPTED_BATCH = False


def run(argv=None) -> None:
    """The ``atmoscatter`` console script (and ``python -m atmoscatter``): :func:`main`,
    then exit with its status.

    After a batch stopped by Ctrl-C or SIGTERM the process leaves with ``os._exit`` once
    the summary is printed and flushed: its worker pool has been killed, and the
    interpreter's exit hooks (``concurrent.futures`` waking its dead pool's management
    thread through a pipe that thread is closing) would otherwise print a traceback at
    random; every output file is already complete or removed by then.
    """
    code = main(argv)
    if _INTERRUPTED_BATCH:
        for stream in (sys.stdout, sys.stderr):
            with contextlib.suppress(Exception):
                stream.flush()
        os._exit(code)
    sys.exit(code)


def main(argv=None) -> int:
    """The ``atmoscatter`` command in-process; returns the exit status (:func:`run` is the
    console script)."""
    parser = _parser()
    args = parser.parse_args(argv)
    debug = bool(getattr(args, "debug", False))
    if not args.command:
        parser.print_help()
        return 2
    # colour-science announces at import that its optional plotting needs matplotlib; that
    # is noise for a command-line user (the package does not plot)
    warnings.filterwarnings("ignore", message='"Matplotlib" related API features')
    commands = {"render": _cmd_render, "batch": _cmd_batch, "info": _cmd_info,
                "preview": _cmd_preview, "models": _cmd_models, "compare": run_compare,
                "cache": _cmd_cache}
    try:
        with warnings.catch_warnings():
            warnings.showwarning = _show_warning
            return commands[args.command](args, sys.stdout)
    except BrokenPipeError:  # e.g. `atmoscatter info --json f.exr | head`
        _silence_stdout()
        return 141
    except KeyboardInterrupt:
        print("atmoscatter: interrupted", file=sys.stderr)
        return 130
    except Exception as exc:
        if debug:
            raise
        msg = " ".join(str(exc).split()) or type(exc).__name__
        print(f"atmoscatter: error: {msg}", file=sys.stderr)
        return 2


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())

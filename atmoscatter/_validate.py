"""Input checking shared by every public function.

Each check raises :class:`ValueError` (or :class:`TypeError`) whose message names
the parameter, the offending value and the valid range, as the project's
conventions require.
"""

from __future__ import annotations

from collections.abc import Iterable

import numpy as np

__all__ = [
    "as_float_array",
    "check_finite",
    "check_positive",
    "check_range",
    "check_option",
    "clamp_cosine",
    "safe_sqrt",
]


def _describe(value) -> str:
    arr = np.asarray(value)
    if arr.ndim == 0:
        return repr(arr.item())
    return f"array of shape {arr.shape}"


def _first_bad(arr: np.ndarray, bad: np.ndarray) -> str:
    if arr.ndim == 0:
        return repr(arr.item())
    idx = np.argwhere(bad)[0]
    return f"{arr[tuple(idx)].item()!r} (at index {tuple(int(i) for i in idx)})"


def as_float_array(value, name: str, *, dtype=None) -> np.ndarray:
    """Convert array-like ``value`` to a floating array.

    float32 input stays float32 (precision follows the input); integers,
    booleans and Python floats become float64.  Non-numeric input raises
    :class:`TypeError` naming ``name``.
    """
    try:
        arr = np.asarray(value)
    except Exception as exc:  # pragma: no cover - exotic inputs
        raise TypeError(f"{name} must be array-like of numbers, got {type(value).__name__}") from exc
    if dtype is not None:
        return arr.astype(dtype, copy=False)
    if arr.dtype.kind == "f":
        return arr
    if arr.dtype.kind in "iub":
        return arr.astype(np.float64)
    if arr.dtype.kind == "O":
        try:
            return arr.astype(np.float64)
        except (TypeError, ValueError) as exc:
            raise TypeError(f"{name} must be array-like of numbers, got {_describe(value)}") from exc
    raise TypeError(f"{name} must be array-like of real numbers, got dtype {arr.dtype}")


def check_finite(value, name: str) -> np.ndarray:
    """Raise ``ValueError`` if any element of ``value`` is NaN or infinite."""
    arr = as_float_array(value, name)
    bad = ~np.isfinite(arr)
    if np.any(bad):
        raise ValueError(f"{name} must be finite, got {_first_bad(arr, bad)}")
    return arr


def check_positive(value, name: str, *, allow_zero: bool = False, unit: str = "") -> np.ndarray:
    """Raise ``ValueError`` unless every element is finite and > 0 (or >= 0)."""
    arr = check_finite(value, name)
    bad = arr < 0 if allow_zero else arr <= 0
    if np.any(bad):
        rng = "[0, inf)" if allow_zero else "(0, inf)"
        u = f" {unit}" if unit else ""
        raise ValueError(f"{name} must be in {rng}{u}, got {_first_bad(arr, bad)}")
    return arr


def check_range(
    value,
    name: str,
    low: float,
    high: float,
    *,
    low_inclusive: bool = True,
    high_inclusive: bool = True,
    unit: str = "",
) -> np.ndarray:
    """Raise ``ValueError`` unless every element lies in the given interval."""
    arr = check_finite(value, name)
    bad = (arr < low) if low_inclusive else (arr <= low)
    bad = bad | ((arr > high) if high_inclusive else (arr >= high))
    if np.any(bad):
        lb = "[" if low_inclusive else "("
        hb = "]" if high_inclusive else ")"
        u = f" {unit}" if unit else ""
        raise ValueError(f"{name} must be in {lb}{low}, {high}{hb}{u}, got {_first_bad(arr, bad)}")
    return arr


def check_option(value: str, name: str, options: Iterable[str]) -> str:
    """Raise ``ValueError`` listing the valid choices if ``value`` is not one of them."""
    opts = list(options)
    if value not in opts:
        raise ValueError(f"{name}={value!r} is not valid; choose one of {sorted(opts)}")
    return value


def clamp_cosine(mu):
    """Clamp a cosine into [-1, 1].

    Cosines computed from dot products of unit vectors can leave [-1, 1] by a
    few ulp; ``arccos`` or ``sqrt(1 - mu**2)`` would then give NaN.
    """
    return np.clip(mu, -1.0, 1.0)


def safe_sqrt(x):
    """Square root of ``max(x, 0)``: guards rounding just below zero."""
    return np.sqrt(np.maximum(x, 0.0))


# ----------------------------------------------------------------------------
# sizes, counts and output paths (scenes, the CLI, batches)
# ----------------------------------------------------------------------------
#: Largest estimated size [bytes] of a render's output arrays (float32 layers) that a
#: scene may ask for: 4 GiB, e.g. a 16384 × 8192 RGB lat-long map (2 GiB) passes, a
#: 65536 × 32768 one (32 GiB) is refused before anything is allocated.  The environment
#: variable ``ATMOSCATTER_MAX_OUTPUT_GIB`` raises or lowers the limit.
MAX_OUTPUT_BYTES = 4 * 1024**3
ENV_MAX_OUTPUT = "ATMOSCATTER_MAX_OUTPUT_GIB"


def max_output_bytes() -> int:
    """The output-size limit [bytes]: :data:`MAX_OUTPUT_BYTES` or ``$ATMOSCATTER_MAX_OUTPUT_GIB``."""
    import math  # noqa: PLC0415
    import os  # noqa: PLC0415

    text = os.environ.get(ENV_MAX_OUTPUT, "").strip()
    if not text:
        return MAX_OUTPUT_BYTES
    try:
        gib = float(text)
    except ValueError:
        gib = math.nan
    if not (math.isfinite(gib) and gib > 0):
        raise ValueError(f"{ENV_MAX_OUTPUT} must be a number of GiB in (0, inf), got {text!r}")
    return int(gib * 1024**3)


def scene_directions(projection: str, width: int, height: int) -> int:
    """Number of directions a scene evaluates (a dome: an upper bound before refinement)."""
    if projection == "cubemap":
        return 6 * width * width
    if projection == "dome":
        return 2 * width * (height + 1)
    return width * height


def check_image_size(projection: str, width: int, height: int, floats_per_direction: int) -> int:
    """Raise ``ValueError`` if the estimated output arrays exceed :func:`max_output_bytes`.

    ``floats_per_direction`` is the number of float32 values stored per direction (e.g. 4
    for RGB + alpha).  Returns the estimate [bytes].
    """
    n = scene_directions(projection, width, height)
    est = 4 * n * max(int(floats_per_direction), 1)
    limit = max_output_bytes()
    if est > limit:
        size = f"{width}" if projection == "cubemap" else f"{width}x{height}"
        raise ValueError(
            f"width/height {size} ({projection}) means {n} directions and about "
            f"{est / 1024**3:.1f} GiB of output arrays; the limit is {limit / 1024**3:.3g} GiB, "
            f"i.e. at most {limit // (4 * max(int(floats_per_direction), 1))} directions for "
            f"this output (set {ENV_MAX_OUTPUT} to change it) — ask for a smaller image"
        )
    return est


def check_count(value, name: str, *, low: int = 1) -> int:
    """An integer ``>= low`` (counts such as ``workers``), else ``ValueError``/``TypeError``."""
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
        raise TypeError(f"{name} must be an integer in [{low}, inf), got {value!r}")
    if value < low:
        raise ValueError(f"{name} must be an integer in [{low}, inf), got {value!r}")
    return int(value)


def check_output_file(path, *, suffixes=(".exr",), name: str = "output", hint: str = "") -> str:
    """Check before any work that ``path`` can be written as a file of one of ``suffixes``.

    Raises ``ValueError`` naming ``path`` when the extension is wrong (``hint`` is
    appended to that message), ``path`` is a directory, or its directory cannot be
    created or written.  Nothing is created.  Returns ``path`` as a string.
    """
    import os  # noqa: PLC0415

    path = os.fspath(path)
    if suffixes and not path.lower().endswith(tuple(s.lower() for s in suffixes)):
        raise ValueError(f"{name} {path!r} must end in {' or '.join(suffixes)}{hint}")
    if os.path.isdir(path):
        raise ValueError(f"{name} {path!r} is a directory; give a file name")
    check_writable_dir(os.path.dirname(os.path.abspath(path)), name=name, target=path,
                       create=False)
    return path


def check_writable_dir(directory, *, name: str = "output directory", target=None,
                       create: bool = True) -> str:
    """Check that files can be written in ``directory`` (``ValueError`` naming it).

    With ``create`` the directory is made if missing; without, the nearest existing
    ancestor must be a writable directory (nothing is left behind: the probe file
    created to test writing is removed at once).
    """
    import os  # noqa: PLC0415
    import tempfile  # noqa: PLC0415

    directory = os.fspath(directory)
    what = f"{name} {os.fspath(target if target is not None else directory)!r}"
    probe_dir = directory
    try:
        if create:
            os.makedirs(directory, exist_ok=True)
        else:
            while not os.path.exists(probe_dir):
                parent = os.path.dirname(probe_dir)
                if parent == probe_dir:
                    break
                probe_dir = parent
            if not os.path.isdir(probe_dir):
                raise NotADirectoryError(20, f"{probe_dir!r} is not a directory")
        fd, probe = tempfile.mkstemp(prefix=".atmoscatter-write-test.", dir=probe_dir)
        os.close(fd)
        os.remove(probe)
    except OSError as exc:
        raise ValueError(f"cannot write {what}: {exc.strerror or exc}") from None
    return directory

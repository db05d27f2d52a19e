"""Reading batches: CSV tables (one scene per row), TOML files (``[base]`` fields,
``[[scene]]`` entries, a ``[sweep]``) and the Cartesian sweep of parameter lists and ranges."""

from __future__ import annotations

import csv
import datetime as _dt
import itertools
import os
import re

import numpy as np

__all__ = ["load_batch", "expand_sweep"]

_NAME_RE = re.compile(r"^[A-Za-z0-9._+-]+$")

_STEP_RE = re.compile(r"^\s*([0-9.]+)\s*(s|sec|min|m|h|d)\s*$")
_UNITS = {"s": 1, "sec": 1, "min": 60, "m": 60, "h": 3600, "d": 86400}


def _range_values(key, spec):
    if not isinstance(spec, dict) or not {"start", "stop", "step"} <= set(spec):
        raise ValueError(f"sweep {key}: a range needs start, stop and step, got {spec!r}")
    start, stop, step = spec["start"], spec["stop"], spec["step"]
    if key == "time" or isinstance(start, (str, _dt.datetime)):
        from ..scene import parse_time  # noqa: PLC0415

        t0, t1 = parse_time(start), parse_time(stop)
        m = _STEP_RE.match(str(step))
        if not m:
            raise ValueError(f"sweep {key}: step must look like '1h', '30min', '1d', got {step!r}")
        dt = _dt.timedelta(seconds=float(m.group(1)) * _UNITS[m.group(2)])
        if dt.total_seconds() <= 0:
            raise ValueError(f"sweep {key}: step must be positive, got {step!r}")
        out, t = [], t0
        while t <= t1:
            out.append(t.strftime("%Y-%m-%dT%H:%M:%SZ"))
            t += dt
        return out
    start, stop, step = float(start), float(stop), float(step)
    if step <= 0:
        raise ValueError(f"sweep {key}: step must be positive, got {step!r}")
    n = int(np.floor((stop - start) / step + 1e-9)) + 1
    return [start + i * step for i in range(max(n, 0))]


def expand_sweep(sweep: dict) -> list[dict]:
    """Cartesian product of a sweep table.

    Each key is a scene field whose value is a list of values or a range
    ``{start, stop, step}`` (numbers, or ISO times with a step such as
    ``"1h"``; ``stop`` included).  The optional key ``name`` is a
    :meth:`str.format` template over the fields and ``index`` (default
    ``"sky_{index:05d}"``).

    Parameters
    ----------
    sweep : dict
        The ``[sweep]`` table: scene fields mapped to lists or ``{start, stop, step}`` ranges,
        plus the optional ``name`` template.

    Returns
    -------
    list of dict
        One mapping of scene fields per combination, each with its ``name``.
    """
    sweep = dict(sweep)
    template = sweep.pop("name", "sky_{index:05d}")
    keys, values = [], []
    for k, v in sweep.items():
        keys.append(k)
        values.append(list(v) if isinstance(v, (list, tuple)) else _range_values(k, v))
    rows = []
    for i, combo in enumerate(itertools.product(*values)):
        row = dict(zip(keys, combo, strict=True))
        fmt = {k: _safe(v) for k, v in row.items()}
        try:
            name = template.format(index=i, **fmt)
        except (KeyError, IndexError, ValueError) as exc:
            raise ValueError(f"sweep name template {template!r} cannot be filled: {exc}") from None
        row["name"] = name
        rows.append(row)
    return rows


def _safe(v):
    if isinstance(v, str):
        return re.sub(r"[^A-Za-z0-9.+-]", "", v.replace(":", ""))
    return v


def _read_csv(path) -> tuple[list, list]:
    """(header, rows) of a batch CSV; every malformed line is an error naming it.

    UTF-8 with or without a byte-order mark (as Excel writes it).  Every row must have as
    many cells as the header (a line of empty cells is skipped); column names must be unique.
    """
    try:
        with open(path, newline="", encoding="utf-8-sig") as fh:
            lines = list(csv.reader(fh))
    except UnicodeDecodeError as exc:
        raise ValueError(f"{path}: not UTF-8 text ({exc.reason} at byte {exc.start}); save the "
                         "table as CSV UTF-8") from None
    except csv.Error as exc:
        raise ValueError(f"{path}: not a valid CSV file ({exc})") from None
    if not lines or not any(c.strip() for c in lines[0]):
        raise ValueError(f"{path}: empty CSV (expected a header of scene fields)")
    cols = [c.strip() for c in lines[0]]
    for j, c in enumerate(cols):
        if not c:
            raise ValueError(f"{path}: line 1 (header): column {j + 1} has no name")
        if c in cols[:j]:
            raise ValueError(f"{path}: line 1 (header): duplicate column {c!r} "
                             f"(columns {cols.index(c) + 1} and {j + 1})")
    rows = []
    for lineno, cells in enumerate(lines[1:], start=2):
        if not any(c.strip() for c in cells):
            continue  # blank line
        if len(cells) != len(cols):
            what = "more" if len(cells) > len(cols) else "fewer"
            raise ValueError(f"{path}: line {lineno} has {len(cells)} cells, {what} than the "
                             f"{len(cols)} columns of the header")
        row = {k: v.strip() for k, v in zip(cols, cells, strict=True)}
        if not row.get("name"):
            row["name"] = f"scene_{len(rows):05d}"
        rows.append(row)
    return cols, rows


def load_batch(path, *, overrides: dict | None = None) -> list[tuple[str, dict]]:
    """Read a batch file into ``[(name, fields), ...]`` (fields not yet validated).

    CSV: one scene per row; the header names scene fields and a ``name``
    column (file stem; default ``scene_<row>``).  Empty cells keep the
    default.  TOML: ``[base]`` (shared fields), ``[[scene]]`` (one table per
    scene, with ``name``) and/or ``[sweep]`` (see :func:`expand_sweep`).
    ``overrides`` (e.g. the CLI's ``--set``) apply to every scene.

    Unknown or duplicate columns, rows with more or fewer cells than the header,
    non-UTF-8 text and duplicate names raise :class:`ValueError` naming the file
    (and the line); bad *values* are reported per scene when the batch runs.

    Parameters
    ----------
    path : str or path-like
        A ``.csv`` or ``.toml`` batch file.
    overrides : dict, optional
        Scene fields set in every scene (after the file's values).

    Returns
    -------
    list of (str, dict)
        ``(name, fields)`` per scene, in file order; ``fields`` are raw scene-field values
        (validated by :class:`Scene` when the scene is rendered).
    """
    from ..scene import Scene  # noqa: PLC0415

    path = os.fspath(path)
    if not os.path.exists(path):
        raise ValueError(f"batch file {path!r} does not exist")
    ext = os.path.splitext(path)[1].lower()
    rows: list[dict] = []
    base: dict = {}
    if ext == ".csv":
        cols, rows = _read_csv(path)
    elif ext == ".toml":
        from ..scene import _load_toml  # noqa: PLC0415

        data = _load_toml(path)
        base = dict(data.get("base", {}))
        for entry in data.get("scene", []):
            rows.append(dict(entry))
        if "sweep" in data:
            rows.extend(expand_sweep(data["sweep"]))
        for i, r in enumerate(rows):
            r.setdefault("name", f"scene_{i:05d}")
        cols = sorted({k for r in rows for k in r} | set(base))
    else:
        raise ValueError(f"batch file {path!r}: expected a .csv or .toml file")
    valid = set(Scene.field_names())
    unknown = [c for c in cols if c != "name" and c not in valid]
    if unknown:
        raise ValueError(
            f"{path}: unknown scene field {unknown[0]!r}; valid fields are name, "
            + ", ".join(Scene.field_names())
        )
    out, seen = [], set()
    for r in rows:
        name = str(r.pop("name"))
        if not _NAME_RE.match(name):
            raise ValueError(f"{path}: name {name!r} is not a valid file stem (letters, digits, . _ + -)")
        if name in seen:
            raise ValueError(f"{path}: duplicate name {name!r}")
        seen.add(name)
        fields = {**base, **r, **(overrides or {})}
        fields["name"] = name
        out.append((name, fields))
    if not out:
        raise ValueError(f"{path}: no scenes")
    return out



"""Progress of long precomputations, for a front end to display (private).

A computation that may take seconds (the multiple-scattering field: one pass over the
grid cells per scattering order) calls :func:`report` as it goes; nothing happens unless
a front end (the CLI's progress bar) has installed a reporter with :func:`reporting`.
The reporter is process-wide, not per thread or context, because the work runs on
thread pools that do not inherit the caller's context; it is called from those threads
and must be thread-safe.  A reporter that raises is ignored: a display never breaks a
computation.
"""

from __future__ import annotations

import contextlib
import threading
from collections.abc import Callable, Iterator

__all__: list[str] = []

Reporter = Callable[[str, int, int], None]  # (stage, done, total)

_LOCK = threading.Lock()
_REPORTER: Reporter | None = None


@contextlib.contextmanager
def reporting(reporter: Reporter | None) -> Iterator[None]:
    """Install ``reporter(stage, done, total)`` for the duration of the block."""
    global _REPORTER
    with _LOCK:
        previous, _REPORTER = _REPORTER, reporter
    try:
        yield
    finally:
        with _LOCK:
            _REPORTER = previous


def active() -> bool:
    """Whether a reporter is installed (callers may skip bookkeeping otherwise)."""
    return _REPORTER is not None


def report(stage: str, done: int, total: int) -> None:
    """Tell the installed reporter that ``done`` of ``total`` units of ``stage`` are done."""
    reporter = _REPORTER
    if reporter is None:
        return
    try:
        reporter(stage, int(done), int(total))
    except Exception:  # noqa: BLE001 - a progress display must not break the computation
        pass

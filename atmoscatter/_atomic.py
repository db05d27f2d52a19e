"""Atomic file writes (private base module): a file is replaced only by a complete one.

:func:`atomic_write` is public as :func:`atmoscatter.atomic_write` (re-exported by
:mod:`atmoscatter.exr`); it lives here, in the base layer, so that the on-disk cache of the
physics layer (:mod:`atmoscatter.cache`) uses it without importing the EXR module, a layer
above it.
"""

from __future__ import annotations

import contextlib
import os
import tempfile

__all__: list[str] = []


def _current_umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


_UMASK = _current_umask()


@contextlib.contextmanager
def atomic_write(path):
    """Yield a temporary path next to ``path``; move it onto ``path`` only on success.

    The temporary file lives in the target's directory (so ``os.replace`` is an
    atomic rename on POSIX and Windows) and is removed if anything fails: an
    interrupted write never leaves a truncated file under the final name, and
    an existing file is only ever replaced by a complete one.

    Parameters
    ----------
    path : str or path-like
        The final file name.  Missing parent directories are created.

    Yields
    ------
    str
        Path of an empty temporary file ``.<name>.<random>.tmp`` in the target's directory,
        for the block to write to.  When the block ends without an exception it is given
        the usual permissions (``0o666`` minus the umask) and moved onto ``path``; on any
        exception (including ``KeyboardInterrupt``) it is removed, ``path`` is left as it
        was and the exception propagates.

    Raises
    ------
    OSError
        If the directory or the temporary file cannot be created; the message names
        ``path``, not the temporary file.
    """
    path = os.fspath(path)
    directory = os.path.dirname(os.path.abspath(path))
    base = os.path.basename(path)
    try:
        os.makedirs(directory, exist_ok=True)
        fd, tmp = tempfile.mkstemp(prefix=f".{base}.", suffix=".tmp", dir=directory)
    except OSError as exc:  # name the file asked for, not the temporary one
        raise OSError(exc.errno, f"cannot write {path!r}: {exc.strerror or exc}") from None
    os.close(fd)
    try:
        yield tmp
        os.chmod(tmp, 0o666 & ~_UMASK)  # mkstemp creates 0600; give the usual permissions
        os.replace(tmp, path)
    except BaseException:
        with contextlib.suppress(FileNotFoundError):
            os.remove(tmp)
        raise

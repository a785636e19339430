"""Atomic file writing: outputs go to a temporary name, then are moved into place."""
from __future__ import annotations

import contextlib
import os
import tempfile

__all__ = ["atomic_path", "atomic_write_text", "atomic_write_bytes"]


@contextlib.contextmanager
def atomic_path(path: str | os.PathLike, suffix: str = ""):
    """Yield a temporary path beside ``path``; on success move it to ``path``.

    On any exception (``BaseException``: also Ctrl-C, and SIGTERM once the CLI turns it into
    ``KeyboardInterrupt``) the temporary file is removed and ``path`` is left as it was.
    ``suffix`` keeps an extension on the temporary name for libraries that dispatch on it.
    Files a library made beside the temporary under its name (``<tmp>.<n>.tmp``, ``<tmp>~``,
    as ifcopenshell does) are removed too, on failure and on success.
    """
    path = os.fsdecode(os.fspath(path))
    d = os.path.dirname(os.path.abspath(path))
    os.makedirs(d, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix="." + os.path.basename(path) + ".", suffix=suffix + ".part", dir=d)
    os.close(fd)
    try:
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(tmp, 0o666 & ~umask)  # mkstemp makes 0600; outputs get the usual permissions
        yield tmp
        os.replace(tmp, path)
    except BaseException:
        _remove_temporaries(tmp)
        raise
    _remove_temporaries(tmp)


def _remove_temporaries(tmp: str) -> None:
    """Remove ``tmp`` and every file in its folder whose name starts with its name.

    The name of ``tmp`` holds a random part from :func:`tempfile.mkstemp`, so the files
    starting with it are ours or were made from it by a library. Errors are ignored (the
    folder may be gone or read-only): on failure this runs while another error is raised.
    """
    d, base = os.path.split(tmp)
    with contextlib.suppress(OSError):
        os.remove(tmp)
    try:
        with os.scandir(d) as it:
            stray = [e.path for e in it if e.name.startswith(base) and not e.is_dir(follow_symlinks=False)]
    except OSError:
        return
    for p in stray:
        with contextlib.suppress(OSError):
            os.remove(p)


def atomic_write_bytes(path: str | os.PathLike, data: bytes) -> None:
    """Write ``data`` to ``path`` through a temporary file (:func:`atomic_path`): all or nothing."""
    with atomic_path(path) as tmp:
        with open(tmp, "wb") as f:
            f.write(data)


def atomic_write_text(path: str | os.PathLike, text: str) -> None:
    """:func:`atomic_write_bytes` of ``text`` encoded as UTF-8."""
    atomic_write_bytes(path, text.encode("utf-8"))

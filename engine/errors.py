"""Typed errors raised by the engine, and the one place that turns any exception into a
one-line message.

Every error carries a message a user can act on. Errors about a file name the file
(``path``) and the problem. Each class has a ``kind``: ``input`` (the file or the options),
``reconstruction`` (the data give no model), ``output`` (a result cannot be written),
``dependency`` (a package is missing), ``cancelled``; anything that is not an
:class:`IndoorError` is ``internal`` (a bug). The Blender side turns them into
``self.report``; the CLI prints :func:`error_line` and exits non-zero.
"""
from __future__ import annotations

import errno
import os

__all__ = [
    "IndoorError",
    "InputError",
    "FormatError",
    "EmptyCloudError",
    "ReconstructionError",
    "OutputError",
    "MissingDependencyError",
    "Cancelled",
    "error_kind",
    "error_line",
    "printable",
    "is_valid_text",
    "ERROR_KINDS",
]

ERROR_KINDS = ("input", "reconstruction", "output", "dependency", "cancelled", "internal")
"""Every value :func:`error_kind` returns."""


class IndoorError(Exception):
    """Base class of every error the engine raises on purpose.

    Parameters
    ----------
    problem : str
        What is wrong, in words a user understands.
    path : str or os.PathLike, optional
        The file concerned; it is named first in the message.
    """

    kind = "input"

    def __init__(self, problem: str = "", path: str | os.PathLike | None = None):
        self.problem = str(problem)
        self.path = None if path is None else printable(path)
        super().__init__(f"{self.path}: {self.problem}" if self.path else self.problem)


class InputError(IndoorError, ValueError):
    """Bad input: a missing, unreadable or malformed file, unusable data or a bad option."""

    kind = "input"


class FormatError(InputError):
    """The file exists but its content does not follow its format."""


class EmptyCloudError(InputError):
    """No usable points are left (empty file, all non-finite, or too few points)."""


class ReconstructionError(IndoorError):
    """The data cannot give a model (no floor or ceiling, no vertical structure, ...)."""

    kind = "reconstruction"


class OutputError(IndoorError, OSError):
    """A result cannot be written: the output folder is a file, read-only, full, ..."""

    kind = "output"


class MissingDependencyError(IndoorError, ImportError):
    """An optional package needed for this operation is not installed."""

    kind = "dependency"

    def __init__(self, package: str, purpose: str):
        self.package = package
        super().__init__(f"{purpose} needs the Python package '{package}' (pip install {package})")


class Cancelled(IndoorError):
    """The caller's ``should_stop`` callback asked the work to stop."""

    kind = "cancelled"


def printable(text) -> str:
    """A path or text as valid UTF-8: the surrogate escapes Python gives the undecodable bytes
    of a file name (``b"\\xff"`` -> ``"\\udcff"``) become backslash escapes (``"\\xff"``);
    bytes are decoded as file names; valid text is returned unchanged. Used wherever a name
    goes into a message, an IFC file or a Blender property."""
    p = os.fspath(text) if isinstance(text, (os.PathLike, bytes)) else str(text)
    if isinstance(p, bytes):
        p = os.fsdecode(p)
    if is_valid_text(p):
        return p
    try:  # surrogate escapes of undecodable bytes -> the bytes, shown as \xNN
        return p.encode("utf-8", "surrogateescape").decode("utf-8", "backslashreplace")
    except UnicodeEncodeError:  # other lone surrogates -> \udNNN
        return p.encode("utf-8", "backslashreplace").decode("utf-8")



def is_valid_text(text: str) -> bool:
    """Whether ``text`` encodes as UTF-8 (no lone surrogates)."""
    try:
        text.encode("utf-8")
        return True
    except UnicodeEncodeError:
        return False


_OUTPUT_ERRNOS = {errno.ENOSPC, errno.EDQUOT, errno.EROFS, errno.EFBIG, errno.EACCES, errno.EPERM,
                  errno.EEXIST, errno.ENOTDIR, errno.EISDIR}


def error_kind(exc: BaseException) -> str:
    """One of :data:`ERROR_KINDS` for any exception."""
    if isinstance(exc, IndoorError):
        return exc.kind
    if isinstance(exc, KeyboardInterrupt):
        return "cancelled"
    if isinstance(exc, OSError) and exc.errno in _OUTPUT_ERRNOS:
        return "output"
    return "internal"


def error_line(exc: BaseException, path: str | os.PathLike | None = None) -> str:
    """One line that names the file, the kind of error and the problem.

    ``path`` is the file the work was about; it is named first unless the message already
    names it. An internal error (not an :class:`IndoorError`) says it is a bug and gives the
    exception's type; ``--debug`` prints its traceback.
    """
    kind = error_kind(exc)
    name = None if path is None else printable(path)
    if isinstance(exc, IndoorError):
        text = exc.problem if (name and exc.path == name) else str(exc)
        where = exc.path if exc.path and exc.path != name else None
        if where and not name:
            text = exc.problem
            name = where
    elif isinstance(exc, OSError) and kind == "output":
        where = exc.filename
        text = f"{exc.strerror or exc}" + (f": {printable(where)}" if where else "")
    elif isinstance(exc, MemoryError):
        text = "out of memory"
    else:
        detail = str(exc) or exc.__class__.__name__
        text = f"{exc.__class__.__name__}: {detail} (a bug: please report it with the output of --debug)"
    text = " ".join(printable(text).split())  # one line
    head = f"{name}: " if name else ""
    return f"{head}{kind} error: {text}"

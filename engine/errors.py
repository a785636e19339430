"""Typed errors raised by the engine.

Every error carries a message a user can act on. Errors about a file name the file
(``path``) and the problem. The Blender side turns them into ``self.report``; the CLI
prints them on one line and exits non-zero.
"""
from __future__ import annotations

import os

__all__ = [
    "IndoorError",
    "InputError",
    "FormatError",
    "EmptyCloudError",
    "ReconstructionError",
    "MissingDependencyError",
    "Cancelled",
]


class IndoorError(Exception):
    """Base class of every error the engine raises on purpose."""


class InputError(IndoorError, ValueError):
    """Bad input: a missing, unreadable or malformed file, or unusable data.

    Parameters
    ----------
    problem : str
        What is wrong, in words a user understands.
    path : str or os.PathLike, optional
        The file concerned; it is named first in the message.
    """

    def __init__(self, problem: str, path: str | os.PathLike | None = None):
        self.problem = problem
        self.path = None if path is None else os.fspath(path)
        super().__init__(f"{self.path}: {problem}" if self.path else problem)


class FormatError(InputError):
    """The file exists but its content does not follow its format."""


class EmptyCloudError(InputError):
    """No usable points are left (empty file, all non-finite, or too few points)."""


class ReconstructionError(IndoorError):
    """The data cannot give a model (no floor or ceiling, no vertical structure, ...)."""


class MissingDependencyError(IndoorError, ImportError):
    """An optional package needed for this operation is not installed."""

    def __init__(self, package: str, purpose: str):
        self.package = package
        super().__init__(f"{purpose} needs the Python package '{package}' (pip install {package})")


class Cancelled(IndoorError):
    """The caller's ``should_stop`` callback asked the work to stop."""

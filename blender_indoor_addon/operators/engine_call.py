"""The operators' one boundary around engine calls: progress bar, one-line report, undo.

``with engine_call(op, context, subject) as call:`` drives the window manager's progress
bar (``call.progress`` is the engine's ``progress(fraction, message)`` callback) and, when
the block raises — an :class:`~engine.errors.IndoorError` of any kind or a bug alike — removes
every datablock the block created (objects, meshes, curves, collections, materials, node
groups, texts, images: :class:`~..bridge.DataSnapshot`), reports the error on one line
naming ``call.subject`` (:func:`engine.errors.error_line`; bugs are logged with their
traceback) and sets ``call.failed``; the operator then returns ``{'CANCELLED'}``.
"""
from __future__ import annotations

import contextlib
import logging

from ...engine.errors import error_kind, error_line
from .. import bridge

log = logging.getLogger(__name__)

__all__ = ["EngineCall", "engine_call", "report_failure"]

PROGRESS_STEPS = 1000
"""Steps of the window manager's progress bar (``progress_begin(0, PROGRESS_STEPS)``)."""


def report_failure(op, exc: BaseException, subject=None) -> set:
    """Report ``exc`` on one line (naming ``subject``, a file or an object) and return ``{'CANCELLED'}``."""
    if error_kind(exc) == "internal":
        log.error("%s", error_line(exc, subject), exc_info=exc)
    op.report({"ERROR"}, error_line(exc, subject))
    return {"CANCELLED"}


class EngineCall:
    """What the body of :func:`engine_call` uses: the progress callback, the subject, the outcome.

    Attributes
    ----------
    subject : str or None
        The file or object an error report names; the body may change it (e.g. to the file
        being read).
    failed : bool
        The body raised; the error was reported and what it created removed.
    error : Exception or None
        What the body raised.
    """

    def __init__(self, context, subject=None):
        self._wm = context.window_manager
        self.subject = subject
        self.failed = False
        self.error = None

    def progress(self, fraction: float, message: str = "") -> None:
        """The engine's ``progress(fraction in [0, 1], message)``: moves the progress bar."""
        self._wm.progress_update(int(round(PROGRESS_STEPS * min(max(float(fraction), 0.0), 1.0))))
        if message:
            log.debug("%3.0f%% %s", 100 * fraction, message)

    def part(self, index: int, count: int):
        """A ``progress`` callback for the ``index``-th of ``count`` equal parts of the work."""
        lo, hi = index / count, (index + 1) / count
        return lambda fraction, message="": self.progress(lo + fraction * (hi - lo), message)


@contextlib.contextmanager
def engine_call(op, context, subject=None, *, progress_bar: bool = True):
    """Run an operator's engine call; on any error report it, undo what it made, set ``failed``.

    Parameters
    ----------
    op : bpy.types.Operator
        Receives the ``{'ERROR'}`` report.
    context : bpy.types.Context
    subject : str, optional
        File or object named by the report (``call.subject`` may change it).
    progress_bar : bool
        Begin and end the window manager's progress bar around the block.

    Yields
    ------
    EngineCall
    """
    call = EngineCall(context, subject)
    snapshot = bridge.DataSnapshot(context.scene)
    if progress_bar:
        call._wm.progress_begin(0, PROGRESS_STEPS)
    try:
        yield call
    except BaseException as e:
        snapshot.undo()
        if not isinstance(e, Exception):  # KeyboardInterrupt, SystemExit: not the operator's to swallow
            raise
        call.failed, call.error = True, e
        report_failure(op, e, call.subject)
    finally:
        if progress_bar:
            call._wm.progress_end()

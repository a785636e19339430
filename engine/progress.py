"""Progress reporting and cancellation for long work.

Long engine functions take ``progress`` and ``should_stop`` callbacks so the Blender side
can show a progress bar and cancel, and the CLI can print a bar. ``Progress`` wraps both
and maps the fraction of a sub-step onto a range of the whole.
"""
from __future__ import annotations

from typing import Callable, Optional

from .errors import Cancelled

__all__ = ["ProgressCallback", "StopCallback", "Progress", "eta_text"]

ProgressCallback = Callable[[float, str], None]
"""``progress(fraction in [0, 1], message)``."""
StopCallback = Callable[[], bool]
"""``should_stop() -> True`` to cancel."""


class Progress:
    """Report progress of a step that is the ``[start, end]`` part of a larger job.

    Parameters
    ----------
    progress : callable or None
        ``progress(fraction, message)``; None reports nothing.
    should_stop : callable or None
        Polled by :meth:`check`; when it returns True, :class:`~engine.errors.Cancelled`
        is raised.
    start, end : float
        The share of the whole job this step covers.
    """

    def __init__(
        self,
        progress: Optional[ProgressCallback] = None,
        should_stop: Optional[StopCallback] = None,
        start: float = 0.0,
        end: float = 1.0,
    ):
        self._progress = progress
        self._should_stop = should_stop
        self.start = float(start)
        self.end = float(end)

    def __call__(self, fraction: float, message: str = "") -> None:
        self.check()
        if self._progress is not None:
            f = min(max(float(fraction), 0.0), 1.0)
            self._progress(self.start + f * (self.end - self.start), message)

    def check(self) -> None:
        """Raise :class:`Cancelled` when the caller asked to stop."""
        if self._should_stop is not None and self._should_stop():
            raise Cancelled("cancelled by the user")

    def sub(self, start: float, end: float) -> "Progress":
        """A Progress for the ``[start, end]`` share of this step."""
        span = self.end - self.start
        return Progress(
            self._progress, self._should_stop, self.start + start * span, self.start + end * span
        )

    @classmethod
    def wrap(cls, progress=None, should_stop=None) -> "Progress":
        """Accept a Progress, a bare callback or None."""
        if isinstance(progress, Progress):
            return progress
        return cls(progress, should_stop)


def eta_text(elapsed: float, fraction: float) -> str:
    """"~N s left": the elapsed time extrapolated over the fraction done, once there is enough
    of both to go on (5 % done and 2 s spent); "" before, and when done."""
    if fraction >= 1.0 or fraction < 0.05 or elapsed < 2.0:
        return ""
    left = elapsed * (1.0 - fraction) / fraction
    return f"~{left:.0f} s left" if left < 120 else f"~{left / 60:.0f} min left"

"""Engine work in a background thread, with progress and cancel, for interactive callers.

A :class:`BackgroundJob` runs ``work(progress, should_stop)`` in a daemon thread. The caller
polls :attr:`~BackgroundJob.running`, :attr:`~BackgroundJob.fraction` and
:attr:`~BackgroundJob.message` (the Blender add-on from a timer on its main thread), may
:meth:`~BackgroundJob.cancel`, and takes the result with :meth:`~BackgroundJob.outcome`,
which raises the worker's error, or :class:`~engine.errors.Cancelled`, in the caller's
thread. Nothing here touches Blender data: results are built into a scene by the caller.
"""
from __future__ import annotations

import threading
import time
from typing import Any, Callable

from .errors import Cancelled
from .progress import eta_text
from .reconstruct import reconstruct

__all__ = ["BackgroundJob", "ReconstructJob"]

Work = Callable[[Callable[[float, str], None], Callable[[], bool]], Any]
"""``work(progress, should_stop) -> result``: ``progress(fraction, message)``, ``should_stop() -> bool``."""


class BackgroundJob:
    """``work(progress, should_stop)`` in a worker thread, cancellable.

    Parameters
    ----------
    work : callable
        ``work(progress, should_stop)``; it reports with ``progress(fraction in [0, 1],
        message)`` and stops (raising :class:`~engine.errors.Cancelled`) when
        ``should_stop()`` returns True, as the engine's long functions do.
    name : str
        Name of the thread.

    Attributes
    ----------
    fraction : float
        The highest fraction reported so far, 0–1 (never goes back).
    message : str
        The last non-empty message.
    result : object
        What ``work`` returned (None until it finished).
    error : Exception or None
        What ``work`` raised, other than :class:`~engine.errors.Cancelled`.
    cancelled : bool
        ``work`` stopped with :class:`~engine.errors.Cancelled`.
    seconds : float
        Wall time of ``work``, seconds (set when it ends).
    done : bool
        ``work`` has ended (returned, raised or was cancelled).
    """

    def __init__(self, work: Work, *, name: str = "indoor-job"):
        self._work = work
        self.fraction, self.message = 0.0, ""
        self.result, self.error, self.cancelled, self.seconds = None, None, False, 0.0
        self.done = False
        self._started: float | None = None
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name=name, daemon=True)

    def _progress(self, fraction: float, message: str = "") -> None:
        self.fraction = max(self.fraction, min(max(float(fraction), 0.0), 1.0))
        if message:
            self.message = message

    def _run(self) -> None:
        t0 = self._started = time.perf_counter()
        try:
            self.result = self._work(self._progress, self._stop.is_set)
        except Cancelled:
            self.cancelled = True
        except Exception as e:  # carried to the caller's thread: a bug must not vanish with the thread
            self.error = e
        finally:
            self.seconds = time.perf_counter() - t0
            self.done = True

    def start(self) -> "BackgroundJob":
        """Start the worker thread; returns the job."""
        self._thread.start()
        return self

    def cancel(self) -> None:
        """Ask the work to stop: ``should_stop()`` returns True from now on."""
        self._stop.set()

    def join(self, timeout: float | None = None) -> bool:
        """Wait for the worker (at most ``timeout`` seconds); True when it has ended."""
        self._thread.join(timeout)
        return not self._thread.is_alive()

    @property
    def eta(self) -> str:
        """"~N s left" while it runs (the elapsed time extrapolated over the fraction done,
        :func:`engine.progress.eta_text`); "" before there is enough to go on, and when done."""
        if self._started is None or self.done:
            return ""
        return eta_text(time.perf_counter() - self._started, self.fraction)

    @property
    def running(self) -> bool:
        """The worker thread is alive."""
        return self._thread.is_alive()

    def outcome(self):
        """The result of a finished job; raises its error, or Cancelled when it was cancelled.

        Raises
        ------
        RuntimeError
            The job has not finished yet (or was never started).
        """
        if not self.done:
            raise RuntimeError("the background job has not finished")
        if self.cancelled:
            raise Cancelled("cancelled by the user")
        if self.error is not None:
            raise self.error
        return self.result


class ReconstructJob(BackgroundJob):
    """:func:`engine.reconstruct.reconstruct` of ``cloud`` in a worker thread.

    ``method``, ``seed`` and ``params`` (a :class:`~engine.params.Params`, a stage's
    parameters, or None for the defaults) are passed on as ``reconstruct``'s; the model is
    :attr:`model` once the job has finished.
    """

    def __init__(self, cloud, method: str = "auto", seed: int = 0, params=None):
        self.cloud, self.method, self.seed, self.params = cloud, method, seed, params
        super().__init__(self._reconstruct, name="indoor-reconstruct")

    def _reconstruct(self, progress, should_stop):
        return reconstruct(self.cloud, self.method, params=self.params, rng=self.seed, progress=progress,
                           should_stop=should_stop)

    @property
    def model(self):
        """The reconstructed :class:`~engine.model.BuildingModel` (None until it finished)."""
        return self.result

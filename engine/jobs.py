"""Running work over many files safely: one error boundary per file, outputs checked before
any work, unique output names, signals, and the batch record.

The CLI, ``scripts/batch.py`` and the Blender operators share these pieces:

* :func:`check_output_dir` — the output folder can be created and written, and is not a
  file; checked before any reconstruction (under a second).
* :func:`output_stems` — inputs that share a stem (``a/scan.ply``, ``b/scan.ply``) get
  distinct output names, so no model overwrites another.
* :func:`guarded` — runs one item; any exception becomes a :class:`Failure` with a one-line
  message naming the file and the kind of error (:func:`engine.errors.error_line`).
* :func:`terminate_as_interrupt` — SIGTERM (sent by ``timeout`` and job schedulers) is
  handled like Ctrl-C, so the temporary files of the file being written are removed.
* :func:`write_batch_record` — ``batch.json``: each input path against its outputs, the
  failures with their kind, written atomically.
"""
from __future__ import annotations

import contextlib
import json
import logging
import os
import signal
import stat
import tempfile
import threading
import traceback
from dataclasses import dataclass, field
from typing import Callable, Optional, Sequence

from .errors import OutputError, error_kind, error_line, printable
from .fileutil import atomic_write_text

__all__ = ["check_output_dir", "output_stems", "Failure", "guarded", "terminate_as_interrupt",
           "write_batch_record", "seed_argument", "stop_requested", "polled", "EXIT_OK", "EXIT_FAILED",
           "EXIT_USAGE", "EXIT_INTERRUPTED"]

log = logging.getLogger(__name__)

EXIT_OK = 0
"""Every file was done."""
EXIT_FAILED = 1
"""Some files (or the one file) failed; the others were done."""
EXIT_USAGE = 2
"""The command line itself is wrong (unknown option, bad value)."""
EXIT_INTERRUPTED = 130
"""Ctrl-C or SIGTERM: the files finished before it are intact, nothing half-written."""


def seed_argument(text: str) -> int:
    """``argparse`` type of ``--seed``: a whole number in ``0 .. 2**63 - 1`` (numpy's seeds)."""
    import argparse

    try:
        v = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"must be a whole number >= 0, not {text!r}") from None
    if v < 0 or v >= 2 ** 63:
        raise argparse.ArgumentTypeError(f"must be a whole number in 0 .. 2**63-1, not {text}")
    return v


def _kind(path: str) -> Optional[str]:
    """"dir", "file" (anything else) or None (nothing there, or nothing this process may
    look at: creating it then fails with the reason), from one look."""
    try:
        return "dir" if stat.S_ISDIR(os.stat(path).st_mode) else "file"
    except OSError:
        return None


def check_output_dir(out_dir: str | os.PathLike) -> str:
    """Check that ``out_dir`` is (or can become) a writable folder, before any work.

    A folder that does not exist yet is created for the check and removed again, so a run
    that writes nothing leaves nothing behind. Checks of one folder may run at once (the
    workers of a cluster batch, each before its file): a folder another check creates meanwhile
    is not this one's to remove, and one another check removes meanwhile is made again.

    Returns
    -------
    str — the folder as given.

    Raises
    ------
    OutputError
        The path is a file, a parent is a file, the folder cannot be created or is not
        writable (read-only, permission denied, read-only file system).
    """
    out = os.fspath(out_dir)
    path = os.path.abspath(out)
    for attempt in range(5):
        if _kind(path) == "file":
            raise OutputError("the output path is a file, not a folder", out)
        missing = []
        probe = path
        while (kind := _kind(probe)) is None:
            missing.append(probe)
            parent = os.path.dirname(probe)
            if parent == probe:
                break
            probe = parent
        if kind == "file":
            raise OutputError(f"cannot create the output folder: {probe} is a file", out)
        created = []
        try:
            for d in reversed(missing):
                try:
                    os.mkdir(d)
                    created.append(d)
                except FileExistsError:  # another check's (if gone again, the next step retries)
                    if _kind(d) == "file":
                        raise
            fd, tmp = tempfile.mkstemp(prefix=".indoor-write-test-", dir=path)
            os.close(fd)
            os.remove(tmp)
            return out
        except FileNotFoundError as e:  # another check removed a folder of the chain meanwhile
            if attempt == 4:
                raise OutputError(f"cannot create the output folder ({e.strerror or e})", out) from None
        except OSError as e:
            what = "cannot create the output folder" if missing and not os.path.isdir(path) \
                else "the output folder is not writable"
            raise OutputError(f"{what} ({e.strerror or e})", out) from None
        finally:
            for d in reversed(created):  # deepest first; not when another check writes in it
                with contextlib.suppress(OSError):
                    os.rmdir(d)
    return out


def output_stems(paths: Sequence[str | os.PathLike]) -> list[str]:
    """One distinct output name (file stem) per input, in order.

    The stem is the file name without its extension. Inputs whose stems clash (the same
    name in two folders, or ``scan.ply`` and ``scan.las``) get ``_2``, ``_3``, ... in the
    order given; a name that another input has as its own stem is never taken. Names are
    compared case-insensitively, since macOS and Windows folders are.
    """
    stems = [os.path.splitext(os.path.basename(os.fspath(p)))[0] or "scan" for p in paths]
    own = {s.lower() for s in stems}
    taken: set[str] = set()
    out = []
    for s in stems:
        name, k = s, 1
        while name.lower() in taken or (k > 1 and name.lower() in own):
            k += 1
            name = f"{s}_{k}"
        taken.add(name.lower())
        out.append(name)
    return out


@dataclass(frozen=True)
class Failure:
    """One file that failed: its path, the kind of error and the one-line message."""

    file: str
    kind: str
    message: str
    traceback: str = field(default="", repr=False)
    details: dict = field(default_factory=dict, repr=False, compare=False)
    """More about the attempt for ``batch.json`` (worker, seconds, peak_mb, attempts)."""

    def to_dict(self) -> dict:
        return {"file": self.file, "kind": self.kind, "error": self.message, **self.details}

    def print(self, debug: bool = False, stream=None) -> None:
        """``error: <message>`` on stderr, then the traceback when ``debug``."""
        import sys

        stream = stream or sys.stderr
        print(f"error: {self.message}", file=stream)
        if debug and self.traceback:
            print(self.traceback, file=stream, end="")


def guarded(path: str | os.PathLike, work: Callable[[], object], *, debug: bool = False,
            on_failure: Optional[Callable[[Failure], None]] = None):
    """Run ``work()`` for the file ``path``; return ``(result, None)`` or ``(None, Failure)``.

    Any :class:`Exception` becomes a :class:`Failure` (its message from
    :func:`engine.errors.error_line`); ``KeyboardInterrupt`` and ``SystemExit`` pass
    through, so the caller can stop the batch. With ``debug`` the failure keeps the
    traceback. ``on_failure`` is called with the failure (to print it at once).
    """
    try:
        return work(), None
    except Exception as e:  # the error boundary: nothing else may stop a batch
        tb = traceback.format_exc() if debug or error_kind(e) == "internal" else ""
        failure = Failure(printable(path), error_kind(e), error_line(e, path), tb)
        if error_kind(e) == "internal":
            log.debug("internal error on %s:\n%s", printable(path), tb)
        if on_failure is not None:
            on_failure(failure)
        return None, failure


_stop = threading.Event()
_polled_depth = 0


def _on_terminate(signum, frame):
    _stop.set()
    if _polled_depth == 0:  # nobody polls stop_requested(): stop here, like Ctrl-C
        raise KeyboardInterrupt(f"signal {signum}")


def stop_requested() -> bool:
    """True once SIGTERM arrived inside :func:`terminate_as_interrupt`: a ``should_stop``."""
    return _stop.is_set()


@contextlib.contextmanager
def polled():
    """Within the block the work polls :func:`stop_requested` (as its ``should_stop``), so
    SIGTERM only sets the flag and the engine raises ``Cancelled`` at its next check. An
    exception raised at an arbitrary point in native code's callers (open3d's thread pool,
    Embree) was seen to end the process with SIGSEGV."""
    global _polled_depth
    _polled_depth += 1
    try:
        yield
    finally:
        _polled_depth -= 1


@contextlib.contextmanager
def terminate_as_interrupt():
    """Within the block, SIGTERM stops the work like Ctrl-C does: it raises
    ``KeyboardInterrupt``, or inside :func:`polled` sets :func:`stop_requested`.

    Only in the main thread (signal handlers can be set nowhere else); the previous handler
    is restored afterwards.
    """
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    _stop.clear()
    old = signal.getsignal(signal.SIGTERM)
    signal.signal(signal.SIGTERM, _on_terminate)
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, old)


def write_batch_record(out_dir: str | os.PathLike, done: Sequence[dict], failed: Sequence[Failure],
                       *, interrupted: bool = False, extra: Optional[dict] = None) -> str:
    """Write ``OUT/batch.json`` atomically and return its path.

    ``done`` holds one dict per finished input with at least ``"input"`` (its path) and its
    outputs; ``failed`` the :class:`Failure` of each failed input.
    """

    path = os.path.join(os.fspath(out_dir), "batch.json")
    record = {"done": list(done), "failed": [f.to_dict() for f in failed],
              "interrupted": bool(interrupted), **(extra or {})}
    atomic_write_text(path, json.dumps(record, indent=2, ensure_ascii=True) + "\n")
    return path

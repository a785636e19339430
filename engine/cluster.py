"""Batch conversion on a Dask cluster: each scan is one task (``indoor convert --workers N`` or
``--scheduler tcp://HOST:PORT``); see docs/cluster.md.

* :func:`expand_inputs` — files, folders (every scan format inside, recursively) and lists of
  paths (``@FILE``, ``*.lst``, or a ``.txt`` whose first line names an existing file).
* :func:`convert_job` — the task: one :class:`Job` converted where it runs, with its seconds,
  peak memory (the worker process's resident set size, sampled every 20 ms during the task)
  and the worker's address; with ``data`` (``--ship``) the scan's bytes come with the task
  and the outputs go back as bytes, so the workers need no shared file system.
* :func:`connect` — a client on an existing scheduler or on a new :class:`LocalCluster`.
* :func:`run_jobs` — submits the jobs, retries a file once when its worker died, and hands
  each result to a callback as it finishes (the CLI writes ``batch.json`` there).
* :func:`manifest_ok` / :func:`write_manifest` — ``<name>.manifest.json`` beside the outputs
  (input sha256, hash of the parameters, engine version) for ``--resume``.

``dask.distributed`` is imported only here and only when a cluster is asked for: the engine
works without it (:class:`~engine.errors.MissingDependencyError` otherwise).
"""
from __future__ import annotations

import contextlib
import dataclasses
import hashlib
import json
import logging
import os
import shutil
import tempfile
import threading
import time
from dataclasses import dataclass, field
from typing import Callable, Optional, Sequence

from .errors import Cancelled, InputError, MissingDependencyError, error_kind, error_line, printable
from .fileutil import atomic_write_bytes, atomic_write_text

__all__ = ["Job", "expand_inputs", "convert_job", "connect", "run_jobs", "params_hash", "file_sha256",
           "manifest_path", "manifest_ok", "write_manifest", "LIST_SUFFIXES", "MANIFEST_SUFFIX"]

log = logging.getLogger(__name__)

LIST_SUFFIXES = (".lst", ".list")
"""A file with one of these extensions is a list of scan paths (as is ``@FILE``)."""
MANIFEST_SUFFIX = ".manifest.json"


def _distributed():
    try:
        import distributed
    except ImportError:
        raise MissingDependencyError("dask[distributed]", "--workers / --scheduler (a Dask cluster)") from None
    return distributed


# ------------------------------------------------------------------ inputs

def _scan_extensions() -> tuple:
    from .io import SUPPORTED_EXTENSIONS

    return tuple(e.lower() for e in SUPPORTED_EXTENSIONS)


def _is_path_list(path: str) -> bool:
    low = path.lower()
    if low.endswith(LIST_SUFFIXES):
        return True
    if not low.endswith(".txt"):
        return False
    try:  # a .txt is a point list unless its first line names an existing file
        with open(path, encoding="utf-8", errors="replace") as f:
            for line in f:
                line = line.strip()
                if line and not line.startswith("#"):
                    p = line if os.path.isabs(line) else os.path.join(os.path.dirname(path), line)
                    return os.path.isfile(p)
    except OSError:
        return False
    return False


def _read_list(path: str) -> list[str]:
    try:
        with open(path, encoding="utf-8") as f:
            lines = [ln.strip() for ln in f]
    except (OSError, UnicodeDecodeError) as e:
        raise InputError(f"cannot read the list of scans ({getattr(e, 'strerror', None) or e})", path) from None
    base = os.path.dirname(path)
    return [ln if os.path.isabs(ln) else os.path.join(base, ln) for ln in lines if ln and not ln.startswith("#")]


def expand_inputs(items: Sequence[str | os.PathLike]) -> list[str]:
    """The scan files named by ``items``, in order: a file is itself; a folder gives every
    scan inside it (any supported extension, recursively, sorted); ``@FILE``, a ``.lst`` /
    ``.list`` file, or a ``.txt`` whose first line names an existing file is a list of paths,
    one per line (``#`` comments; relative paths from the list's folder). A path that does
    not exist, or a folder without any scan, is kept, so its conversion reports it like any
    other bad file.

    Raises
    ------
    InputError
        A list file cannot be read.
    """
    exts = _scan_extensions()
    out: list[str] = []
    for item in items:
        p = os.fspath(item)
        if p.startswith("@") and not os.path.exists(p):
            out.extend(expand_inputs(_read_list(p[1:])))
        elif os.path.isdir(p):
            found = []
            for root, dirs, files in os.walk(p):
                dirs.sort()
                found.extend(os.path.join(root, f) for f in sorted(files) if f.lower().endswith(exts))
            out.extend(found or [p])  # no scan inside: the folder itself fails, named, and the batch goes on
        elif os.path.isfile(p) and _is_path_list(p):
            out.extend(expand_inputs(_read_list(p)))
        else:
            out.append(p)
    return out


# ------------------------------------------------------------------ resume manifests

def file_sha256(path: str | os.PathLike, chunk: int = 1 << 20) -> str:
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(chunk), b""):
            h.update(block)
    return h.hexdigest()


def params_hash(options: dict, params=None) -> str:
    """sha256 of everything besides the scan that decides the outputs: the convert options
    and the reconstruction parameters."""
    from .params import Params

    data = {"options": options, "params": Params.coerce(params).to_dict()}
    return hashlib.sha256(json.dumps(data, sort_keys=True, default=str).encode()).hexdigest()


def manifest_path(out_dir: str | os.PathLike, name: str) -> str:
    return os.path.join(os.fspath(out_dir), name + MANIFEST_SUFFIX)


def write_manifest(out_dir, name: str, input_path: str, sha256: str, phash: str, outputs: Sequence[str]) -> str:
    """``<name>.manifest.json``, written after the outputs (atomically): what made them."""
    from . import __version__

    path = manifest_path(out_dir, name)
    atomic_write_text(path, json.dumps({"input": printable(input_path), "sha256": sha256, "params": phash,
                                        "engine": __version__,
                                        "outputs": [os.path.basename(o) for o in outputs if o]}, indent=2) + "\n")
    return path


def manifest_ok(out_dir, name: str, input_path: str, phash: str) -> Optional[dict]:
    """The manifest of ``name`` when its outputs exist and were made from this very input
    (same sha256), with the same parameters and engine version; else None."""
    from . import __version__

    try:
        with open(manifest_path(out_dir, name), encoding="utf-8") as f:
            m = json.load(f)
    except (OSError, ValueError):
        return None
    if not isinstance(m, dict) or m.get("params") != phash or m.get("engine") != __version__:
        return None
    outs = m.get("outputs") or []
    if not outs or not all(os.path.isfile(os.path.join(os.fspath(out_dir), o)) for o in outs):
        return None
    try:
        if file_sha256(input_path) != m.get("sha256"):
            return None
    except OSError:
        return None
    return m


# ------------------------------------------------------------------ the task

@dataclass(frozen=True)
class Job:
    """One file to convert: ``convert_file(path, out_dir, name=name, params=params, **options)``."""

    path: str
    name: str
    out_dir: str
    options: dict = field(default_factory=dict)
    params: object = None
    timeout: Optional[float] = None

    def with_(self, **kw) -> "Job":
        return dataclasses.replace(self, **kw)


class _PeakRSS:
    """The peak resident set size of this process while the block runs, sampled every 20 ms
    (psutil, which ``distributed`` depends on; else ``ru_maxrss``, the process's all-time peak)."""

    def __init__(self, interval: float = 0.02):
        self.interval = interval
        self.peak = 0
        self._stop = threading.Event()

    def _rss(self) -> int:
        try:
            import psutil

            return psutil.Process().memory_info().rss
        except Exception:  # no psutil: the all-time peak of the process, in KiB on Linux
            import resource

            return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024

    def _run(self):
        while not self._stop.wait(self.interval):
            self.peak = max(self.peak, self._rss())

    def __enter__(self):
        self.peak = self._rss()
        self._thread = threading.Thread(target=self._run, daemon=True)
        self._thread.start()
        return self

    def __exit__(self, *exc):
        self._stop.set()
        self._thread.join()
        self.peak = max(self.peak, self._rss())


def _worker_address() -> str:
    try:
        from distributed import get_worker

        return get_worker().address
    except (ImportError, ValueError):
        return "local"


def _reroot(files: dict, old: str, new: str) -> dict:
    """Shipped outputs name the worker's temporary copy of the scan (provenance source): put
    the client's path back, in JSON and in the IFC text."""
    swaps = [(json.dumps(old)[1:-1].encode(), json.dumps(new)[1:-1].encode()), (old.encode(), new.encode())]
    out = {}
    for k, b in files.items():
        for a, c in swaps:
            b = b.replace(a, c)
        out[k] = b
    return out


_shipped: dict = {}  # worker's temporary copy -> the client's path (the model's source and name)
_shipped_lock = threading.Lock()


def _install_shipped_reader() -> None:
    """Let the engine's reader name a shipped scan by the client's path, not the worker's
    temporary copy: the model's name and source (and so its GlobalIds) are then the same
    as in place. Installed once per worker process; other paths read as before."""
    from . import reconstruct

    if getattr(reconstruct.read_point_cloud, "_indoor_shipped", False):
        return
    read = reconstruct.read_point_cloud

    def read_point_cloud(path, *a, **kw):
        cloud = read(path, *a, **kw)
        with _shipped_lock:
            orig = _shipped.get(os.fspath(path))
        return cloud if orig is None else dataclasses.replace(cloud, source=orig)

    read_point_cloud._indoor_shipped = True
    reconstruct.read_point_cloud = read_point_cloud


def convert_job(job: Job, data: Optional[bytes] = None) -> dict:
    """Convert one file where this runs (a Dask worker or the client); never raises for a bad
    file: the result has ``status`` ``"done"`` or ``"failed"`` (``kind`` and ``error``: one
    line naming the file), ``seconds``, ``peak_mb`` and ``worker``. With ``data`` the scan's
    bytes are converted in a temporary folder and the outputs returned in ``files``."""
    from . import reconstruct

    t0 = time.perf_counter()
    deadline = None if not job.timeout else time.monotonic() + float(job.timeout)

    def should_stop():
        return deadline is not None and time.monotonic() > deadline

    tmp, path = None, job.path
    res: dict = {"input": job.path, "name": job.name, "worker": _worker_address(), "pid": os.getpid()}
    try:
        with _PeakRSS() as mem:
            try:
                path, out_dir = job.path, job.out_dir
                if data is not None:
                    tmp = tempfile.mkdtemp(prefix="indoor-ship-")
                    path = os.path.join(tmp, "in", os.path.basename(job.path))
                    out_dir = os.path.join(tmp, "out")
                    os.makedirs(os.path.dirname(path))
                    with open(path, "wb") as f:
                        f.write(data)
                    _install_shipped_reader()
                    with _shipped_lock:
                        _shipped[path] = job.path
                    res["sha256"] = hashlib.sha256(data).hexdigest()
                else:
                    res["sha256"] = file_sha256(path) if os.path.isfile(path) else None
                r = reconstruct.convert_file(path, out_dir, name=job.name, params=job.params,
                                             should_stop=should_stop, **job.options)
                res.update({"status": "done", "json": r.json_path, "ifc": r.ifc_path, **r.report["summary"],
                            "method": r.model.provenance.method})
                if data is not None:
                    files = {}
                    for key in ("json", "ifc"):
                        if res[key]:
                            with open(res[key], "rb") as f:
                                files[os.path.basename(res[key])] = f.read()
                            res[key] = os.path.join(job.out_dir, os.path.basename(res[key]))
                    res["files"] = _reroot(files, path, job.path)
            except Exception as e:  # the error boundary of one file
                if isinstance(e, Cancelled) and should_stop():
                    res.update({"status": "failed", "kind": "cancelled",
                                "error": f"{printable(job.path)}: timed out after {job.timeout:g} s (--timeout)"})
                else:
                    line = error_line(e, job.path)
                    res.update({"status": "failed", "kind": error_kind(e),
                                "error": line.replace(path, job.path) if data is not None else line})
                    if error_kind(e) == "internal":  # a bug: its traceback for --debug
                        import traceback

                        res["traceback"] = traceback.format_exc()
    finally:
        if tmp is not None:
            with _shipped_lock:
                _shipped.pop(path, None)
            shutil.rmtree(tmp, ignore_errors=True)
    res["seconds"] = round(time.perf_counter() - t0, 3)
    res["peak_mb"] = round(mem.peak / 2 ** 20, 1)
    return res


# ------------------------------------------------------------------ the cluster

@contextlib.contextmanager
def connect(scheduler: Optional[str] = None, workers: Optional[int] = None, memory_limit=None):
    """A ``distributed.Client``: on the scheduler at ``scheduler`` (``tcp://HOST:PORT``), or
    on a new ``LocalCluster`` of ``workers`` processes with one thread each and
    ``memory_limit`` per worker (``"2GB"``, bytes, ``"auto"``; the nanny restarts a worker
    over it), closed at the end. The local scheduler declares a task failed the first time
    its worker dies (``allowed-failures`` 0): :func:`run_jobs` does the one retry itself."""
    distributed = _distributed()
    import dask

    if logging.getLogger().getEffectiveLevel() > logging.INFO:  # dask's INFO lines only with --verbose
        logging.getLogger("distributed").setLevel(logging.WARNING)
        logging.getLogger("distributed.nanny").setLevel(logging.ERROR)  # "still alive ..., killing" at close
    if scheduler:
        client = distributed.Client(scheduler, timeout="20s")
        try:
            yield client
        finally:
            client.close()
        return
    # one task per worker at a time (worker-saturation 1): a task queued behind a task that
    # kills its worker would die with it, "failed" without having run
    with dask.config.set({"distributed.scheduler.allowed-failures": 0,
                          "distributed.scheduler.worker-saturation": 1.0}):
        cluster = distributed.LocalCluster(n_workers=int(workers or 1), threads_per_worker=1, processes=True,
                                           memory_limit=memory_limit if memory_limit is not None else "auto",
                                           dashboard_address=":0")
    try:
        client = distributed.Client(cluster)
        try:
            yield client
        finally:
            client.close()
    finally:
        cluster.close()


def dashboard_link(client) -> Optional[str]:
    try:
        return client.dashboard_link
    except Exception:  # no dashboard (bokeh missing) or scheduler without one
        return None


def _died_result(job: Job, attempts: int, exc: BaseException) -> dict:
    return {"input": job.path, "name": job.name, "status": "failed", "kind": "internal", "attempts": attempts,
            "worker": getattr(getattr(exc, "last_worker", None), "address", None),
            "error": f"{printable(job.path)}: the worker died {attempts} times while converting it "
                     "(killed, crashed, or over its memory limit)"}


def _task_states(keys, dask_scheduler=None) -> dict:
    """On the scheduler: each key's task state (None: the scheduler does not know it), and
    ``"_workers"``: the number of workers with threads."""
    tasks = dask_scheduler.tasks
    out = {k: (tasks[k].state if k in tasks else None) for k in keys}
    out["_workers"] = sum(1 for ws in dask_scheduler.workers.values() if ws.nthreads)
    return out


STALL_STATES = {None: "lost by the scheduler", "released": "lost by the scheduler",
                "forgotten": "lost by the scheduler", "no-worker": "not placed on any worker",
                "memory": "finished but never reported", "erred": "failed but never reported"}
"""Scheduler states of a task the client still waits for that mean it is stuck (the
watchdog of :func:`run_jobs`), with how to say so."""


def stalled_tasks(states: dict, since: dict, now: float, grace: float,
                  no_worker_grace: Optional[float] = None) -> list:
    """The keys stuck for at least ``grace`` seconds (``no_worker_grace`` for ``no-worker``,
    default the same): in a state of :data:`STALL_STATES` (``no-worker`` only while the
    cluster has workers) at each look since first seen so. ``since`` (key → first time seen
    stuck) is updated in place."""
    out = []
    workers = states.get("_workers", 1)
    for k, st in states.items():
        if k == "_workers":
            continue
        if st in STALL_STATES and (st != "no-worker" or workers):
            since.setdefault(k, now)
            g = grace if st != "no-worker" or no_worker_grace is None else no_worker_grace
            if now - since[k] >= g:
                out.append(k)
        else:
            since.pop(k, None)
    return out


def run_jobs(client, jobs: Sequence[Job], *, on_result: Optional[Callable[[int, dict], None]] = None,
             task: Callable = convert_job, ship: bool = False, retries: int = 1,
             on_tick: Optional[Callable[[int, int, int], None]] = None, max_in_flight: Optional[int] = None,
             stall_timeout: float = 60.0, poll: float = 0.2, check_every: float = 5.0) -> list:
    """Run ``task(job)`` (``task(job, bytes)`` with ``ship``) for every job on ``client``'s
    cluster; return the results in the order of ``jobs``.

    ``on_result(index, result)`` is called on the client as each one finishes. A task whose
    worker died (``KilledWorker``) is queued again, up to ``retries`` times; then it is a
    failure. ``on_tick(done, failed, running)`` is called as tasks finish (running: the
    unfinished tasks, at most one per worker thread). ``max_in_flight`` bounds the submitted,
    unfinished tasks; by default it is the workers' threads at each submission, so no task
    waits on a worker behind another (it would die with it when that one kills the worker).

    A watchdog asks the scheduler every ``check_every`` seconds for the state of the
    unfinished tasks: one stuck for ``stall_timeout`` seconds (unknown to the scheduler, not
    placed on any worker while there are workers, or finished without the client being told;
    see :data:`STALL_STATES`) is cancelled and counts as a died worker (submitted again, up
    to ``retries``); one running longer than its job's ``timeout`` plus ``stall_timeout``
    (the worker's own deadline did not stop it) fails as timed out. So no batch waits forever.
    """
    distributed = _distributed()
    results: list = [None] * len(jobs)
    attempts = [0] * len(jobs)
    pending: dict = {}
    running: dict = {}  # key -> client time the watchdog first saw it on a worker
    queue = list(range(len(jobs)))[::-1]
    threads = max(1, sum(client.nthreads().values()))
    done = failed = 0

    def key(i):
        return f"convert-{i}-{jobs[i].name}-{attempts[i]}"

    def submit(i):  # a retry: first in the queue
        queue.append(i)

    def fill():  # the queued jobs, up to the limit, in one client.map call
        # by default one task per live worker thread: a task queued on a worker behind one that
        # kills it would die with it without having run (and a retry count against it)
        limit = max_in_flight if max_in_flight is not None else sum(client.nthreads().values())
        batch, data = [], []
        while queue and len(pending) + len(batch) < limit:
            i = queue.pop()
            if ship:
                try:
                    data.append(_read_bytes(jobs[i].path))
                except OSError as e:  # --ship: the client cannot read the scan
                    finish(i, {"input": jobs[i].path, "name": jobs[i].name, "status": "failed", "kind": "input",
                               "error": error_line(InputError(f"cannot read ({e.strerror or e})", jobs[i].path))})
                    continue
            attempts[i] += 1
            batch.append(i)
        if batch:
            futs = client.map(task, [jobs[i] for i in batch], *([data] if ship else []),
                              key=[key(i) for i in batch], pure=False)
            for i, fut in zip(batch, futs):
                pending[fut] = i
            ac.update(futs)

    def finish(i, r):
        nonlocal done, failed
        r.setdefault("attempts", attempts[i])
        results[i] = r
        if r.get("status") == "done":
            done += 1
        else:
            failed += 1
        if on_result is not None:
            on_result(i, r)

    def failure(i, exc) -> Optional[dict]:  # None: submitted again
        if isinstance(exc, distributed.KilledWorker) and attempts[i] <= retries:
            submit(i)
            return None
        if isinstance(exc, distributed.KilledWorker):
            return _died_result(jobs[i], attempts[i], exc)
        # the task itself raised (a custom task, or a bug), or was cancelled
        return {"input": jobs[i].path, "name": jobs[i].name, "status": "failed",
                "kind": error_kind(exc) if isinstance(exc, BaseException) else "internal",
                "error": error_line(exc, jobs[i].path) if isinstance(exc, BaseException) else str(exc)}

    def drop(fut):
        pending.pop(fut, None)
        running.pop(fut.key, None)
        with contextlib.suppress(Exception):
            fut.cancel()
        fut.release()

    def watchdog(now):
        by_key = {fut.key: fut for fut in pending}
        try:
            states = client.run_on_scheduler(_task_states, keys=list(by_key))
        except Exception as e:  # the scheduler itself is gone: the futures will err
            log.warning("batch: cannot ask the scheduler for the task states: %s", e)
            return
        # a retry is submitted preferring the workers other than the one that died; when those
        # are gone too (both restarted by their nannies), the scheduler leaves it unplaced
        # ("no-worker") although it may go anywhere: two looks are enough there
        for k in stalled_tasks(states, stuck, now, stall_timeout, min(stall_timeout, 2 * check_every)):
            fut = by_key[k]
            i = pending[fut]
            how = STALL_STATES[states[k]]
            again = attempts[i] <= retries
            log.warning("batch: %s: the task was %s for %.0f s%s", printable(jobs[i].path), how,
                        now - stuck.pop(k), "; submitting it again" if again else "")
            drop(fut)
            if again:
                submit(i)
            else:
                finish(i, {"input": jobs[i].path, "name": jobs[i].name, "status": "failed", "kind": "internal",
                           "error": f"{printable(jobs[i].path)}: the task was {how} ({attempts[i]} attempts)"})
        for fut, i in list(pending.items()):
            if states.get(fut.key) != "processing":
                continue
            t = getattr(jobs[i], "timeout", None)
            since = running.setdefault(fut.key, now)  # first seen on a worker (to a look)
            if t and now - since > float(t) + stall_timeout:
                drop(fut)
                finish(i, {"input": jobs[i].path, "name": jobs[i].name, "status": "failed", "kind": "cancelled",
                           "error": f"{printable(jobs[i].path)}: timed out after {float(t):g} s (--timeout; "
                                    "the worker did not stop it)"})

    ac = distributed.as_completed([], with_results=True, raise_errors=False)
    stuck: dict = {}
    fill()
    if on_tick is not None:
        on_tick(done, failed, min(len(pending), threads))
    last = time.monotonic()
    while pending or queue:
        batch = ac.next_batch(block=False) if ac.has_ready() else []
        for fut, value in batch:  # results are fetched in the background: no round trip per task
            if fut not in pending:  # dropped by the watchdog
                continue
            i = pending.pop(fut)
            running.pop(fut.key, None)
            status = fut.status
            fut.release()
            if status == "finished":
                finish(i, value)
                continue
            r = failure(i, value[1] if isinstance(value, tuple) and len(value) == 3 else value)
            if r is not None:
                finish(i, r)
        now = time.monotonic()
        if not batch and now - last >= check_every and pending:
            watchdog(now)
            last = now
        if batch or not pending:
            fill()
            if on_tick is not None:
                on_tick(done, failed, min(len(pending), threads))
        elif not batch:
            _wait_ready(ac, poll)
    return results


def _wait_ready(ac, timeout: float) -> None:
    """Wait until ``ac`` (an ``as_completed``) has a finished future, or ``timeout`` seconds."""
    cond = getattr(ac, "thread_condition", None)
    if cond is None:  # another distributed version: poll
        time.sleep(timeout)
        return
    with cond:
        if not ac.has_ready():
            cond.wait(timeout=timeout)


def _read_bytes(path: str) -> bytes:
    with open(path, "rb") as f:
        return f.read()


def write_shipped(out_dir: str, result: dict) -> None:
    """Write the outputs a ``--ship`` task sent back into ``out_dir`` (each atomically)."""
    files = result.pop("files", None) or {}
    for fname, data in files.items():
        atomic_write_bytes(os.path.join(out_dir, fname), data)


def remove_partials(out_dir: str, name: str) -> None:
    """Remove the temporary ``.<name>.*.part`` files a worker killed mid-write left behind."""
    with contextlib.suppress(OSError), os.scandir(out_dir) as it:
        for e in it:
            if e.name.startswith("." + name + ".") and e.name.endswith(".part"):
                with contextlib.suppress(OSError):
                    os.remove(e.path)

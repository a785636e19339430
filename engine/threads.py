"""One thread cap for every parallel library (OpenMP, BLAS, kd-tree queries, Open3D).

A 2-core machine running NumPy's BLAS, Open3D's OpenMP and SciPy's threaded kd-tree queries
side by side would otherwise start a thread pool per library per core count it guesses
(containers often report the host's cores). The cap is the cores this process may run on
(``os.sched_getaffinity``), or ``INDOOR_THREADS`` when set. :func:`apply_thread_env` sets the
usual environment variables, unless the user set them, before NumPy or Open3D load
(``engine/__init__.py`` calls it first): OpenMP's and NumExpr's to the cap, the BLAS pools'
(:data:`BLAS_VARIABLES`) to one thread. NumPy's BLAS does little of the engine's work (3 × 3
eigenproblems, products of (n, 3) arrays that memory bounds), and OpenBLAS's idle workers
spin between calls: two of them burnt 1.4 s of the 8 CPU seconds of a 1M-point office
convert, for no gain in time on a quiet machine and 20 % more wall time when another program
used a core. Inside Blender NumPy is loaded before the engine, so the variables come too late
for it: :func:`cap_loaded_blas` then sets the OpenBLAS libraries already loaded to one thread
through their own ``openblas_set_num_threads`` (Linux; unless the user set
``OPENBLAS_NUM_THREADS``).
"""
from __future__ import annotations

import os

__all__ = ["available_cores", "thread_cap", "apply_thread_env", "cap_loaded_blas", "loaded_blas_threads",
           "THREAD_VARIABLES", "BLAS_VARIABLES"]

BLAS_VARIABLES = ("OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "VECLIB_MAXIMUM_THREADS")
"""Environment variables NumPy's BLAS reads at load time (one thread by default)."""
THREAD_VARIABLES = ("OMP_NUM_THREADS", "NUMEXPR_NUM_THREADS") + BLAS_VARIABLES
"""Every environment variable :func:`apply_thread_env` sets."""


def available_cores() -> int:
    """Cores this process may run on (its CPU affinity), at least 1."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except (AttributeError, OSError):
        return max(1, os.cpu_count() or 1)


def thread_cap() -> int:
    """Threads for parallel work: ``INDOOR_THREADS`` when it is a positive integer, else the
    available cores."""
    v = os.environ.get("INDOOR_THREADS", "").strip()
    if v.isdigit() and int(v) > 0:
        return int(v)
    return available_cores()


def apply_thread_env() -> int:
    """Set each of :data:`THREAD_VARIABLES` the user left unset: the BLAS pools to 1 thread,
    the others to :func:`thread_cap`; returns the cap."""
    import sys

    n = thread_cap()
    user_blas = "OPENBLAS_NUM_THREADS" in os.environ
    for k in THREAD_VARIABLES:
        os.environ.setdefault(k, "1" if k in BLAS_VARIABLES else str(n))
    if "numpy" in sys.modules and not user_blas:  # loaded first (Blender): too late for the variables
        cap_loaded_blas(1)
    return n


_SET = ("openblas_set_num_threads64_", "openblas_set_num_threads")
_GET = ("openblas_get_num_threads64_", "openblas_get_num_threads")


def _loaded_openblas() -> list:
    """The OpenBLAS libraries loaded in this process (ctypes handles; Linux: /proc/self/maps)."""
    import ctypes

    try:
        with open("/proc/self/maps") as f:
            paths = sorted({line.split()[-1] for line in f
                            if "openblas" in line.lower() and line.rstrip().split()[-1].startswith("/")})
    except OSError:
        return []
    libs = []
    for path in paths:
        try:
            libs.append(ctypes.CDLL(path))
        except OSError:
            continue
    return libs


def _blas_calls(names: tuple) -> list:
    """The first of ``names`` each loaded OpenBLAS library exports (ctypes functions)."""
    out = []
    for lib in _loaded_openblas():
        fn = next((getattr(lib, name) for name in names if hasattr(lib, name)), None)
        if fn is not None:
            out.append(fn)
    return out


def cap_loaded_blas(threads: int = 1) -> int:
    """Set every OpenBLAS library already loaded to ``threads`` threads; returns how many were
    set (0 where none is loaded or the platform does not say: not Linux)."""
    calls = _blas_calls(_SET)
    for fn in calls:
        fn(int(threads))
    return len(calls)


def loaded_blas_threads() -> list:
    """The thread count of every OpenBLAS library loaded (Linux), for checks."""
    return [int(fn()) for fn in _blas_calls(_GET)]

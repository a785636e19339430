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
used a core. Inside Blender NumPy is already loaded and Blender's own settings apply.
"""
from __future__ import annotations

import os

__all__ = ["available_cores", "thread_cap", "apply_thread_env", "THREAD_VARIABLES", "BLAS_VARIABLES"]

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
    n = thread_cap()
    for k in THREAD_VARIABLES:
        os.environ.setdefault(k, "1" if k in BLAS_VARIABLES else str(n))
    return n

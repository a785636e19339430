"""Benchmarks: ``python -m bench --out out/bench [--only NAME] [--quick]``.

Every module ``bench/bench_<name>.py`` is a benchmark named ``<name>``; it exposes
``run(out_dir: str, quick: bool) -> dict`` returning JSON-ready figures, which
``bench/__main__.py`` writes to ``<out>/<name>.json`` (with timing and machine facts added).
Adding a benchmark is adding such a module; nothing needs registering.
"""

import resource


def peak_rss_mb() -> float:
    """Peak resident memory of this process so far (``VmHWM``), MB."""
    try:
        with open("/proc/self/status") as f:
            for line in f:
                if line.startswith("VmHWM:"):
                    return int(line.split()[1]) / 1024.0
    except OSError:
        pass
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0

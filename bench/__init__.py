"""Benchmarks: ``python -m bench --out out/bench [--only NAME] [--quick]``.

Every module ``bench/bench_<name>.py`` is a benchmark named ``<name>``; it exposes
``run(out_dir: str, quick: bool) -> dict`` returning JSON-ready figures, which
``bench/__main__.py`` writes to ``<out>/<name>.json`` (with timing and machine facts added).
Adding a benchmark is adding such a module; nothing needs registering.
"""

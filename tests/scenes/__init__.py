"""Hand-built scenes shared by the test files, each with its truth written out (independent of
``engine.synthetic``), and the paths of the repository and of ``tests/data``.

``tests/`` is on ``sys.path`` (pytest's ``pythonpath`` setting), so test files import these as
``scenes.<module>``; no test file imports another test file.
"""
import os

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
"""The repository root (the extension package in the source tree)."""
DATA = os.path.join(ROOT, "tests", "data")
"""The third-party scans and IFC models the tests read."""

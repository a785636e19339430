"""Run the test suite headless inside Blender, either way:

    blender -b --factory-startup --python-exit-code 1 --python tests/run_tests.py -- <pytest args>
    python tests/run_tests.py <pytest args>          # with the bpy module installed

Without path arguments pytest collects every folder under tests/ (``testpaths`` and
``pythonpath`` in pyproject.toml). The exit code is pytest's (non-zero on any failure or
when no test ran).
"""
import os
import site
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def _pytest_args():
    argv = sys.argv
    if "--" in argv:  # inside Blender: our args follow "--"
        return argv[argv.index("--") + 1:]
    return argv[1:]


def _private_blender_user_dirs():
    """Point Blender's user folders at a throwaway directory so no test run writes to the
    user's ~/.config/blender (extensions cache, preferences)."""
    import tempfile

    base = tempfile.mkdtemp(prefix="indoor-tests-blender-")
    for kind in ("RESOURCES", "CONFIG", "SCRIPTS", "EXTENSIONS", "DATAFILES"):
        os.environ.setdefault("BLENDER_USER_" + kind, os.path.join(base, kind.lower()))
    return base


def main():
    args = _pytest_args()
    _private_blender_user_dirs()
    # Under a real Blender binary its own Python lacks pytest and the engine's packages:
    # borrow the project's .venv (Blender's bundled numpy stays first on the path).
    venv_site = os.path.join(ROOT, ".venv", "lib", "python%d.%d" % sys.version_info[:2], "site-packages")
    if os.path.isdir(venv_site) and venv_site not in sys.path:
        site.addsitedir(venv_site)
    if ROOT not in sys.path:
        sys.path.insert(0, ROOT)
    import bpy  # noqa: F401  (fail early and clearly when Blender is not available)
    import pytest

    os.chdir(ROOT)
    code = pytest.main(["-p", "no:cacheprovider", "-p", "no:dash", *args])
    return int(code)


if __name__ == "__main__":
    code = main()
    sys.stdout.flush()
    sys.stderr.flush()
    # Exit at once with pytest's code: the bpy module can hang at interpreter shutdown when
    # an add-on class is left registered, and Blender's own exit would hide the code.
    os._exit(code)

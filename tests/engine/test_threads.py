"""The thread cap (engine.threads)."""
import os
import subprocess
import sys

import pytest

from engine.threads import BLAS_VARIABLES, THREAD_VARIABLES, available_cores, thread_cap

from scenes import ROOT


def _env_after_import(env):
    code = "import engine, os, json; print(json.dumps({k: os.environ.get(k) for k in %r}))" % (THREAD_VARIABLES,)
    out = subprocess.run([sys.executable, "-c", code], env=env, cwd=ROOT, capture_output=True, text=True, check=True)
    import json
    return json.loads(out.stdout)


def _clean_env(**extra):
    env = {k: v for k, v in os.environ.items() if k not in THREAD_VARIABLES and k != "INDOOR_THREADS"}
    env.update(extra)
    return env


def test_importing_the_engine_caps_openmp_at_the_available_cores_and_blas_at_one():
    got = _env_after_import(_clean_env())
    assert got["OMP_NUM_THREADS"] == got["NUMEXPR_NUM_THREADS"] == str(available_cores())
    assert {got[k] for k in BLAS_VARIABLES} == {"1"}  # idle OpenBLAS workers spin (engine.threads)


def test_indoor_threads_sets_the_cap_and_user_settings_win():
    got = _env_after_import(_clean_env(INDOOR_THREADS="3", OMP_NUM_THREADS="5", OPENBLAS_NUM_THREADS="2"))
    assert got["OMP_NUM_THREADS"] == "5" and got["OPENBLAS_NUM_THREADS"] == "2"  # the user's: left alone
    assert got["NUMEXPR_NUM_THREADS"] == "3" and got["MKL_NUM_THREADS"] == "1"


def test_numpy_blas_starts_no_worker_threads_after_importing_the_engine():
    """OpenBLAS starts its workers when it loads; with one thread it starts none, so the
    process holds its main thread alone after a large product (Linux: /proc/self/task)."""
    if not os.path.isdir("/proc/self/task"):
        pytest.skip("no /proc")
    code = ("import engine, numpy, os; a = numpy.ones((400, 400)); b = a @ a; "
            "print(len(os.listdir('/proc/self/task')))")
    counts = [subprocess.run([sys.executable, "-c", code], env=_clean_env(**extra), cwd=ROOT,
                             capture_output=True, text=True, check=True).stdout.strip()
              for extra in ({}, {"OPENBLAS_NUM_THREADS": "2"})]
    assert counts[0] == "1"
    assert counts[1] == "2"  # the check itself sees a worker when there is one


def test_thread_cap_ignores_nonsense(monkeypatch):
    monkeypatch.setenv("INDOOR_THREADS", "zero")
    assert thread_cap() == available_cores()
    monkeypatch.setenv("INDOOR_THREADS", "0")
    assert thread_cap() == available_cores()
    monkeypatch.setenv("INDOOR_THREADS", "5")
    assert thread_cap() == 5


def test_blas_loaded_before_the_engine_is_capped_at_runtime():
    """Inside Blender NumPy (and its OpenBLAS) loads before the engine, too late for the
    variables: importing the engine sets the loaded library to one thread, unless the user
    set OPENBLAS_NUM_THREADS (Linux)."""
    if not os.path.isdir("/proc/self/task") or available_cores() < 2:
        pytest.skip("needs Linux and 2 cores (OpenBLAS starts one thread per core)")
    code = ("import numpy, json; from importlib import util; "
            "spec = util.spec_from_file_location('t', {path!r}); t = util.module_from_spec(spec); "
            "spec.loader.exec_module(t); before = t.loaded_blas_threads(); import engine; "
            "print(json.dumps([before, t.loaded_blas_threads()]))").format(
        path=os.path.join(ROOT, "engine", "threads.py"))
    import json

    def run(**extra):
        out = subprocess.run([sys.executable, "-c", code], env=_clean_env(**extra), cwd=ROOT,
                             capture_output=True, text=True, check=True)
        return json.loads(out.stdout)

    before, after = run()
    assert before and min(before) >= 2 and set(after) == {1}
    before, after = run(OPENBLAS_NUM_THREADS="2")  # the user's: left alone
    assert set(before) == set(after) == {2}

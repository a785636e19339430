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

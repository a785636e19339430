"""The thread cap (engine.threads)."""
import os
import subprocess
import sys

from engine.threads import THREAD_VARIABLES, available_cores, thread_cap

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


def test_importing_the_engine_caps_every_pool_at_the_available_cores():
    got = _env_after_import(_clean_env())
    assert set(got.values()) == {str(available_cores())}


def test_indoor_threads_sets_the_cap_and_user_settings_win():
    got = _env_after_import(_clean_env(INDOOR_THREADS="1", OMP_NUM_THREADS="3"))
    assert got["OMP_NUM_THREADS"] == "3"  # set by the user: left alone
    assert got["OPENBLAS_NUM_THREADS"] == "1" and got["MKL_NUM_THREADS"] == "1"


def test_thread_cap_ignores_nonsense(monkeypatch):
    monkeypatch.setenv("INDOOR_THREADS", "zero")
    assert thread_cap() == available_cores()
    monkeypatch.setenv("INDOOR_THREADS", "0")
    assert thread_cap() == available_cores()
    monkeypatch.setenv("INDOOR_THREADS", "5")
    assert thread_cap() == 5

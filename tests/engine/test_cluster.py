"""Batch conversion on a Dask cluster (engine/cluster.py, ``indoor convert --workers``): one task
per file, failures per file, a dead worker's file retried, ``--resume``, ``--ship``, and models
equal to the in-process ones (GlobalIds included)."""
import json
import os
import sys

import pytest

from engine import BuildingModel, cluster
from engine.cli import main
from engine.errors import MissingDependencyError
from engine.io import write_ply

POINTS = 15_000  # a small office: ~5-15 s per conversion on a busy 2-core machine
EPOCH = "1700000000"  # SOURCE_DATE_EPOCH: IFC headers without the clock, byte-comparable


def _bad_ply(path):
    path.write_bytes(b"ply\nformat binary_little_endian 1.0\nelement vertex 1000\n"
                     b"property float x\nproperty float y\nproperty float z\nend_header\n" + b"\0" * 12)
    return path


@pytest.fixture(scope="module")
def scans(tmp_path_factory, request):
    """Three small scans (two of them called scan.ply, in two folders) and a corrupt one."""
    scene = request.getfixturevalue("synthetic_scene")
    root = tmp_path_factory.mktemp("scans")
    paths = []
    for folder, seed, fname in (("a", 1, "scan.ply"), ("b", 2, "scan.ply"), ("c", 3, "other.ply")):
        (root / folder).mkdir()
        p = root / folder / fname
        write_ply(p, scene("office_mw", seed, "tls", POINTS).cloud)
        paths.append(str(p))
    paths.append(str(_bad_ply(root / "c" / "broken.ply")))
    return root, paths


def _model_dict(path):
    d = BuildingModel.from_json(path).to_dict()
    d["provenance"].pop("timings", None)  # seconds differ between any two runs
    return d


# ------------------------------------------------------------------ no cluster needed

def test_expand_inputs_folders_and_lists(tmp_path):
    (tmp_path / "d" / "sub").mkdir(parents=True)
    for rel in ("d/b.ply", "d/sub/a.LAS", "d/notes.md", "x.e57"):
        (tmp_path / rel).write_bytes(b"")
    lst = tmp_path / "scans.lst"
    lst.write_text("# two scans\nx.e57\n\n" + str(tmp_path / "d" / "b.ply") + "\n")
    txt = tmp_path / "list.txt"
    txt.write_text("x.e57\n")
    points = tmp_path / "points.txt"
    points.write_text("0 0 0\n1 1 1\n")
    got = cluster.expand_inputs([str(tmp_path / "d"), str(lst), "@" + str(txt), str(txt), str(points),
                                 str(tmp_path / "missing.ply")])
    assert got == [str(tmp_path / "d" / "b.ply"), str(tmp_path / "d" / "sub" / "a.LAS"),
                   str(tmp_path / "x.e57"), str(tmp_path / "d" / "b.ply"),
                   str(tmp_path / "x.e57"), str(tmp_path / "x.e57"), str(points), str(tmp_path / "missing.ply")]


def test_manifest_matches_only_same_input_params_and_outputs(tmp_path):
    scan = tmp_path / "s.ply"
    scan.write_bytes(b"points v1")
    (tmp_path / "s.json").write_text("{}")
    h = cluster.params_hash({"seed": 0})
    assert h != cluster.params_hash({"seed": 1})
    cluster.write_manifest(tmp_path, "s", str(scan), cluster.file_sha256(scan), h, [str(tmp_path / "s.json")])
    assert cluster.manifest_ok(tmp_path, "s", str(scan), h)["outputs"] == ["s.json"]
    assert cluster.manifest_ok(tmp_path, "s", str(scan), cluster.params_hash({"seed": 1})) is None
    scan.write_bytes(b"points v2")  # same name, other content
    assert cluster.manifest_ok(tmp_path, "s", str(scan), h) is None
    scan.write_bytes(b"points v1")
    os.remove(tmp_path / "s.json")  # an output is gone
    assert cluster.manifest_ok(tmp_path, "s", str(scan), h) is None


def test_without_dask_a_typed_error(monkeypatch, tmp_path, capsys):
    monkeypatch.setitem(sys.modules, "distributed", None)  # import distributed -> ImportError
    with pytest.raises(MissingDependencyError, match="dask"):
        with cluster.connect(workers=1):
            pass
    scan = _bad_ply(tmp_path / "x.ply")
    assert main(["convert", str(scan), "-o", str(tmp_path / "o"), "--workers", "1"]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "dask[distributed]" in err[0] and "pip install" in err[0]


@pytest.mark.slow  # the scans fixture simulates three scans
def test_timeout_in_process(scans, tmp_path, capsys):
    _, paths = scans
    code = main(["convert", paths[0], "-o", str(tmp_path), "--method", "manhattan", "--timeout", "0.001",
                 "--json"])
    assert code == 1
    failed = json.loads(capsys.readouterr().out)["failed"]
    assert len(failed) == 1 and "timed out" in failed[0]["error"] and failed[0]["kind"] == "cancelled"
    assert not (tmp_path / "scan.json").exists()


# ------------------------------------------------------------------ LocalCluster of 2 workers

@pytest.mark.slow
def test_cluster_batch_failure_resume_and_same_models(scans, tmp_path, monkeypatch, capsys):
    monkeypatch.setenv("SOURCE_DATE_EPOCH", EPOCH)  # before the workers start: they inherit it
    root, paths = scans
    out, ref = tmp_path / "out", tmp_path / "ref"
    code = main(["convert", str(root), "-o", str(out), "--method", "manhattan", "--workers", "2", "--json"])
    assert code == 1  # the corrupt file
    result = json.loads(capsys.readouterr().out)
    record = json.loads((out / "batch.json").read_text())
    # the folder expands to its 4 scans, sorted: a/scan, b/scan, c/broken, c/other
    assert sorted(d["input"] for d in record["done"]) == sorted(paths[:3])
    assert [f["file"] for f in record["failed"]] == [paths[3]]
    assert record["failed"][0]["kind"] == "input" and "broken.ply" in record["failed"][0]["error"]
    for entry in record["done"] + record["failed"]:
        assert entry["worker"].startswith("tcp://127.0.0.1:")
        assert entry["attempts"] == 1 and entry["seconds"] > 0 and entry["peak_mb"] > 50  # a worker holds numpy
    assert len(result["converted"]) == 3
    # same stems in two folders: scan and scan_2, nothing overwritten
    by_input = {d["input"]: d for d in record["done"]}
    assert os.path.basename(by_input[paths[0]]["ifc"]) == "scan.ifc"
    assert os.path.basename(by_input[paths[1]]["ifc"]) == "scan_2.ifc"
    # the models equal the in-process ones, IFC byte for byte (GlobalIds included)
    assert main(["convert", paths[2], "-o", str(ref), "--method", "manhattan", "--quiet"]) == 0
    assert (out / "other.ifc").read_bytes() == (ref / "other.ifc").read_bytes()
    assert _model_dict(out / "other.json") == _model_dict(ref / "other.json")

    # an interrupted run: one file's outputs are missing, another's IFC half there (removed)
    for f in ("other.json", "other.ifc", "other.manifest.json"):
        os.remove(out / f)
    os.remove(out / "scan.ifc")
    kept = (out / "scan_2.ifc").stat().st_mtime_ns
    code = main(["convert", str(root), "-o", str(out), "--method", "manhattan", "--workers", "2", "--resume",
                 "--json"])
    assert code == 1
    result = json.loads(capsys.readouterr().out)
    assert [s["input"] for s in result["skipped"]] == [paths[1]]
    assert sorted(r["input"] for r in result["converted"]) == sorted([paths[0], paths[2]])
    assert (out / "scan_2.ifc").stat().st_mtime_ns == kept
    assert (out / "other.ifc").exists() and (out / "scan.ifc").exists()
    # other parameters: nothing is up to date
    code = main(["convert", paths[1], "-o", str(out), "--method", "manhattan", "--seed", "1", "--resume",
                 "--no-ifc", "--json"])
    assert json.loads(capsys.readouterr().out)["skipped"] == []


def flaky_convert(job, data=None):
    """The real task, but the worker process dies (os._exit) the first time for each job."""
    marker = job.options.pop("_marker")
    if not os.path.exists(marker):
        open(marker, "w").close()
        os._exit(17)
    if job.options.pop("_always_die", False):
        os._exit(17)
    return cluster.convert_job(job, data)


@pytest.mark.slow
def test_dead_worker_retried_once_ship_and_timeout(scans, tmp_path, monkeypatch):
    import cloudpickle

    monkeypatch.setenv("SOURCE_DATE_EPOCH", EPOCH)
    cloudpickle.register_pickle_by_value(sys.modules[__name__])  # workers need not import the tests
    _, paths = scans
    out, ref = tmp_path / "out", tmp_path / "ref"
    out.mkdir()
    opts = {"method": "manhattan", "seed": 0}
    jobs = [cluster.Job(paths[2], "other", str(out), {**opts, "_marker": str(tmp_path / "m1")}),
            cluster.Job(paths[3], "broken", str(out), {**opts, "_marker": str(tmp_path / "m2"),
                                                        "_always_die": True})]
    seen = []
    with cluster.connect(workers=2) as client:
        first = set(client.scheduler_info()["workers"])
        # a watchdog asks the scheduler every 2 s; a task stuck for 20 s is submitted again
        res = cluster.run_jobs(client, jobs, task=flaky_convert, on_result=lambda i, r: seen.append(i),
                               stall_timeout=20, check_every=2)
        assert sorted(seen) == [0, 1]
        assert res[0]["status"] == "done" and res[0]["attempts"] == 2
        assert res[0]["worker"] not in first or len(first) == 2  # a restarted or the other worker
        assert res[1]["status"] == "failed" and res[1]["attempts"] == 2 and "died 2 times" in res[1]["error"]
        # --ship: bytes to the worker and back; same model as in place
        ship_dir = tmp_path / "ship"
        ship_dir.mkdir()
        shipped = cluster.run_jobs(client, [cluster.Job(paths[2], "other", str(ship_dir), opts)], ship=True)[0]
        assert shipped["status"] == "done" and shipped["json"] == str(ship_dir / "other.json")
        assert sorted(shipped["files"]) == ["other.ifc", "other.json"]
        cluster.write_shipped(str(ship_dir), shipped)
        # a per-file timeout on the worker
        slow = cluster.run_jobs(client, [cluster.Job(paths[0], "t", str(tmp_path / "t"), opts, timeout=0.001)])[0]
        assert slow["status"] == "failed" and "timed out" in slow["error"]
    assert not (out / "broken.json").exists()
    assert not [f for f in os.listdir(out) if f.endswith(".part")]
    assert main(["convert", paths[2], "-o", str(ref), "--method", "manhattan", "--quiet"]) == 0
    for d in (out, ship_dir):
        assert (d / "other.ifc").read_bytes() == (ref / "other.ifc").read_bytes()
        assert _model_dict(d / "other.json") == _model_dict(ref / "other.json")


def test_stalled_tasks_need_the_grace_at_each_look():
    since = {}
    states = {"a": None, "b": "processing", "c": "no-worker", "d": "memory", "_workers": 2}
    assert cluster.stalled_tasks(states, since, 0.0, 10.0) == []
    assert sorted(since) == ["a", "c", "d"]
    # "a" comes back (a look where it is processing): its clock starts again
    assert cluster.stalled_tasks({**states, "a": "processing"}, since, 5.0, 10.0) == []
    assert sorted(cluster.stalled_tasks(states, since, 10.0, 10.0)) == ["c", "d"]
    assert sorted(cluster.stalled_tasks(states, since, 15.0, 10.0)) == ["c", "d"]  # "a": stuck since 10
    assert sorted(cluster.stalled_tasks(states, since, 20.0, 10.0)) == ["a", "c", "d"]
    # no worker at all: waiting for one is not a stall
    assert cluster.stalled_tasks({"c": "no-worker", "_workers": 0}, {}, 100.0, 0.0) == []


def sleepy_task(job, data=None):
    """A task that ignores its deadline: sleeps ``options["sleep"]`` seconds."""
    import time
    time.sleep(float(job.options.get("sleep", 0)))
    return {"input": job.path, "name": job.name, "status": "done"}


def _forget(keys, client_id, dask_scheduler=None):
    dask_scheduler.client_releases_keys(keys=keys, client=client_id, stimulus_id="test-forget")
    return [k in dask_scheduler.tasks for k in keys]


@pytest.mark.slow
def test_watchdog_resubmits_a_lost_task_and_fails_a_stuck_one(tmp_path):
    import threading
    import time

    import cloudpickle

    cloudpickle.register_pickle_by_value(sys.modules[__name__])
    with cluster.connect(workers=1) as client:
        forgotten = []

        def forget_soon():  # the scheduler forgets the task while the client still waits for it
            time.sleep(1.0)
            keys = [k for k in client.futures]
            forgotten.extend(client.run_on_scheduler(_forget, keys, client.id))

        th = threading.Thread(target=forget_soon)
        th.start()
        t0 = time.monotonic()
        res = cluster.run_jobs(client, [cluster.Job("a.ply", "a", str(tmp_path), {"sleep": 3})], task=sleepy_task,
                               stall_timeout=2, check_every=0.5)[0]
        th.join()
        assert forgotten == [False]  # the scheduler no longer knew the task
        assert res["status"] == "done" and res["attempts"] == 2
        assert time.monotonic() - t0 < 60  # without the watchdog: forever
        # a task that does not stop at its deadline fails once it is timeout + stall_timeout on a worker
        res = cluster.run_jobs(client, [cluster.Job("b.ply", "b", str(tmp_path), {"sleep": 60}, timeout=0.5)],
                               task=sleepy_task, stall_timeout=1, check_every=0.5)[0]
        assert res["status"] == "failed" and "timed out after 0.5 s" in res["error"] and res["attempts"] == 1

"""engine.background: engine work in a worker thread (progress, cancel, errors), without Blender."""
import threading
import time

import pytest

from engine.background import BackgroundJob, ReconstructJob
from engine.errors import Cancelled, ReconstructionError
from engine.progress import Progress


def _wait(job, timeout=120.0):
    assert job.join(timeout), "the job did not end in time"


@pytest.fixture(scope="module")
def office():
    from engine.synthetic import preset

    return preset("office_mw", seed=1, target_points=20_000)


def test_job_runs_and_reports_progress_in_order():
    seen = []

    def work(progress, should_stop):
        for i in range(5):
            progress(i / 4, f"step {i}")
            seen.append(threading.current_thread().name)
        return "done"

    job = BackgroundJob(work, name="indoor-test").start()
    _wait(job)
    assert job.done and not job.running and job.outcome() == "done"
    assert job.fraction == 1.0 and job.message == "step 4"
    assert set(seen) == {"indoor-test"}  # the work ran in the worker thread
    assert job.error is None and not job.cancelled and job.seconds >= 0.0


def test_eta_extrapolates_the_elapsed_time_while_running():
    half, release = threading.Event(), threading.Event()

    def work(progress, should_stop):
        progress(0.5, "half")
        half.set()
        release.wait(30)
        return None

    job = BackgroundJob(work)
    assert job.eta == ""  # not started
    job.start()
    assert half.wait(30)
    job._started -= 10.0  # as if 10 s had passed: half done in 10 s leaves about 10 s
    assert job.eta == "~10 s left"
    release.set()
    _wait(job)
    assert job.eta == ""  # done


def test_fraction_never_goes_back_and_stays_in_range():
    def work(progress, should_stop):
        progress(0.6, "later")
        progress(0.2)  # a sub-step reporting less: the bar does not go back
        progress(7.0)
        return None

    job = BackgroundJob(work).start()
    _wait(job)
    assert job.fraction == 1.0 and job.message == "later"


def test_cancel_stops_the_work_with_cancelled():
    started = threading.Event()

    def work(progress, should_stop):
        p = Progress.wrap(progress, should_stop)
        started.set()
        while True:  # as the engine's loops do: check at each step
            p(0.5, "working")
            time.sleep(0.005)

    job = BackgroundJob(work).start()
    assert started.wait(10)
    job.cancel()
    _wait(job, 10)
    assert job.cancelled and job.error is None and job.result is None
    with pytest.raises(Cancelled):
        job.outcome()


def test_error_is_carried_to_the_caller():
    def work(progress, should_stop):
        progress(0.3, "almost")
        raise ZeroDivisionError("float division by zero")

    job = BackgroundJob(work).start()
    _wait(job)
    assert isinstance(job.error, ZeroDivisionError) and not job.cancelled
    with pytest.raises(ZeroDivisionError, match="division"):
        job.outcome()  # raised again in the caller's thread


def test_outcome_before_the_end_is_an_error():
    release = threading.Event()
    job = BackgroundJob(lambda progress, should_stop: release.wait(10))
    with pytest.raises(RuntimeError, match="not finished"):
        job.outcome()  # not started
    job.start()
    try:
        with pytest.raises(RuntimeError, match="not finished"):
            job.outcome()
    finally:
        release.set()
    _wait(job)
    assert job.outcome() is True


def test_reconstruct_job_gives_the_engine_model(office):
    from engine.reconstruct import reconstruct

    job = ReconstructJob(office.cloud, "manhattan", 0).start()
    _wait(job, 300)
    assert job.error is None and not job.cancelled
    assert job.fraction == pytest.approx(1.0) and job.message
    expect = reconstruct(office.cloud, "manhattan", rng=0)
    assert [s.id for s in job.model.shapes] == [s.id for s in expect.shapes]
    assert len(job.model.spaces) >= 2


def test_reconstruct_job_cancelled_at_once(office):
    job = ReconstructJob(office.cloud, "manhattan", 0)
    job.cancel()  # before it starts: the engine stops at its first check
    job.start()
    _wait(job, 60)
    assert job.cancelled and job.model is None
    with pytest.raises(Cancelled):
        job.outcome()


def test_reconstruct_job_carries_a_reconstruction_error():
    import numpy as np

    from engine.pointcloud import PointCloud

    rng = np.random.default_rng(0)
    flat = PointCloud(xyz=np.column_stack([rng.uniform(0, 5, 3000), rng.uniform(0, 5, 3000), np.zeros(3000)]))
    job = ReconstructJob(flat, "manhattan", 0).start()
    _wait(job, 60)
    assert isinstance(job.error, ReconstructionError)
    with pytest.raises(ReconstructionError):
        job.outcome()

"""Per-stage time budgets, the memory cap and the too_large pre-check, with tiny budgets."""

from __future__ import annotations

import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest
import trimesh

from simcore.budgets import Budgets, StageTimeout
from simcore.errors import SimcoreError
from simcore.options import JobOptions
from simcore.pipeline import PipelineInputs, run_pipeline
from simcore.stage_clock import StageClock
from tests.meshes import glb_bytes

REPO = Path(__file__).resolve().parents[2]


@pytest.fixture
def capsule(tmp_path) -> PipelineInputs:
    path = tmp_path / "capsule.glb"
    path.write_bytes(glb_bytes(trimesh.creation.capsule(height=1.0, radius=0.2, count=[16, 16])))
    return PipelineInputs(path, "glb")


def test_a_stage_past_its_budget_fails_the_job_with_stage_timeout_naming_the_setting(capsule, tmp_path):
    with pytest.raises(SimcoreError) as caught:
        run_pipeline(capsule, JobOptions(stages=["skeleton"]), tmp_path / "out", budgets=Budgets(skeleton_seconds=0.001))
    assert caught.value.code == "stage_timeout"
    assert "skeleton stage" in str(caught.value) and "RIGFORGE_BUDGETS__SKELETON_SECONDS" in str(caught.value)


def test_the_same_budget_holds_off_the_main_thread_where_no_alarm_can_be_armed(capsule, tmp_path):
    errors: list[BaseException] = []

    def job() -> None:
        try:
            run_pipeline(capsule, JobOptions(stages=[]), tmp_path / "out", budgets=Budgets(ingest_seconds=0.001))
        except BaseException as exc:  # noqa: BLE001 - handed to the test thread
            errors.append(exc)

    thread = threading.Thread(target=job)
    thread.start()
    thread.join(60)
    assert len(errors) == 1 and getattr(errors[0], "code", None) == "stage_timeout", errors


def test_a_generous_budget_lets_the_job_through(capsule, tmp_path):
    state = run_pipeline(capsule, JobOptions(stages=[]), tmp_path / "out", budgets=Budgets(ingest_seconds=120))
    assert "ingest" in state.report["timings_s"]


def test_a_loop_that_never_checks_is_interrupted_in_the_main_thread_within_its_budget():
    started = time.monotonic()
    with pytest.raises(StageTimeout), StageClock("skin", 0.3):
        while True:  # a stage that neither reports progress nor checks for cancel
            pass
    assert time.monotonic() - started < 2.0


def test_a_timeout_that_native_code_turned_into_another_error_still_leaves_as_the_timeout():
    with pytest.raises(StageTimeout) as caught, StageClock("skeleton", 0.05):
        try:
            while True:
                pass
        except StageTimeout:
            raise TypeError("Cannot compare structured arrays") from None  # as numpy's np.unique did mid-compare
    assert isinstance(caught.value.__cause__, TypeError)


def test_an_error_of_the_stage_itself_is_left_as_it_is():
    with pytest.raises(ValueError), StageClock("skeleton", 5.0):
        raise ValueError("the stage's own")


def test_the_clock_restores_an_alarm_armed_before_the_stage_and_its_handler():
    import signal

    fired: list[int] = []
    previous = signal.signal(signal.SIGALRM, lambda signum, frame: fired.append(signum))
    left = signal.setitimer(signal.ITIMER_REAL, 30.0)[0]  # e.g. pytest-timeout's timer for this test
    try:
        with StageClock("motion", 5.0):
            pass
        assert 25.0 < signal.getitimer(signal.ITIMER_REAL)[0] <= 30.0 and not fired
        with StageClock("motion", 5.0):
            signal.setitimer(signal.ITIMER_REAL, 0.05)  # the earlier timer falls due inside the stage
            time.sleep(0.2)
        assert fired == [signal.SIGALRM]
    finally:
        signal.setitimer(signal.ITIMER_REAL, left)
        signal.signal(signal.SIGALRM, previous)


def test_a_job_that_cannot_fit_the_memory_budget_fails_before_its_heavy_stages_with_too_large(capsule, tmp_path):
    started = time.monotonic()
    with pytest.raises(SimcoreError) as caught:
        run_pipeline(capsule, JobOptions(), tmp_path / "out", budgets=Budgets(worker_memory_mb=1))
    assert caught.value.code == "too_large" and caught.value.field == "mesh"
    assert "skeleton stage" in str(caught.value) and "RIGFORGE_BUDGETS__WORKER_MEMORY_MB" in str(caught.value)
    assert time.monotonic() - started < 10


OOM_CHILD = """
import sys
from pathlib import Path
from simcore.budgets import apply_memory_cap
from simcore.job_cost import data_segment_bytes
from simcore.options import JobOptions
from simcore.pipeline import PipelineInputs, run_pipeline
from simcore.errors import SimcoreError
run_pipeline(PipelineInputs(Path(sys.argv[3]), "obj"), JobOptions(stages=[]), Path(sys.argv[2]) / "warm")  # loads, threads
apply_memory_cap(data_segment_bytes() + 24 * 2**20)
try:
    run_pipeline(PipelineInputs(Path(sys.argv[1]), "obj"), JobOptions(stages=[]), Path(sys.argv[2]))
except SimcoreError as exc:
    print("CODE", exc.code, exc)
import numpy
big = numpy.ones(2**20)  # the process lives on, and can allocate again once the job's memory is gone
print("ALIVE", big.sum())
"""


def test_an_allocation_past_the_worker_memory_cap_fails_the_job_with_out_of_memory_and_the_process_lives(tmp_path):
    sphere = trimesh.creation.icosphere(subdivisions=6)  # 41k vertices: ingest needs well over the 24 MB left
    obj = tmp_path / "sphere.obj"
    obj.write_text(sphere.export(file_type="obj"))
    small = tmp_path / "small.obj"
    small.write_text(trimesh.creation.icosphere(subdivisions=1).export(file_type="obj"))
    out = subprocess.run([sys.executable, "-c", OOM_CHILD, str(obj), str(tmp_path / "out"), str(small)], cwd=REPO,
                         capture_output=True, text=True, timeout=120)
    assert "CODE out_of_memory" in out.stdout, out.stdout + out.stderr[-2000:]
    assert "RIGFORGE_BUDGETS__WORKER_MEMORY_MB" in out.stdout and "ALIVE 1048576.0" in out.stdout, out.stdout

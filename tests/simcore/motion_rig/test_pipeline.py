"""A mesh-sequence upload through the job pipeline: from_motion chosen on its own, valid animated exports."""

import json

import pytest

from simcore.errors import InvalidInput
from simcore.evaluation.motion_sequences import tube_sequence
from simcore.options import JobOptions
from simcore.pipeline import PipelineInputs, run_pipeline
from tests.simcore.motion_rig.test_upload import frames_zip


def test_sequence_upload_is_rigged_from_its_motion(tmp_path):
    tube = tube_sequence(8, 8, 2, 10, seed=2)
    upload = tmp_path / "frames.zip"
    upload.write_bytes(frames_zip(tube.frames, tube.faces))
    stages: list[str] = []
    state = run_pipeline(PipelineInputs(upload, "zip"), JobOptions(up_axis="y", units="m", sequence_bones=4),
                         tmp_path / "out", on_progress=lambda stage, fraction: stages.append(stage))
    assert stages[0] == "ingest" and "skin" not in stages and "motion" not in stages and stages[-1] == "done"
    assert {"rigged.glb", "animated.glb", "animated.usdc", "skeleton.json", "report.json"} <= set(state.artifacts)
    report = json.loads((tmp_path / "out" / "report.json").read_text())
    assert report["skeleton"]["method"] == "from_motion" and state.skeleton is not None
    assert report["motion_rig"]["bones"] == state.skeleton.num_joints == 4  # sequence_bones given: that many bones
    assert len(report["motion_rig"]["rmse_per_frame"]) == len(tube.frames)
    assert report["motion"]["clip"]["frames"] == len(tube.frames)
    for name in ("rigged.glb", "animated.glb"):
        if "skipped" not in report["validation"][name]:
            assert report["validation"][name]["errors"] == 0
    assert (state.skeleton.parents < 0).sum() == 1


def test_a_one_frame_sequence_fails_with_a_clear_code(tmp_path):
    tube = tube_sequence(6, 6, 2, 2)
    upload = tmp_path / "one.zip"
    upload.write_bytes(frames_zip(tube.frames[:1], tube.faces))
    with pytest.raises(InvalidInput) as err:
        run_pipeline(PipelineInputs(upload, "zip"), JobOptions(skeleton="from_motion"), tmp_path / "out")
    assert err.value.code == "sequence_too_short" and err.value.field == "mesh"


@pytest.mark.parametrize(("asked", "bones"), [({}, None), ({"max_joints": 64}, None), ({"max_joints": 4}, None),
                                              ({"sequence_bones": 64}, 64), ({"sequence_bones": 4}, 4)])
def test_the_bone_count_survives_the_options_round_trip_a_job_makes(asked: dict, bones: int | None):
    """A job's options are stored with every default filled in (the API's model_dump) and read back by the worker:
    `sequence_bones` fixes the count (64 too), `max_joints` only caps the chosen one."""
    from simcore.motion_rig.stage import params_for

    stored = JobOptions(**asked).model_dump(mode="json")
    params = params_for(JobOptions.model_validate(stored))
    assert params.bones == bones and params.max_bones == (JobOptions(**asked).max_joints if bones is None else bones)


def test_more_sequence_bones_than_max_joints_names_the_field():
    from pydantic import ValidationError

    with pytest.raises(ValidationError) as err:
        JobOptions(max_joints=16, sequence_bones=32)
    assert err.value.errors()[0]["loc"] == ("sequence_bones",) and "max_joints" in err.value.errors()[0]["msg"]

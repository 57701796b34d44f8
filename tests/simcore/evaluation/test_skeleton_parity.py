"""Jobs and `rigforge eval skeleton` give identical skeletons: the eval runs the job's ingest and prediction."""

from __future__ import annotations

import json
import shutil

import numpy as np
import pytest

from simcore.evaluation.skeleton_ablation import ALL_OFF, ALL_ON, ablate_directory
from simcore.evaluation.skeleton_eval import evaluate_directory, job_prediction, load_case
from simcore.options import JobOptions
from simcore.pipeline import PipelineInputs, run_pipeline
from simcore.skeleton.geometric_rules import RULES
from simcore.skeleton.types import Skeleton


@pytest.mark.parametrize(("name", "method"), [
    ("rigged_simple.glb", "geometric"), ("cesium_man.glb", "geometric"), ("soldier.glb", "humanoid"),
    ("fox.glb", "auto"),
])
def test_a_job_and_the_eval_give_the_same_skeleton(dev_assets, tmp_path, name, method):
    path = dev_assets / name
    state = run_pipeline(PipelineInputs(path, path.suffix.lstrip(".")), JobOptions(skeleton=method, stages=["skeleton"]),
                         tmp_path / "job")
    job = Skeleton.from_dict(json.loads((tmp_path / "job" / "skeleton.json").read_text()))
    prediction = job_prediction(load_case(path), method)
    assert prediction.method == state.report["skeleton"]["method"]
    assert prediction.skeleton.num_joints == job.num_joints
    np.testing.assert_array_equal(prediction.skeleton.parents, job.parents)
    np.testing.assert_allclose(prediction.skeleton.positions, job.positions, atol=1e-6)  # skeleton.json rounds


def test_the_eval_row_counts_the_jobs_joints(dev_assets, tmp_path):
    shutil.copy(dev_assets / "cesium_man.glb", tmp_path / "cesium_man.glb")
    row = evaluate_directory(tmp_path, "geometric").to_dict()["assets"][0]
    job = job_prediction(load_case(tmp_path / "cesium_man.glb"), "geometric")
    assert row["joints_pred"] == job.skeleton.num_joints and row["j2j"] > 0


def test_ablation_turns_each_rule_off_and_lists_a_bad_file(dev_assets, tmp_path):
    shutil.copy(dev_assets / "rigged_simple.glb", tmp_path / "rigged_simple.glb")
    (tmp_path / "broken.glb").write_bytes(b"glTF not really")
    ablation = ablate_directory(tmp_path)
    table = ablation.table()
    assert [row["variant"] for row in table] == [ALL_ON, *(f"-{name}" for name in RULES), ALL_OFF]
    assert table[0]["d_j2j"] == 0 and all(row["assets"] == 1 for row in table)
    assert "broken" in ablation.skipped

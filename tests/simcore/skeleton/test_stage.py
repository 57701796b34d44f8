"""Pipeline stage `skeleton`: skeleton.json, state, report, keep mode, progress."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
import scipy.sparse as sp

from simcore.errors import InvalidInput
from simcore.geometry.capsule_creatures import quadruped
from simcore.geometry.mesh import IngestedMesh
from simcore.io.gltf_rig import RiggedAsset
from simcore.options import JobOptions
from simcore.pipeline import PipelineInputs, PipelineState, StageProgress
from simcore.skeleton import stage
from simcore.skeleton.types import Skeleton


def make_state(tmp_path: Path, with_rig: bool = False, **options) -> tuple[PipelineState, list[float]]:
    vertices, faces, truth = quadruped()
    rig = None
    if with_rig:
        weights = sp.csr_matrix((np.ones(len(vertices)), (np.arange(len(vertices)), np.zeros(len(vertices), int))),
                                shape=(len(vertices), truth.num_joints))
        rig = RiggedAsset(vertices, faces, truth, weights, np.arange(truth.num_joints), np.tile(np.eye(4), (truth.num_joints, 1, 1)))
    state = PipelineState(PipelineInputs(tmp_path / "in.glb", "glb"), JobOptions(**options), tmp_path)
    state.mesh = IngestedMesh(vertices, faces, b"", source_rig=rig)
    seen: list[float] = []
    return state, seen


def progress_into(seen: list[float]) -> StageProgress:
    return StageProgress("skeleton", 0.2, 0.2, lambda name, fraction: seen.append(fraction), lambda: None)


def test_geometric_stage_writes_skeleton_json_and_sets_state(tmp_path):
    state, seen = make_state(tmp_path, skeleton="geometric", max_joints=20)
    stage.run(state, progress_into(seen))
    doc = json.loads((tmp_path / "skeleton.json").read_text())
    skeleton = Skeleton.from_dict(doc)
    assert doc["method"] == "geometric" and skeleton.num_joints <= 20
    assert state.skeleton is not None
    np.testing.assert_allclose(skeleton.positions, state.skeleton.positions, atol=1e-6)
    assert state.artifacts["skeleton.json"] == tmp_path / "skeleton.json"
    assert state.report["skeleton"]["joints"] == skeleton.num_joints
    assert seen[-1] == pytest.approx(0.4) and seen == sorted(seen)
    assert doc["tokens"] is not None and doc["tokens"]["ids"][0] != doc["tokens"]["ids"][-1]


def test_keep_uses_the_uploads_own_skeleton(tmp_path):
    state, seen = make_state(tmp_path, with_rig=True, skeleton="keep")
    stage.run(state, progress_into(seen))
    assert state.skeleton is not None and state.mesh is not None and state.mesh.source_rig is not None
    assert state.skeleton.names == state.mesh.source_rig.skeleton.names
    assert json.loads((tmp_path / "skeleton.json").read_text())["method"] == "keep"


def test_keep_without_a_skin_is_a_clear_error(tmp_path):
    state, seen = make_state(tmp_path, skeleton="keep")
    with pytest.raises(InvalidInput) as err:
        stage.run(state, progress_into(seen))
    assert err.value.code == "no_skeleton" and err.value.field == "options.skeleton"

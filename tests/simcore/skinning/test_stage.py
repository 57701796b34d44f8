"""Pipeline stage `skin`: state.weights, report["skinning"], progress."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from simcore.errors import InvalidInput
from simcore.geometry.capsule_creatures import quadruped
from simcore.geometry.mesh import IngestedMesh
from simcore.options import JobOptions
from simcore.pipeline import PipelineInputs, PipelineState, StageProgress, _stages
from simcore.skeleton.types import Skeleton
from simcore.skinning import stage


def test_skin_stage_sets_weights_and_reports_scores(tmp_path: Path) -> None:
    vertices, faces, skeleton = quadruped()
    state = PipelineState(PipelineInputs(tmp_path / "in.glb", "glb"), JobOptions(skinning="auto", max_influences=4), tmp_path)
    state.mesh = IngestedMesh(vertices, faces, b"")
    state.skeleton = skeleton
    seen: list[float] = []
    stage.run(state, StageProgress("skin", 0.4, 0.2, lambda name, f: seen.append(f), lambda: None))
    assert state.weights is not None and state.weights.shape == (len(vertices), skeleton.num_joints)
    np.testing.assert_allclose(np.asarray(state.weights.sum(axis=1)).ravel(), 1.0, atol=1e-5)
    report = state.report["skinning"]
    assert report["method"] == "learned" and set(report["scores"]) == {"learned"} and report["reason"].startswith("learned model")
    assert report["weights"]["unweighted_vertices"] == 0 and report["weights"]["max_influences"] <= 4
    assert report["mirror"] == {"axis": "z", "vertices": pytest.approx(1.0, abs=0.01), "joints": skeleton.num_joints}
    assert {"omega_orth", "kappa_log", "h_spec", "strain_mean", "score"} <= set(report["scores"]["learned"])
    assert seen[-1] == pytest.approx(0.6) and seen == sorted(seen)


def test_skin_stage_needs_a_skeleton(tmp_path: Path) -> None:
    vertices, faces, _ = quadruped()
    state = PipelineState(PipelineInputs(tmp_path / "in.glb", "glb"), JobOptions(), tmp_path)
    state.mesh = IngestedMesh(vertices, faces, b"")
    with pytest.raises(InvalidInput) as err:
        stage.run(state, StageProgress("skin", 0.0, 1.0, lambda n, f: None, lambda: None))
    assert err.value.code == "missing_stage_input"


def test_skin_runs_right_after_skeleton() -> None:
    names = [name for name, _, _ in _stages()]
    assert names.index("skin") == names.index("skeleton") + 1


def _ik_rig(tmp_path: Path, **options) -> tuple[PipelineState, int]:
    """The capsule quadruped's skeleton plus an IK target under the root, placed at the first foot."""
    vertices, faces, skeleton = quadruped()
    foot = int(np.argmin(skeleton.positions[:, 1]))
    rig = Skeleton(np.vstack([skeleton.positions, skeleton.positions[foot]]), np.append(skeleton.parents, 0),
                   [*skeleton.names, "Foot_IK"])
    state = PipelineState(PipelineInputs(tmp_path / "in.glb", "glb"), JobOptions(skinning="geodesic", **options), tmp_path)
    state.mesh = IngestedMesh(vertices, faces, b"")
    state.skeleton = rig
    return state, rig.num_joints - 1


def test_excluded_joints_get_no_weight_and_keep_their_column(tmp_path: Path) -> None:
    state, ik = _ik_rig(tmp_path)
    stage.run(state, StageProgress("skin", 0.0, 1.0, lambda n, f: None, lambda: None))
    assert state.weights is not None and state.weights[:, ik].sum() > 1.0  # left in, the IK target takes weight around the foot

    state, ik = _ik_rig(tmp_path, exclude_joints=["*_ik", "nothing*"])
    stage.run(state, StageProgress("skin", 0.0, 1.0, lambda n, f: None, lambda: None))
    assert state.weights is not None and state.weights.shape[1] == ik + 1 and state.weights[:, ik].sum() == 0.0
    np.testing.assert_allclose(np.asarray(state.weights.sum(axis=1)).ravel(), 1.0, atol=1e-5)
    assert state.report["skinning"]["excluded_joints"] == ["Foot_IK"]
    assert [w["message"] for w in state.report["warnings"]] == ["options.exclude_joints pattern 'nothing*' matches no joint"]


def test_the_root_cannot_be_excluded(tmp_path: Path) -> None:
    state, _ = _ik_rig(tmp_path, exclude_joints=["*"])
    with pytest.raises(InvalidInput) as err:
        stage.run(state, StageProgress("skin", 0.0, 1.0, lambda n, f: None, lambda: None))
    assert err.value.field == "options.exclude_joints"


def test_joints_the_kept_rig_never_weights_get_no_weight(tmp_path: Path) -> None:
    """With `skeleton: keep`, a joint the upload's own weights leave empty (its IK target) is a helper: no weight,
    its column kept, and the report names it; with a predicted skeleton nothing is left out."""
    import scipy.sparse as sp

    from simcore.io.gltf_rig import RiggedAsset

    state, ik = _ik_rig(tmp_path, skeleton="keep")
    assert state.mesh is not None and state.skeleton is not None
    nearest = np.argmin(np.linalg.norm(state.mesh.vertices[:, None] - state.skeleton.positions[None, :ik], axis=2), axis=1)
    own = sp.csr_matrix((np.ones(len(nearest)), (np.arange(len(nearest)), nearest)), shape=(len(nearest), ik + 1))
    state.mesh.source_rig = RiggedAsset(state.mesh.vertices, state.mesh.faces, state.skeleton, own,
                                        np.arange(ik + 1), np.tile(np.eye(4), (ik + 1, 1, 1)))
    stage.run(state, StageProgress("skin", 0.0, 1.0, lambda n, f: None, lambda: None))
    assert state.weights is not None and state.weights.shape[1] == ik + 1 and state.weights[:, ik].sum() == 0.0
    np.testing.assert_allclose(np.asarray(state.weights.sum(axis=1)).ravel(), 1.0, atol=1e-5)
    assert state.report["skinning"]["weightless_in_upload"] == ["Foot_IK"] and state.report["skinning"]["excluded_joints"] == []

    predicted, ik = _ik_rig(tmp_path)  # the same rig as a predicted skeleton: the IK target is a joint like any other
    assert predicted.mesh is not None
    predicted.mesh.source_rig = state.mesh.source_rig
    stage.run(predicted, StageProgress("skin", 0.0, 1.0, lambda n, f: None, lambda: None))
    assert predicted.weights is not None and predicted.weights[:, ik].sum() > 1.0
    assert predicted.report["skinning"]["weightless_in_upload"] == []


def test_a_kept_root_that_holds_weight_keeps_its_weight(dev_assets: Path, tmp_path: Path) -> None:
    """RiggedSimple's root is its first bone and bends the cylinder's lower half: kept, it keeps that half (an
    armature root would pass it to the second bone). A predicted or weightless root decides the same way."""
    from simcore.evaluation.motion_eval import job_rig

    state = job_rig(dev_assets / "rigged_simple.glb", tmp_path, JobOptions(skeleton="keep"))
    assert state.mesh is not None and state.weights is not None and state.mesh.source_rig is not None
    lower = state.mesh.vertices[:, 1] < state.mesh.vertices[:, 1].min() + 1e-3
    assert lower.sum() >= 32 and state.weights[lower, 0].toarray().min() > 0.9
    l1 = np.abs(state.weights.toarray() - state.mesh.source_rig.weights.toarray()).sum(axis=1).mean()
    assert l1 < 0.3  # 1.01 when the root was taken for an armature root

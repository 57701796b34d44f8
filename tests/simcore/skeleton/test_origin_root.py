"""A predicted skeleton hangs from a helper root at the file's origin (`options.root_joint`), which takes no weight."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from simcore.gate.measures import skeleton_figures
from simcore.geometry.capsule_creatures import quadruped
from simcore.geometry.mesh import IngestedMesh
from simcore.options import JobOptions
from simcore.pipeline import PipelineInputs, PipelineState, StageProgress
from simcore.skeleton import stage as skeleton_stage
from simcore.skeleton.origin_root import origin_root
from simcore.skeleton.types import JointKind, Skeleton
from simcore.skinning import stage as skin_stage

BOX = np.array([[x, y, z] for x in (-0.2, 0.2) for y in (1.0, 2.0) for z in (-0.2, 0.2)])  # hovers above the origin
CHAIN = Skeleton(np.array([[0.0, 1.2, 0.0], [0.0, 1.5, 0.0], [0.0, 1.8, 0.0]]), np.array([-1, 0, 1]),
                 ["root", "spine", "head"])


def test_a_root_is_added_at_the_origin_under_a_hovering_model():
    rooted, why = origin_root(CHAIN, BOX, max_joints=64)
    assert why == "added at the file's origin" and rooted.num_joints == 4
    np.testing.assert_array_equal(rooted.positions[0], 0.0)
    np.testing.assert_array_equal(rooted.parents, [-1, 0, 1, 2])
    assert rooted.kinds[0] == JointKind.HELPER and rooted.kinds[1:] == CHAIN.kinds
    assert rooted.names == ["origin_root", "root", "spine", "head"]  # "root" was taken
    rooted.validate()


@pytest.mark.parametrize(("shift", "max_joints", "why"), [
    (np.array([0.0, 5.0, 0.0]), 64, "the file's origin lies far from the model"),  # 3 model sizes above the origin
    (np.zeros(3), 3, "max_joints leaves no room"),
    (np.array([0.0, -1.2, 0.0]), 64, "a joint lies at the file's origin already"),
])
def test_no_root_is_added_far_away_past_the_joint_cap_or_over_a_joint(shift, max_joints, why):
    chain = Skeleton(CHAIN.positions + shift, CHAIN.parents, CHAIN.names)
    same, said = origin_root(chain, BOX + shift, max_joints=max_joints)
    assert same is chain and said == why


def _state(tmp_path: Path, **options) -> PipelineState:
    vertices, faces, _ = quadruped()  # stands on y = 0 around the origin
    state = PipelineState(PipelineInputs(tmp_path / "in.glb", "glb"), JobOptions(**{"skeleton": "geometric", **options}), tmp_path)
    state.mesh = IngestedMesh(vertices, faces, b"")
    return state


def _run(state: PipelineState) -> None:
    skeleton_stage.run(state, StageProgress("skeleton", 0.0, 0.5, lambda n, f: None, lambda: None))
    skin_stage.run(state, StageProgress("skin", 0.5, 0.5, lambda n, f: None, lambda: None))


def test_a_job_hangs_its_skeleton_from_the_origin_and_skins_nothing_to_it(tmp_path):
    state = _state(tmp_path)
    _run(state)
    assert state.skeleton is not None and state.weights is not None
    assert state.skeleton.kinds[0] == JointKind.HELPER and np.allclose(state.skeleton.positions[0], 0.0)
    assert state.report["skeleton"]["origin_root"] == {"added": True, "reason": "added at the file's origin"}
    assert state.weights[:, 0].nnz == 0
    np.testing.assert_allclose(np.asarray(state.weights.sum(axis=1)).ravel(), 1.0, atol=1e-5)


def test_root_joint_none_keeps_the_body_root_and_the_body_is_skinned_alike_either_way(tmp_path):
    for sub in ("none", "origin"):
        (tmp_path / sub).mkdir()
    state = _state(tmp_path / "none", root_joint="none")
    _run(state)
    assert state.skeleton is not None and JointKind.HELPER not in state.skeleton.kinds
    assert "origin_root" not in state.report["skeleton"]
    rooted = _state(tmp_path / "origin")
    _run(rooted)
    assert rooted.weights is not None and state.weights is not None
    np.testing.assert_array_equal(rooted.weights[:, 1:].toarray(), state.weights.toarray())


def test_the_gate_counts_only_body_joints_inside(tmp_path):
    state = _state(tmp_path, skeleton="geometric", max_joints=12)
    _run(state)
    assert state.skeleton is not None and state.mesh is not None
    body = Skeleton(state.skeleton.positions[1:], np.maximum(state.skeleton.parents[1:] - 1, -1), state.skeleton.names[1:])
    helper_outside = Skeleton(np.vstack([[0.0, -2.0, 0.0], body.positions]), state.skeleton.parents,
                              state.skeleton.names, state.skeleton.kinds)
    plain = skeleton_figures(body, state.mesh.vertices, state.mesh.faces)["joints_inside"]
    assert skeleton_figures(helper_outside, state.mesh.vertices, state.mesh.faces)["joints_inside"] == plain
    free = Skeleton(helper_outside.positions, helper_outside.parents, helper_outside.names)  # the same joint, not a helper
    assert skeleton_figures(free, state.mesh.vertices, state.mesh.faces)["joints_inside"] < plain


def test_re_skinning_the_jobs_skeleton_json_gives_the_jobs_weights(tmp_path):
    """The dashboard's re-skin keeps the job's skeleton.json (with its helper root): the body is skinned as the job
    skinned it, its own root bending the mesh, not read as an armature root."""
    for sub in ("job", "again"):
        (tmp_path / sub).mkdir()
    job = _state(tmp_path / "job")
    _run(job)
    again = PipelineState(PipelineInputs(tmp_path / "in.glb", "glb", skeleton_path=tmp_path / "job" / "skeleton.json"),
                          JobOptions(skeleton="keep"), tmp_path / "again")
    again.mesh = job.mesh
    _run(again)
    assert again.skeleton is not None and again.skeleton.kinds[0] == JointKind.HELPER
    assert job.weights is not None and again.weights is not None
    np.testing.assert_allclose(again.weights.toarray(), job.weights.toarray(), atol=1e-4)  # skeleton.json rounds to 1e-6 m


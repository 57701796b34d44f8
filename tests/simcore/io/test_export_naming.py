"""Naming is applied once, at export: GLB, USD, skeleton.json and the animation agree; keep mode keeps names."""

from __future__ import annotations

import json

import numpy as np
import pytest

from simcore import export_stage
from simcore.geometry.mesh import IngestedMesh
from simcore.io.gltf_document import GltfDocument
from simcore.io.gltf_rig import read_rigged_asset
from simcore.options import JobOptions
from simcore.pipeline import PipelineInputs, PipelineState, StageProgress
from tests.simcore.io.rig_export_fixtures import bend_animation, capsule_glb, chain_skeleton, falloff_weights


def _run(tmp_path, **options) -> PipelineState:
    glb, mesh = capsule_glb()
    skeleton = chain_skeleton(4)
    state = PipelineState(PipelineInputs(tmp_path / "in.glb", "glb"), JobOptions(**options), tmp_path)
    state.mesh = IngestedMesh(np.asarray(mesh.vertices), np.asarray(mesh.faces), glb)
    state.skeleton, state.weights = skeleton, falloff_weights(mesh.vertices, skeleton, keep=3)
    state.animation = bend_animation(skeleton, frames=4)
    path = tmp_path / "skeleton.json"
    path.write_text(json.dumps({"method": "geometric", **skeleton.to_dict()}))
    state.artifacts["skeleton.json"] = path
    export_stage.run(state, StageProgress("export", 0.0, 1.0, lambda *a: None, lambda: None))
    return state


def _glb_names(state: PipelineState, name: str) -> list[str]:
    return read_rigged_asset(GltfDocument.from_bytes(state.artifacts[name].read_bytes())).skeleton.names


@pytest.mark.parametrize("options", [{}, {"naming": "unreal"}, {"skeleton": "keep", "naming": "generic"}])
def test_every_output_carries_the_descriptive_names(tmp_path, options):
    from pxr import Usd, UsdSkel

    state = _run(tmp_path, **options)
    expected = ["root", "spine_01", "spine_02", "head"]
    assert state.skeleton is not None and state.animation is not None
    assert state.skeleton.names == expected and state.animation.joint_names == expected
    assert _glb_names(state, "rigged.glb") == expected and _glb_names(state, "animated.glb") == expected
    assert json.loads(state.artifacts["skeleton.json"].read_text())["names"] == expected
    stage = Usd.Stage.Open(str(state.artifacts["animated.usdc"]))
    skel = UsdSkel.Skeleton(stage.GetPrimAtPath("/Character/Skeleton"))
    assert list(skel.GetJointNamesAttr().Get()) == expected
    assert state.report["naming"]["renamed"] == 4


def test_keep_mode_keeps_the_uploads_names(tmp_path):
    state = _run(tmp_path, skeleton="keep")
    assert state.skeleton is not None
    assert state.skeleton.names == ["joint_0", "joint_1", "joint_2", "joint_3"]
    assert _glb_names(state, "rigged.glb") == state.skeleton.names
    assert state.report["naming"]["preset"] is None

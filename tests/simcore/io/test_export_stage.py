"""The export stage: every output written, validated, registered; validator errors fail the job."""

from __future__ import annotations

import numpy as np
import pytest

from simcore import export_stage
from simcore.geometry.mesh import IngestedMesh
from simcore.io import fbx_export, gltf_validate
from simcore.options import JobOptions
from simcore.pipeline import PipelineInputs, PipelineState, StageProgress
from tests.simcore.io.rig_export_fixtures import bend_animation, capsule_glb, chain_skeleton, falloff_weights


def _state(tmp_path, animated: bool) -> PipelineState:
    glb, mesh = capsule_glb()
    skeleton = chain_skeleton(4)
    state = PipelineState(PipelineInputs(tmp_path / "in.glb", "glb"), JobOptions(), tmp_path)
    state.mesh = IngestedMesh(np.asarray(mesh.vertices), np.asarray(mesh.faces), glb)
    state.skeleton, state.weights = skeleton, falloff_weights(mesh.vertices, skeleton, keep=3)
    if animated:
        state.animation = bend_animation(skeleton, frames=6)
        state.refined_frames = np.repeat(mesh.vertices[None].astype(np.float32), 6, axis=0)
    return state


def _progress(seen: list) -> StageProgress:
    return StageProgress("export", 0.0, 1.0, lambda name, f: seen.append(f), lambda: None)


def test_stage_writes_and_validates_every_output(tmp_path):
    state = _state(tmp_path, animated=True)
    seen: list[float] = []
    export_stage.run(state, _progress(seen))
    names = {"rigged.glb", "rigged.usdc", "rigged.usdz", "animated.glb", "animated.usdc", "animated.usdz",
             "refined.glb", "refined.usdc"}
    assert names | {"texture_0.png"} <= set(state.artifacts) and all(state.artifacts[n].is_file() for n in names)
    assert set(state.report["validation"]) == names
    assert all(v["errors"] == 0 for v in state.report["validation"].values()), state.report["validation"]
    assert state.weights is not None and state.report["weights"]["vertices"] == state.weights.shape[0]
    assert state.report["export"]["refined.glb"]["morph"]["keys"] == 6
    assert seen[-1] == 1.0 and seen == sorted(seen)


def test_validator_error_fails_the_job(tmp_path, monkeypatch):
    state = _state(tmp_path, animated=False)
    broken = lambda paths: [gltf_validate.ValidationResult(str(p), 1, 0, messages=[{"code": "X"}]) for p in paths]  # noqa: E731
    monkeypatch.setattr(gltf_validate, "validate_gltf_files", broken)
    with pytest.raises(export_stage.ExportInvalid) as err:
        export_stage.run(state, _progress([]))
    assert err.value.code == "export_invalid"


def test_missing_validator_is_a_warning(tmp_path, monkeypatch):
    state = _state(tmp_path, animated=False)
    monkeypatch.setenv("RIGFORGE_GLTF_VALIDATOR", str(tmp_path / "nowhere"))
    export_stage.run(state, _progress([]))
    assert "skipped" in state.report["validation"]["rigged.glb"]
    assert any("not validated" in w["message"] for w in state.report["warnings"])
    assert state.report["validation"]["rigged.usdc"]["errors"] == 0


def test_stage_without_weights_skips_with_a_warning(tmp_path):
    state = _state(tmp_path, animated=False)
    state.weights = None
    export_stage.run(state, _progress([]))
    assert not state.artifacts and state.report["warnings"]


def test_fbx_without_a_writer_is_a_warning(tmp_path, monkeypatch):
    monkeypatch.setattr(fbx_export, "blender_python", lambda: None)
    state = _state(tmp_path, animated=False)
    state.options = JobOptions(fbx=True)
    export_stage.run(state, _progress([]))
    assert not any(name.endswith(".fbx") for name in state.artifacts)
    assert any(w["code"] == "fbx_unavailable" for w in state.report["warnings"])


@pytest.mark.skipif(fbx_export.blender_python() is None,
                    reason="FBX writer not installed: no bpy (`make fbx-writer` or RIGFORGE_BLENDER_PYTHON)")
def test_fbx_files_join_the_artifacts(tmp_path):
    state = _state(tmp_path, animated=True)
    state.options = JobOptions(fbx=True)
    export_stage.run(state, _progress([]))
    for name in ("rigged.fbx", "animated.fbx"):
        assert state.artifacts[name].read_bytes().startswith(b"Kaydara FBX Binary")
        assert state.report["export"][name]["seconds"] > 0

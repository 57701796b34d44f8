"""A skinned upload saved in another pose than its bind pose is rigged in its bind pose."""

from __future__ import annotations

import base64

import numpy as np
import pytest

from simcore.ingest import ingest
from simcore.io.gltf_document import GltfDocument
from simcore.io.gltf_rig import read_rigged_asset
from tests.simcore.io.studio_rig_fixtures import studio_rig, to_glb

ORDER = ["hips", "spine", "head", "sword"]
BEND = [0.0, 0.0, np.sin(np.pi / 6), np.cos(np.pi / 6)]  # 60° about z: the spine's rest pose bends the body


def _posed(doc: dict) -> dict:
    """The rig with its spine node's rest rotation bent: viewers show it bent, its vertices stay straight."""
    spine = next(n for n in doc["nodes"] if n.get("name") == "spine")
    spine["rotation"] = BEND
    return doc


def _stored_positions(doc: dict) -> np.ndarray:
    """(V, 3) the POSITION accessor as stored: the bind pose (its inverse bind matrices have no rotation)."""
    blob = base64.b64decode(doc["buffers"][0]["uri"].split(",", 1)[1])
    view = doc["bufferViews"][doc["accessors"][0]["bufferView"]]
    return np.frombuffer(blob[view["byteOffset"]: view["byteOffset"] + view["byteLength"]], np.float32).reshape(-1, 3)


def test_a_posed_file_is_ingested_in_its_bind_pose_with_its_bind_skeleton() -> None:
    doc = _posed(studio_rig(ORDER))
    mesh = ingest(to_glb(doc), "glb")
    np.testing.assert_allclose(mesh.vertices, _stored_positions(doc), atol=1e-5)
    rig = mesh.source_rig
    assert rig is not None
    heads = dict(zip(rig.skeleton.names, rig.skeleton.positions, strict=True))
    np.testing.assert_allclose(heads["head"], [0.0, 1.2, 0.0], atol=1e-6)  # straight above the spine, not bent
    np.testing.assert_allclose(heads["sword"], [0.35, 0.8, 0.0], atol=1e-6)
    rotations = rig.skeleton.orientations
    assert rotations is not None
    np.testing.assert_allclose(np.abs(rotations[:, 3]), 1.0, atol=1e-6)  # bind joint frames: no bend in them


def test_the_source_skin_still_matches_every_vertex_of_a_posed_file() -> None:
    doc = _posed(studio_rig(ORDER))
    mesh = ingest(to_glb(doc), "glb")
    rig = mesh.source_rig
    assert rig is not None
    assert np.diff(rig.weights.indptr).min() > 0  # each vertex found its skinned vertex at the bind pose
    stored = read_rigged_asset(GltfDocument.from_bytes(to_glb(doc)))
    np.testing.assert_allclose(rig.weights.toarray(), stored.weights.toarray(), atol=1e-6)


def test_a_file_at_its_bind_pose_ingests_as_before() -> None:
    doc = studio_rig(ORDER)
    mesh = ingest(to_glb(doc), "glb")
    np.testing.assert_allclose(mesh.vertices, _stored_positions(doc), atol=1e-5)


def test_a_mesh_parented_under_a_joint_follows_that_joint_to_its_bind_pose() -> None:
    doc = _posed(studio_rig(ORDER))
    head = next(k for k, n in enumerate(doc["nodes"]) if n.get("name") == "head")
    doc["nodes"].append({"name": "hat", "mesh": 0, "translation": [0.0, 0.1, 0.0]})  # unskinned: rides the head
    doc["nodes"][head].setdefault("children", []).append(len(doc["nodes"]) - 1)
    mesh = ingest(to_glb(doc), "glb")
    stored = _stored_positions(doc)
    hat = mesh.vertices[len(stored):]
    np.testing.assert_allclose(hat, stored + [0.0, 1.3, 0.0], atol=1e-5)  # above the straight head, not the bent one


def test_a_posed_file_playing_its_own_clip_animates_as_the_same_file_saved_at_its_bind_pose(tmp_path) -> None:
    from simcore.options import JobOptions, MotionOptions
    from simcore.pipeline import PipelineInputs, run_pipeline

    options = JobOptions(stages=["skeleton", "skin", "motion"], motion=MotionOptions(clip=0), quality_gate="warn")
    figures = []
    for name, doc in (("bind", studio_rig(ORDER, animated=True)), ("posed", _posed(studio_rig(ORDER, animated=True)))):
        path = tmp_path / f"{name}.glb"
        path.write_bytes(to_glb(doc))
        state = run_pipeline(PipelineInputs(path, "glb"), options, tmp_path / name)
        figures.append({k: state.report["quality"]["motion"][k] for k in ("stretch_low", "stretch_high")})
    assert figures[0] == pytest.approx(figures[1], abs=1e-4)

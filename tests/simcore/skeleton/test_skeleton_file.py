"""An edited skeleton file next to the mesh: read in any joint order, checked, and re-skinned as given."""

from __future__ import annotations

import json

import numpy as np
import pytest

from simcore.errors import InvalidInput
from simcore.io.gltf_document import GltfDocument
from simcore.io.gltf_rig import read_rigged_asset
from simcore.options import JobOptions
from simcore.pipeline import PipelineInputs, run_pipeline
from simcore.skeleton.skeleton_file import read_skeleton_file
from tests.simcore.io.rig_export_fixtures import capsule_glb, chain_skeleton

VERTICES = np.array([[-0.1, -0.5, -0.1], [0.1, 0.5, 0.1]])


def _edited() -> dict:
    """A three-joint chain listed child first, with the middle joint moved and renamed."""
    return {"names": ["tip", "base", "bend"], "parents": [2, -1, 1],
            "positions": [[0, 0.4, 0], [0, -0.4, 0], [0.03, 0.05, 0]]}


def test_joints_in_any_order_come_back_parents_first():
    skeleton = read_skeleton_file(json.dumps(_edited()).encode(), VERTICES)
    assert skeleton.names == ["base", "bend", "tip"] and skeleton.parents.tolist() == [-1, 0, 1]
    np.testing.assert_allclose(skeleton.positions[1], [0.03, 0.05, 0])


def test_kinds_follow_their_joints_into_parents_first_order():
    doc = {**_edited(), "kinds": ["free", "helper", "spring"]}
    skeleton = read_skeleton_file(json.dumps(doc).encode(), VERTICES)
    assert [k.value for k in skeleton.kinds] == ["helper", "spring", "free"]  # base, bend, tip


@pytest.mark.parametrize(("edit", "words"), [
    (lambda d: d.update(parents=[2, -1, 0]), "cycle"),
    (lambda d: d.update(parents=[-1, -1, 1]), "exactly one root"),
    (lambda d: d["positions"].__setitem__(0, [0, float("nan"), 0]), "non-finite"),
    (lambda d: d.update(names=["a", "a", "b"]), "unique"),
    (lambda d: d.update(names=[f"j{k}" for k in range(300)]), "1 to 256"),
    (lambda d: d["positions"].__setitem__(0, [0, 9.0, 0]), "far outside"),
    (lambda d: d.update(orientations=[[0, 0, 0, 2]] * 3), "unit quaternions"),
    (lambda d: d.update(kinds=["free", "bogus", "free"]), "'kinds' must list"),
    (lambda d: d.update(kinds=["free"]), "'kinds' must list"),
])
def test_broken_files_are_refused_by_what_is_wrong(edit, words):
    doc = _edited()
    edit(doc)
    with pytest.raises(InvalidInput) as err:
        read_skeleton_file(json.dumps(doc).encode(), VERTICES)
    assert err.value.code == "invalid_skeleton" and err.value.field == "skeleton" and words in str(err.value)


def test_a_job_with_an_edited_skeleton_rigs_with_it(tmp_path):
    glb, _ = capsule_glb()
    (tmp_path / "in.glb").write_bytes(glb)
    edited = chain_skeleton(4).to_dict()
    edited["positions"][2][0] = 0.04  # a joint moved in the editor
    edited["names"][2] = "knee"  # and renamed
    (tmp_path / "edited.json").write_text(json.dumps(edited))
    inputs = PipelineInputs(tmp_path / "in.glb", "glb", skeleton_path=tmp_path / "edited.json")
    state = run_pipeline(inputs, JobOptions(skeleton="keep", stages=["skeleton", "skin", "export"]), tmp_path / "out")
    assert state.report["skeleton"]["method"] == "given"
    rig = read_rigged_asset(GltfDocument.from_bytes(state.artifacts["rigged.glb"].read_bytes()))
    assert rig.skeleton.names == edited["names"]
    np.testing.assert_allclose(rig.skeleton.positions, edited["positions"], atol=1e-5)
    assert rig.weights[:, 2].max() > 0.25  # the moved joint is skinned


def test_a_skeleton_file_needs_keep(tmp_path):
    glb, _ = capsule_glb()
    (tmp_path / "in.glb").write_bytes(glb)
    (tmp_path / "edited.json").write_text(json.dumps(chain_skeleton(3).to_dict()))
    inputs = PipelineInputs(tmp_path / "in.glb", "glb", skeleton_path=tmp_path / "edited.json")
    with pytest.raises(InvalidInput) as err:
        run_pipeline(inputs, JobOptions(stages=["skeleton"]), tmp_path / "out")
    assert err.value.field == "options.skeleton"

"""Materials whose images point at files beside the upload: the images are dropped unread, the mesh goes through,
and the job's report says so (issue 25)."""

from __future__ import annotations

import builtins
from typing import Any

import pytest

from simcore.io.gltf_document import GltfDocument
from simcore.io.gltf_images import drop_external_images
from simcore.options import JobOptions
from simcore.pipeline import PipelineInputs, run_pipeline
from tests.simcore.io.studio_rig_fixtures import studio_rig, to_glb

PNG_DATA = "data:image/png;base64,iVBORw0KGgo="


def test_dropping_an_image_renumbers_textures_and_clears_the_slots_that_used_it():
    gltf: dict[str, Any] = {
        "images": [{"uri": "guard1_body.png"}, {"uri": PNG_DATA}, {"uri": "C:/work/turtle1.png"}],
        "textures": [{"source": 0}, {"source": 1, "sampler": 0},
                     {"source": 2, "extensions": {"EXT_texture_webp": {"source": 1}}}],
        "materials": [{"pbrMetallicRoughness": {"baseColorTexture": {"index": 0}, "metallicRoughnessTexture": {"index": 2}},
                       "normalTexture": {"index": 1, "scale": 0.5}}],
    }
    assert drop_external_images(gltf) == ["guard1_body.png", "C:/work/turtle1.png"]
    assert gltf["images"] == [{"uri": PNG_DATA}]
    assert gltf["textures"] == [{"source": 0, "sampler": 0}, {"extensions": {"EXT_texture_webp": {"source": 0}}}]
    assert gltf["materials"][0] == {"pbrMetallicRoughness": {"metallicRoughnessTexture": {"index": 1}},
                                    "normalTexture": {"index": 0, "scale": 0.5}}


def test_external_images_are_never_opened(monkeypatch):
    data = to_glb(studio_rig(["hips", "spine", "head"], image_uri="C:/work/guard1_body.png"))

    def refuse(*args, **kwargs):
        raise AssertionError(f"opened {args[:1]}")

    monkeypatch.setattr(builtins, "open", refuse)
    doc = GltfDocument.from_bytes(data)
    assert doc.dropped_images == ["C:/work/guard1_body.png"]
    assert "images" not in doc.json and "baseColorTexture" not in doc.json["materials"][0]["pbrMetallicRoughness"]


@pytest.mark.parametrize("skeleton", ["auto", "keep"])
def test_a_rig_with_external_textures_is_rigged_with_a_warning(tmp_path, skeleton):
    (tmp_path / "guard.glb").write_bytes(to_glb(studio_rig(["hips", "spine", "head"], image_uri="guard1_body.png")))
    state = run_pipeline(PipelineInputs(tmp_path / "guard.glb", "glb"), JobOptions(skeleton=skeleton), tmp_path / "out")
    warning = next(w for w in state.report["warnings"] if isinstance(w, dict) and w["code"] == "external_images_dropped")
    assert warning["stage"] == "ingest" and "guard1_body.png" in warning["message"]
    assert state.report["mesh"]["external_images_dropped"] == ["guard1_body.png"]
    rigged = GltfDocument.from_bytes(state.artifacts["rigged.glb"].read_bytes())
    assert "images" not in rigged.json and rigged.json["materials"]

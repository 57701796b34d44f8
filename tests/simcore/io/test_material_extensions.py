"""Material and texture extensions of an upload (Blender writes several) are kept and declared in the exports."""

from __future__ import annotations

from pathlib import Path

from simcore.io.gltf_document import GltfDocument
from simcore.options import JobOptions
from simcore.pipeline import PipelineInputs, run_pipeline
from tests.simcore.io.rig_export_fixtures import capsule_glb, glb_with_json


def _with_extensions(doc: dict) -> None:
    material = doc["materials"][0]
    material["extensions"] = {"KHR_materials_emissive_strength": {"emissiveStrength": 4.0}}
    material["emissiveFactor"] = [1.0, 0.5, 0.0]
    texture_info = material["pbrMetallicRoughness"]["baseColorTexture"]
    texture_info["extensions"] = {"KHR_texture_transform": {"scale": [2.0, 2.0]}}
    doc["extensionsUsed"] = ["KHR_materials_emissive_strength", "KHR_texture_transform", "KHR_lights_punctual"]


def test_an_upload_with_material_extensions_rigs_and_validates(tmp_path: Path) -> None:
    source = tmp_path / "capsule.glb"
    source.write_bytes(glb_with_json(capsule_glb()[0], _with_extensions))
    state = run_pipeline(PipelineInputs(source, "glb"), JobOptions(), tmp_path / "out")  # failed validation before
    rigged = GltfDocument.from_bytes(state.artifacts["rigged.glb"].read_bytes()).json
    # Declared exactly: what the kept materials use (the unused light extension is not carried).
    assert rigged["extensionsUsed"] == ["KHR_materials_emissive_strength", "KHR_texture_transform"]
    assert rigged["materials"][0]["extensions"]["KHR_materials_emissive_strength"]["emissiveStrength"] == 4.0

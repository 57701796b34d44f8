"""A glTF uploaded as a .zip (the .gltf, its .bin and its images): packed into one GLB with its textures, which
the rigged output keeps; archives that escape their root, are too big or hold no model are refused by code."""

from __future__ import annotations

import base64
import io
import json
import zipfile

import pytest

from simcore.errors import InvalidInput, LimitExceeded
from simcore.io import gltf_zip
from simcore.io.gltf_document import GltfDocument
from simcore.io.gltf_zip import glb_from_zip
from simcore.io.sniff import sniff
from simcore.options import JobOptions
from simcore.pipeline import PipelineInputs, run_pipeline
from tests.simcore.io.studio_rig_fixtures import png_bytes, studio_rig

IMAGE_NAME = "textures/guard 1.png"


def split_gltf(buffer_uri: str = "rig.bin", image_uri: str = "textures/guard%201.png") -> tuple[dict, bytes]:
    """(.gltf JSON whose buffer and image are files, the buffer's bytes)."""
    doc = studio_rig(["hips", "spine", "head"], image_uri=image_uri)
    blob = base64.b64decode(doc["buffers"][0]["uri"].split(",", 1)[1])
    doc["buffers"][0]["uri"] = buffer_uri
    return doc, blob


def make_zip(entries: dict[str, bytes]) -> bytes:
    out = io.BytesIO()
    with zipfile.ZipFile(out, "w", zipfile.ZIP_DEFLATED) as zf:
        for name, data in entries.items():
            zf.writestr(name, data)
    return out.getvalue()


def character_zip(**entries: bytes) -> bytes:
    doc, blob = split_gltf()
    return make_zip({"guard/guard.gltf": json.dumps(doc).encode(), "guard/rig.bin": blob,
                     f"guard/{IMAGE_NAME}": png_bytes(), **entries})


def test_a_zipped_gltf_becomes_one_glb_with_its_texture_inside():
    data = character_zip()
    assert sniff(data[:4096], len(data)) == "zip"
    doc = GltfDocument.from_bytes(glb_from_zip(data))
    assert doc.dropped_images == [] and "uri" not in doc.json["images"][0]
    assert doc.view_bytes(doc.json["images"][0]["bufferView"])[0] == png_bytes()
    assert doc.json["images"][0]["mimeType"] == "image/png"


@pytest.mark.parametrize("skeleton", ["auto", "keep"])
def test_the_rigged_glb_keeps_the_zipped_texture(tmp_path, skeleton):
    (tmp_path / "upload").write_bytes(character_zip())
    state = run_pipeline(PipelineInputs(tmp_path / "upload", "zip"), JobOptions(skeleton=skeleton), tmp_path / "out")
    rigged = GltfDocument.from_bytes(state.artifacts["rigged.glb"].read_bytes())
    texture = rigged.json["materials"][0]["pbrMetallicRoughness"]["baseColorTexture"]["index"]
    image = rigged.json["images"][rigged.json["textures"][texture]["source"]]
    assert rigged.view_bytes(image["bufferView"])[0] == png_bytes()
    assert not any(isinstance(w, dict) and w["code"] == "external_images_dropped" for w in state.report.get("warnings", []))


@pytest.mark.parametrize("image_uri", ["textures/guard%201.png", "sub/../../secret.png", "C:/work/x.png"])
def test_an_image_outside_the_zip_is_dropped_unread_like_any_external_image(image_uri):
    doc, blob = split_gltf(image_uri=image_uri)
    glb = glb_from_zip(make_zip({"a.gltf": json.dumps(doc).encode(), "rig.bin": blob}))
    assert GltfDocument.from_bytes(glb).dropped_images == [image_uri]


def _with_gltf(**kwargs) -> bytes:
    doc, blob = split_gltf(**kwargs)
    return make_zip({"a.gltf": json.dumps(doc).encode(), "rig.bin": blob, IMAGE_NAME: png_bytes()})


@pytest.mark.parametrize(("make", "code"), [
    (lambda: character_zip(**{"../evil.sh": b"x"}), "zip_unsafe_path"),  # zip-slip entry
    (lambda: character_zip(**{"/etc/cron.d/x": b"x"}), "zip_unsafe_path"),
    (lambda: character_zip(**{"..\\..\\evil.dll": b"x"}), "zip_unsafe_path"),
    (lambda: _with_gltf(buffer_uri="../../etc/passwd"), "zip_unsafe_path"),
    (lambda: _with_gltf(buffer_uri="C:/work/rig.bin"), "zip_unsafe_path"),
    (lambda: _with_gltf(buffer_uri="file:///etc/passwd"), "zip_unsafe_path"),
    (lambda: _with_gltf(buffer_uri="missing.bin"), "zip_missing_file"),
    (lambda: make_zip({"readme.txt": b"hello"}), "zip_no_gltf"),
    (lambda: make_zip({"a.gltf": b"{}", "b.gltf": b"{}"}), "zip_several_models"),
    (lambda: make_zip({"a.gltf": b"{not json"}), "invalid_gltf"),
    (lambda: b"PK\x03\x04" + bytes(200), "invalid_zip"),
], ids=["entry-dotdot", "entry-absolute", "entry-backslash", "uri-dotdot", "uri-drive", "uri-scheme",
        "missing-buffer", "no-model", "two-models", "bad-json", "not-a-zip"])
def test_bad_zips_are_refused_with_a_code(make, code):
    with pytest.raises(InvalidInput) as err:
        glb_from_zip(make())
    assert err.value.code == code and err.value.field == "mesh"


@pytest.mark.parametrize(("cap", "value", "code"), [("MAX_ENTRIES", 2, "zip_too_many_entries"),
                                                    ("MAX_UNPACKED_BYTES", 10_000, "zip_too_large")])
def test_zip_limits(monkeypatch, cap, value, code):
    monkeypatch.setattr(gltf_zip, cap, value)
    with pytest.raises(LimitExceeded) as err:
        glb_from_zip(character_zip())
    assert err.value.code == code

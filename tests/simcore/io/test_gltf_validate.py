"""The Khronos validator wrapper: runs through Node, reports errors, says clearly when it is missing.

These tests fail (never skip) when node_modules/gltf-validator is absent: CI runs `npm ci` first.
"""

from __future__ import annotations

import pytest

from simcore.io.gltf_validate import ValidatorUnavailable, validate_gltf_file, validate_gltf_files
from tests.simcore.io.rig_export_fixtures import capsule_glb, glb_with_json


def test_valid_file_has_no_errors(tmp_path):
    path = tmp_path / "mesh.glb"
    path.write_bytes(capsule_glb()[0])
    result = validate_gltf_file(path)
    assert result.ok and result.errors == 0
    assert result.validator.startswith("2.")


def test_broken_accessor_is_reported_as_error(tmp_path):
    glb = capsule_glb()[0]

    def break_count(doc):
        doc["accessors"][0]["count"] += 1000  # indices now run past their bufferView

    good, bad = tmp_path / "good.glb", tmp_path / "bad.glb"
    good.write_bytes(glb)
    bad.write_bytes(glb_with_json(glb, break_count))
    results = validate_gltf_files([good, bad])
    assert [r.ok for r in results] == [True, False]
    assert any(m["code"].startswith("ACCESSOR") or m["code"].startswith("BUFFER") for m in results[1].messages)


def test_garbage_is_one_error(tmp_path):
    path = tmp_path / "junk.glb"
    path.write_bytes(b"not a gltf at all")
    assert validate_gltf_file(path).errors >= 1


def test_missing_package_raises_a_clear_error(tmp_path, monkeypatch):
    monkeypatch.setenv("RIGFORGE_GLTF_VALIDATOR", str(tmp_path / "nowhere"))
    path = tmp_path / "mesh.glb"
    path.write_bytes(capsule_glb()[0])
    with pytest.raises(ValidatorUnavailable, match="npm ci"):
        validate_gltf_file(path)

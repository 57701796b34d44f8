"""Mesh-sequence uploads through the API: USD with time-sampled points and a .zip of per-frame OBJ files are
accepted (not mistaken for a zipped glTF) and rigged from their motion; a still USD fails with a clear code."""

from __future__ import annotations

import json

import pytest

from simcore.evaluation.motion_sequences import tube_sequence
from tests.api.test_bad_input import post
from tests.simcore.motion_rig.test_upload import frames_zip
from tests.simcore.motion_rig.test_usd_upload import usd_sequence

RIG_FROM_MOTION = json.dumps({"units": "m", "max_joints": 3})


@pytest.fixture(scope="module")
def tube():
    return tube_sequence(6, 6, 2, 8, seed=3)


def _rigged(client, auth, data: bytes, name: str, fmt: str) -> dict:
    r = post(client, auth, data, name, options=RIG_FROM_MOTION)
    assert r.status_code == 202, r.text
    job = client.get(f"/api/v1/jobs/{r.json()['id']}", headers=auth).json()
    assert job["status"] == "succeeded", job
    assert job["mesh"]["format"] == fmt
    names = {a["name"]: a for a in job["artifacts"]}
    assert {"rigged.glb", "animated.glb"} <= set(names)
    return client.get(names["report.json"]["url"], headers=auth).json()


@pytest.mark.parametrize("suffix", [".usdc", ".usda"])
def test_a_usd_sequence_is_accepted_and_rigged_from_its_motion(client, auth, tube, tmp_path, suffix):
    path = usd_sequence(tmp_path / f"tube{suffix}", tube.frames, tube.faces)
    report = _rigged(client, auth, path.read_bytes(), path.name, "usd")
    assert report["skeleton"]["method"] == "from_motion" and 1 < report["motion_rig"]["bones"] <= 3  # Dem Bones may fill fewer
    assert report["motion_rig"]["frames"] == len(tube.frames)


def test_a_zip_of_obj_frames_is_accepted_and_rigged_from_its_motion(client, auth, tube):
    report = _rigged(client, auth, frames_zip(tube.frames, tube.faces), "frames.zip", "zip")
    assert report["skeleton"]["method"] == "from_motion" and report["motion_rig"]["frames"] == len(tube.frames)


def test_a_still_usd_fails_with_no_mesh_sequence(client, auth, tube, tmp_path):
    path = usd_sequence(tmp_path / "still.usdc", tube.frames[:1], tube.faces)
    r = post(client, auth, path.read_bytes(), path.name, options=RIG_FROM_MOTION)
    assert r.status_code == 202, r.text
    job = client.get(f"/api/v1/jobs/{r.json()['id']}", headers=auth).json()
    assert job["status"] == "failed" and job["error"]["code"] == "no_mesh_sequence", job

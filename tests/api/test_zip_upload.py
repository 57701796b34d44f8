"""A glTF with its .bin and textures uploaded as one .zip: accepted and rigged; a .zip that escapes its root or
holds no model is a 4xx problem naming the mesh field (issue 25)."""

from __future__ import annotations

from tests.api.test_bad_input import assert_problem, post
from tests.simcore.io.test_gltf_zip import character_zip, make_zip


def test_a_zipped_gltf_is_accepted_and_ingested(client, auth):
    r = post(client, auth, character_zip(), "guard.zip")
    assert r.status_code == 202 and r.json()["status"] == "succeeded", r.text


def test_a_zip_slip_archive_is_refused(client, auth):
    assert_problem(post(client, auth, character_zip(**{"../../evil.sh": b"x"}), "guard.zip"), 422, "zip_unsafe_path", "mesh")


def test_a_zip_without_a_model_is_refused(client, auth):
    assert_problem(post(client, auth, make_zip({"notes.txt": b"hi"}), "notes.zip"), 422, "zip_no_gltf", "mesh")

"""The API checks at most `max_parallel_parses` glTF uploads at once; the next one gets 503 + Retry-After."""

from __future__ import annotations

from tests.hostile.gltf_cases import glb, rigged_base


def test_a_glTF_upload_finding_no_parse_slot_gets_503_with_retry_after(client, auth, monkeypatch):
    from api.jobs import uploads
    from api.settings import get_settings

    monkeypatch.setattr(uploads, "PARSE_WAIT_SECONDS", 0.05)
    slots = uploads._parse_slots(get_settings().max_parallel_parses)
    held = [slots.acquire(timeout=1) for _ in range(get_settings().max_parallel_parses)]  # busy parses elsewhere
    try:
        r = client.post("/api/v1/jobs", headers=auth, files={"mesh": ("t.glb", glb(*rigged_base()))}, data={"options": '{"stages": []}'})
    finally:
        for ok in held:
            if ok:
                slots.release()
    assert r.status_code == 503 and r.headers["retry-after"] == str(uploads.RETRY_AFTER_SECONDS)
    assert r.headers["content-type"] == "application/problem+json" and r.json()["code"] == "server_busy"
    again = client.post("/api/v1/jobs", headers=auth, files={"mesh": ("t.glb", glb(*rigged_base()))}, data={"options": '{"stages": []}'})
    assert again.status_code == 202, again.text

"""The hostile-input corpus (tests/hostile/corpus.py): every case ends as a 4xx problem+json or a failed job with
a specific code, or runs when the input is merely odd; never a 500, never internal_error.

File and options cases run the layer that decides them (the API's upload check, then ingest or the motion
reader) without a job; request cases and a sample of file cases go through the HTTP API with a real job.
"""

from __future__ import annotations

import pytest

from tests.api.conftest import INGEST_ONLY
from tests.hostile.case import OK, Case
from tests.hostile.corpus import all_cases
from tests.hostile.outcome import outcome

CASES = all_cases()
DIRECT = [c for c in CASES if c.kind != "request"]
REQUESTS = [c for c in CASES if c.kind == "request"]
THROUGH_API = REQUESTS + [c for c in DIRECT if c.kind in ("mesh", "motion")][::9]
MOTION_HOST = b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n"


def test_the_corpus_covers_every_input_kind():
    prefixes = {c.name.split("-")[0] for c in CASES}
    assert len(CASES) >= 300 and {"gltf", "glb", "obj", "ply", "stl", "bvh", "options", "request", "motion"} <= prefixes


@pytest.mark.parametrize("case", DIRECT, ids=[c.name for c in DIRECT])
def test_each_input_ends_with_its_expected_outcome(case: Case, tmp_path, monkeypatch):
    monkeypatch.setenv("RIGFORGE_DATA_DIR", str(tmp_path))
    result = outcome(case)
    assert result.code in case.expect, result
    if result.kind == "rejected":
        assert result.status is not None, result
        assert 400 <= result.status < 500 and result.field == case.kind.split("-")[0] or case.kind == "options", result


def _send(client, auth: dict, case: Case):
    if case.kind == "request":
        spec = case.request
        headers = {**auth, **spec["headers"]}
        headers = {k: v for k, v in headers.items() if v}
        if spec.get("content") is not None:
            return client.post("/api/v1/jobs", headers=headers, content=spec["content"])
        parts = [(field, (name, data)) for field, name, data in spec["files"]]
        return client.post("/api/v1/jobs", headers=headers, files=parts or None, data=spec["form"] or None)
    files = {"mesh": ("upload", case.data)} if case.kind == "mesh" else {"mesh": ("t.obj", MOTION_HOST), "motion": ("clip", case.data)}
    return client.post("/api/v1/jobs", headers=auth, files=files, data={"options": INGEST_ONLY if case.kind == "mesh" else "{}"})


def assert_api_outcome(client, auth: dict, case: Case) -> None:
    """4xx problem+json with the expected code, or 202 with a job that succeeded or failed with an expected code."""
    r = _send(client, auth, case)
    assert r.status_code < 500, (case.name, r.status_code, r.text[:300])
    if r.status_code == 202:
        job = r.json()
        code = OK if job["status"] == "succeeded" else (job["error"] or {}).get("code")
        assert job["status"] in ("succeeded", "failed") and code != "internal_error", (case.name, job)
        assert code in case.expect or (case.kind == "motion" and job["status"] == "failed" and job["error"]["message"]), (case.name, job)
        return
    assert r.headers["content-type"] == "application/problem+json", (case.name, r.text[:300])
    body = r.json()
    assert body["code"] in case.expect and body["detail"], (case.name, body)


@pytest.mark.parametrize("case", THROUGH_API, ids=[c.name for c in THROUGH_API])
def test_through_the_api(client, auth, case: Case):
    assert_api_outcome(client, auth, case)

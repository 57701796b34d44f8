"""Concurrent submits with one Idempotency-Key all answer with the first job (never a 500 from the unique constraint)."""

from __future__ import annotations

import threading

from tests.api.conftest import INGEST_ONLY

MESH = b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n"


def race_submits(client, headers: dict, count: int = 8) -> list:
    """`count` threads submit the same request at once; returns the responses."""
    barrier, responses = threading.Barrier(count), [None] * count

    def submit(k: int) -> None:
        barrier.wait()
        responses[k] = client.post("/api/v1/jobs", headers=headers, files={"mesh": ("t.obj", MESH)}, data={"options": INGEST_ONLY})

    threads = [threading.Thread(target=submit, args=(k,)) for k in range(count)]
    for t in threads:
        t.start()
    for t in threads:
        t.join(60)
    return responses


def test_racing_submits_with_one_key_get_the_first_job(client, auth, inline_worker):
    for round_ in range(3):
        responses = race_submits(client, {**auth, "Idempotency-Key": f"race-{round_}"})
        assert [r.status_code for r in responses] == [202] * len(responses), [r.text for r in responses if r.status_code != 202]
        assert len({r.json()["id"] for r in responses}) == 1
    assert len(inline_worker) == 3  # one job (and one enqueue) per key


def test_a_racing_submit_with_a_different_request_is_a_conflict(client, auth):
    headers = {**auth, "Idempotency-Key": "same"}
    first = client.post("/api/v1/jobs", headers=headers, files={"mesh": ("t.obj", MESH)}, data={"options": INGEST_ONLY})
    other = client.post("/api/v1/jobs", headers=headers, files={"mesh": ("t.obj", MESH + b"\n")}, data={"options": INGEST_ONLY})
    assert first.status_code == 202 and other.status_code == 409 and other.json()["code"] == "idempotency_conflict"

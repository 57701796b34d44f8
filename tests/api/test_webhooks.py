"""Webhooks: signed deliveries on terminal states, retries with backoff, the delivery log in the job JSON."""

from __future__ import annotations

import json
import time

import pytest
import trimesh
from standardwebhooks.webhooks import Webhook

from api.settings import get_settings
from api.webhooks.dispatch import deliver_due
from tests.api.conftest import INGEST_ONLY
from tests.meshes import glb_bytes
from tests.webhook_receiver import free_port, receiver

BOX = glb_bytes(trimesh.creation.box())


def submit(client, auth, **data):
    r = client.post("/api/v1/jobs", headers=auth, files={"mesh": ("box.glb", BOX)}, data={"options": INGEST_ONLY, **data})
    assert r.status_code == 202, r.text
    return r.json()["id"]


def job(client, auth, job_id):
    return client.get(f"/api/v1/jobs/{job_id}", headers=auth).json()


def secret(client, auth) -> str:
    return client.get("/api/v1/keys/me/webhook", headers=auth).json()["secret"]


def test_a_finished_job_posts_a_signed_event_and_logs_it(client, auth):
    with receiver() as hook:
        job_id = submit(client, auth, callback_url=hook.url)
        assert job(client, auth, job_id)["webhooks"][0]["status"] == "pending"
        assert deliver_due(get_settings()) == 1
    headers, body = hook.received[0]
    payload = Webhook(secret(client, auth)).verify(body, headers)  # the Standard Webhooks reference verifier
    assert payload["type"] == "job.succeeded" and payload["data"]["id"] == job_id and payload["data"]["status"] == "succeeded"
    assert abs(int(headers["webhook-timestamp"]) - time.time()) < 60
    log = job(client, auth, job_id)["webhooks"]
    assert [(d["event"], d["status"], d["url"]) for d in log] == [("job.succeeded", "delivered", hook.url)]
    assert log[0]["attempts"][0]["status_code"] == 200 and log[0]["id"] == headers["webhook-id"]
    assert deliver_due(get_settings()) == 0  # delivered once


def test_a_tampered_body_fails_verification(client, auth):
    with receiver() as hook:
        submit(client, auth, callback_url=hook.url)
        deliver_due(get_settings())
    headers, body = hook.received[0]
    with pytest.raises(Exception, match="signature"):
        Webhook(secret(client, auth)).verify(body.replace(b"succeeded", b"failed"), headers)


def test_a_receiver_that_is_down_gets_the_event_once_it_comes_back(client, auth, monkeypatch):
    monkeypatch.setenv("RIGFORGE_WEBHOOKS__BACKOFF_SECONDS", "1")
    get_settings.cache_clear()
    port = free_port()
    job_id = submit(client, auth, callback_url=f"http://127.0.0.1:{port}/hook")
    assert deliver_due(get_settings()) == 1  # nobody listens
    pending = job(client, auth, job_id)["webhooks"][0]
    assert pending["status"] == "pending" and pending["attempts"][0]["status_code"] is None
    assert "Connect" in pending["attempts"][0]["error"] and pending["next_attempt_at"] is not None
    with receiver(port, statuses=[503]) as hook:
        assert deliver_due(get_settings()) == 0  # not due before its backoff
        time.sleep(1.1)
        assert deliver_due(get_settings()) == 1  # up, but answers 503
        time.sleep(1.1)
        assert deliver_due(get_settings()) == 0  # the second wait is twice as long
        time.sleep(1.0)
        assert deliver_due(get_settings()) == 1
    log = job(client, auth, job_id)["webhooks"][0]
    assert log["status"] == "delivered" and [a["status_code"] for a in log["attempts"]] == [None, 503, 200]
    assert len({h["webhook-id"] for h, _ in hook.received}) == 1  # one event, retried under one id


def test_a_delivery_gives_up_after_max_attempts(client, auth, monkeypatch):
    monkeypatch.setenv("RIGFORGE_WEBHOOKS__MAX_ATTEMPTS", "2")
    monkeypatch.setenv("RIGFORGE_WEBHOOKS__BACKOFF_SECONDS", "0.05")
    get_settings.cache_clear()
    with receiver(statuses=[500, 500, 500]) as hook:
        job_id = submit(client, auth, callback_url=hook.url)
        deliver_due(get_settings())
        time.sleep(0.1)
        deliver_due(get_settings())
        time.sleep(0.2)
        assert deliver_due(get_settings()) == 0
    log = job(client, auth, job_id)["webhooks"][0]
    assert log["status"] == "failed" and len(log["attempts"]) == 2 and log["next_attempt_at"] is None


def test_the_key_default_url_gets_cancel_events(client, auth, monkeypatch):
    monkeypatch.setattr("worker.celery_app.enqueue", lambda job_id: None)  # stays queued
    with receiver() as hook:
        r = client.put("/api/v1/keys/me/webhook", headers=auth, json={"url": hook.url})
        assert r.status_code == 200 and r.json()["url"] == hook.url and r.json()["secret"].startswith("whsec_")
        job_id = submit(client, auth)
        assert client.post(f"/api/v1/jobs/{job_id}/cancel", headers=auth).status_code == 202
        deliver_due(get_settings())
    assert json.loads(hook.received[0][1])["type"] == "job.canceled"
    assert job(client, auth, job_id)["callback_url"] is None  # the key's default, not the job's own


def test_rotating_the_secret_changes_the_signature_key(client, auth):
    before = secret(client, auth)
    after = client.post("/api/v1/keys/me/webhook/secret", headers=auth).json()["secret"]
    assert after != before and secret(client, auth) == after


@pytest.mark.parametrize("url", ["ftp://example.com/hook", "file:///etc/passwd", "javascript:alert(1)", "/relative/hook",
                                 "http://"])
def test_non_http_callback_urls_are_refused_naming_the_field(client, auth, url):
    r = client.post("/api/v1/jobs", headers=auth, files={"mesh": ("box.glb", BOX)}, data={"callback_url": url})
    assert r.status_code == 422 and r.headers["content-type"] == "application/problem+json"
    assert r.json()["code"] == "invalid_callback_url" and r.json()["field"] == "callback_url"
    r = client.put("/api/v1/keys/me/webhook", headers=auth, json={"url": url})
    assert r.status_code == 422 and r.json()["field"] == "url"

"""The dashboard never puts the API key in a URL: it follows a job's events with fetch and the Authorization header,
and downloads by the signed links in the job's JSON (a fresh one asked for when the rendered one is about to expire)."""

from __future__ import annotations

import json
import time

import httpx
import pytest

from tests.e2e.conftest import ARTIFACTS
from tests.e2e.test_dashboard import block_events, sign_in

pytestmark = pytest.mark.browser
INGEST_ONLY = '{"stages": []}'


def _finished_ingest_job(server, dev_assets) -> dict:
    with httpx.Client(base_url=server.url, headers={"Authorization": f"Bearer {server.local_key}"}, timeout=60) as client:
        job = client.post("/api/v1/jobs", files={"mesh": ("fox.glb", (dev_assets / "fox.glb").read_bytes())},
                          data={"options": INGEST_ONLY}).json()
        deadline = time.monotonic() + 120
        while job["status"] in ("queued", "running") and time.monotonic() < deadline:
            time.sleep(0.3)
            job = client.get(f"/api/v1/jobs/{job['id']}").json()
    assert job["status"] == "succeeded", job
    return job


def _open_as_queued(page, job: dict) -> list:
    """Serve the page's first read of `job` as still queued, so it follows the job to its end; returns the requests made."""
    requests: list = []
    page.on("request", lambda r: requests.append(r))
    served_as_queued: list[str] = []

    def first_read_as_queued(route) -> None:
        if served_as_queued:
            route.continue_()
            return
        served_as_queued.append(route.request.url)
        route.fulfill(status=200, content_type="application/json",
                      body=json.dumps({**job, "status": "queued", "stage": None, "progress": 0.0, "finished_at": None,
                                       "artifacts": [], "download_all_url": None}))

    page.route(f"**/api/v1/jobs/{job['id']}", first_read_as_queued)
    page.goto(f"/#/jobs/{job['id']}")
    page.wait_for_selector("#job-head .badge[data-status=succeeded]", timeout=60_000)
    assert served_as_queued
    return requests


def test_events_by_header_and_downloads_by_signed_link(page, dashboard_server, dev_assets):
    job = _finished_ingest_job(dashboard_server, dev_assets)
    key = dashboard_server.local_key
    sign_in(page, key)
    requests = _open_as_queued(page, job)
    events = [r for r in requests if r.url.endswith(f"/api/v1/jobs/{job['id']}/events")]
    assert events and events[0].headers.get("authorization") == f"Bearer {key}"

    link = page.get_attribute("a[aria-label='Download mesh.glb']", "href")
    assert "/api/v1/files/" in link and "sig=" in link
    with page.expect_download() as info:
        page.click("a[aria-label='Download mesh.glb']")
    saved = ARTIFACTS / "downloaded-signed-mesh.glb"
    info.value.save_as(saved)
    assert saved.read_bytes()[:4] == b"glTF"
    with page.expect_download() as info:
        page.click("#download-all")
    assert info.value.suggested_filename == f"rigforge-{job['id']}.zip"
    # A link that has expired while the page stayed open is replaced by a fresh one from the job.
    page.eval_on_selector("a[aria-label='Download mesh.glb']", "a => { a.href = a.href.replace(/expires=\\d+/, 'expires=1'); }")
    with page.expect_download() as info:
        page.click("a[aria-label='Download mesh.glb']")
    info.value.save_as(saved)
    assert saved.read_bytes()[:4] == b"glTF"
    assert not [r.url for r in requests if key in r.url]
    assert not page.console_errors and not page.external_requests


def test_a_blocked_event_stream_falls_back_to_polling(page, dashboard_server, dev_assets):
    job = _finished_ingest_job(dashboard_server, dev_assets)
    blocked = block_events(page)
    sign_in(page, dashboard_server.local_key)
    requests = _open_as_queued(page, job)  # reached `succeeded` by polling the job
    assert blocked and len([r for r in requests if r.url.endswith(f"/api/v1/jobs/{job['id']}")]) >= 2
    assert page.get_attribute("#job-head [role=progressbar]", "aria-valuenow") == "100"

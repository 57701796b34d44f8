"""The API served by uvicorn writes its access log without the API key or signed-link secrets in it: a job is submitted,
followed over SSE and downloaded (signed links, the header, and a client that still puts the key in the URL)."""

from __future__ import annotations

import json
import logging
import threading
from collections.abc import Iterator

import httpx
import pytest
import uvicorn

from tests.api.conftest import INGEST_ONLY, _new_key
from tests.integration.conftest import free_port, wait_for
from tests.service_env import service_env


@pytest.fixture
def served(data_dir, inline_worker) -> Iterator[tuple[str, str]]:
    """(base URL, API key) of the app under uvicorn in a thread, its access log going to the root logger."""
    with service_env(data_dir):
        from api.app import create_app

        port = free_port()
        server = uvicorn.Server(uvicorn.Config(create_app(), host="127.0.0.1", port=port, log_config=None, access_log=True))
        thread = threading.Thread(target=server.run, daemon=True)
        thread.start()
        try:
            wait_for(lambda: server.started, 30)
            yield f"http://127.0.0.1:{port}", _new_key("log test")
        finally:
            server.should_exit = True
            thread.join(30)


def test_access_log_never_contains_the_key(served, dev_assets, caplog):
    url, key = served
    caplog.set_level(logging.INFO, logger="uvicorn.access")
    auth = {"Authorization": f"Bearer {key}"}
    with httpx.Client(base_url=url, timeout=60) as http:
        r = http.post("/api/v1/jobs", headers=auth, files={"mesh": ("fox.glb", (dev_assets / "fox.glb").read_bytes())},
                      data={"options": INGEST_ONLY})
        assert r.status_code == 202, r.text
        with http.stream("GET", f"/api/v1/jobs/{r.json()['id']}/events", headers=auth) as events:
            final = [json.loads(line[6:]) for line in events.iter_lines() if line.startswith("data: ")][-1]
        assert final["status"] == "succeeded", final
        mesh = next(a for a in final["artifacts"] if a["name"] == "mesh.glb")
        signed = http.get(mesh["download_url"])  # no key: the link is signed
        assert signed.status_code == 200 and signed.content == http.get(mesh["url"], headers=auth).content
        assert http.get(final["download_all_url"]).headers["content-type"] == "application/zip"
        legacy = http.get(f"/api/v1/jobs/{final['id']}", params={"key": key})  # an old client: refused, and not logged
        assert legacy.status_code == 401 and legacy.json()["code"] == "key_in_url"
    text = "\n".join(r.getMessage() for r in caplog.records if r.name == "uvicorn.access")
    assert f"/api/v1/files/{final['id']}/mesh.glb?expires=" in text and "sig=***" in text and "key=***" in text, text
    assert key not in text and key[-12:] not in text
    assert mesh["download_url"].split("sig=")[1] not in text

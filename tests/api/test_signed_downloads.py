"""Downloads without a key: the job's signed links work alone, on local files and on S3, and only for what they
sign and until they expire; a key in a URL is refused."""

from __future__ import annotations

import io
import time
import uuid
import zipfile
from urllib.parse import parse_qs, urlsplit

import httpx
import pytest

from tests.api.conftest import BACKENDS, INGEST_ONLY

pytestmark = pytest.mark.parametrize("storage_backend", BACKENDS, indirect=True)


def _job(client, auth, dev_assets) -> dict:
    r = client.post("/api/v1/jobs", headers=auth, files={"mesh": ("fox.glb", (dev_assets / "fox.glb").read_bytes())},
                    data={"options": INGEST_ONLY})
    assert r.status_code == 202, r.text
    return client.get(f"/api/v1/jobs/{r.json()['id']}", headers=auth).json()


def _get(client, url: str) -> httpx.Response:
    """An API link through the app; a presigned S3 link from the S3 server itself, with no credentials."""
    return client.get(url) if url.startswith(str(client.base_url)) else httpx.get(url)


def test_signed_links_download_without_a_key(client, auth, dev_assets, storage_backend):
    job = _job(client, auth, dev_assets)
    mesh = next(a for a in job["artifacts"] if a["name"] == "mesh.glb")
    assert ("/api/v1/files/" in mesh["download_url"]) == (storage_backend == "local")  # S3: the store's presigned URL
    signed = _get(client, mesh["download_url"])
    assert signed.status_code == 200 and signed.content == client.get(mesh["url"], headers=auth).content
    assert "mesh.glb" in signed.headers["content-disposition"]
    archive = client.get(job["download_all_url"])
    assert archive.status_code == 200
    assert sorted(zipfile.ZipFile(io.BytesIO(archive.content)).namelist()) == sorted(a["name"] for a in job["artifacts"])


def test_a_link_opens_only_what_it_signs_until_it_expires(client, auth, dev_assets):
    from api.signed_urls import _signature

    job = _job(client, auth, dev_assets)
    link = urlsplit(job["download_all_url"])
    query = {k: v[0] for k, v in parse_qs(link.query).items()}
    forged = client.get(link.path, params={**query, "sig": "0" * 64})
    assert forged.status_code == 403 and forged.json()["code"] == "bad_signature"
    other = client.get(link.path.replace("artifacts.zip", "report.json"), params=query)  # signed for the zip only
    assert other.status_code == 403 and other.json()["code"] == "bad_signature"
    job_id, past = uuid.UUID(job["id"]), int(time.time()) - 1
    expired = client.get(link.path, params={"expires": past, "sig": _signature(job_id, "artifacts.zip", past)})
    assert expired.status_code == 403 and expired.json()["code"] == "link_expired"
    assert client.get(link.path, params={"expires": "soon", "sig": query["sig"]}).status_code == 422


def test_a_key_in_the_url_is_refused(client, auth, dev_assets):
    job = _job(client, auth, dev_assets)
    key = auth["Authorization"].split()[1]
    r = client.get(f"/api/v1/jobs/{job['id']}/artifacts/mesh.glb", params={"key": key})
    assert r.status_code == 401 and r.json()["code"] == "key_in_url"

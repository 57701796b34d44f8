"""A finished job's actions: download everything as one zip, run it again, delete it."""

from __future__ import annotations

import io
import json
import zipfile

import pytest

from tests.api.conftest import BACKENDS, INGEST_ONLY

pytestmark = pytest.mark.parametrize("storage_backend", BACKENDS, indirect=True)  # the same tests on S3


def _fox_job(client, auth, dev_assets, options=INGEST_ONLY) -> dict:
    r = client.post("/api/v1/jobs", headers=auth, files={"mesh": ("fox.glb", (dev_assets / "fox.glb").read_bytes())},
                    data={"options": options})
    assert r.status_code == 202, r.text
    return client.get(f"/api/v1/jobs/{r.json()['id']}", headers=auth).json()


def test_download_all_zips_every_artifact(client, auth, dev_assets):
    job = _fox_job(client, auth, dev_assets)
    r = client.get(f"/api/v1/jobs/{job['id']}/artifacts.zip", headers=auth)
    assert r.status_code == 200 and r.headers["content-type"] == "application/zip"
    assert f'rigforge-{job["id"]}.zip' in r.headers["content-disposition"]
    archive = zipfile.ZipFile(io.BytesIO(r.content))
    assert sorted(archive.namelist()) == sorted(a["name"] for a in job["artifacts"])
    report = client.get(next(a["url"] for a in job["artifacts"] if a["name"] == "report.json"), headers=auth).content
    assert archive.read("report.json") == report


def test_rerun_queues_the_same_inputs_and_options_again(client, auth, dev_assets):
    options = json.dumps({"stages": [], "max_joints": 12})
    job = _fox_job(client, auth, dev_assets, options)
    r = client.post(f"/api/v1/jobs/{job['id']}/rerun", headers=auth)
    assert r.status_code == 202, r.text
    again = client.get(f"/api/v1/jobs/{r.json()['id']}", headers=auth).json()
    assert again["id"] != job["id"] and again["status"] == "succeeded"
    assert again["options"] == job["options"] and again["mesh"] == job["mesh"]


def test_delete_removes_a_finished_job_and_its_files(client, auth, other_auth, dev_assets, stored_names):
    job = _fox_job(client, auth, dev_assets)
    assert [n for n in stored_names() if job["id"] in n]
    assert client.delete(f"/api/v1/jobs/{job['id']}", headers=other_auth).status_code == 404  # not theirs
    assert client.delete(f"/api/v1/jobs/{job['id']}", headers=auth).status_code == 204
    assert client.get(f"/api/v1/jobs/{job['id']}", headers=auth).status_code == 404
    assert not [n for n in stored_names() if job["id"] in n]  # its outputs are gone


def test_deleting_a_source_job_unlinks_its_reskins(client, auth, dev_assets):
    source = _fox_job(client, auth, dev_assets)
    r = client.post("/api/v1/jobs", headers=auth, files={"mesh": ("fox.glb", (dev_assets / "fox.glb").read_bytes())},
                    data={"options": INGEST_ONLY, "source_job": source["id"]})
    assert r.json()["source_job_id"] == source["id"]
    assert client.delete(f"/api/v1/jobs/{source['id']}", headers=auth).status_code == 204
    assert client.get(f"/api/v1/jobs/{r.json()['id']}", headers=auth).json()["source_job_id"] is None


def test_deleting_a_queued_job_cancels_it_and_removes_its_upload(client, auth, dev_assets, stored_names, monkeypatch):
    monkeypatch.setattr("worker.celery_app.enqueue", lambda job_id: None)  # nobody runs it
    job = _fox_job(client, auth, dev_assets)
    assert job["status"] == "queued"
    assert len([n for n in stored_names() if "uploads/" in n]) == 1
    assert client.delete(f"/api/v1/jobs/{job['id']}", headers=auth).status_code == 204
    assert client.get(f"/api/v1/jobs/{job['id']}", headers=auth).status_code == 404
    assert not [n for n in stored_names() if "uploads/" in n]


def test_an_upload_two_jobs_share_stays_until_both_are_deleted(client, auth, dev_assets, stored_names):
    first, second = _fox_job(client, auth, dev_assets), _fox_job(client, auth, dev_assets)
    assert client.delete(f"/api/v1/jobs/{first['id']}", headers=auth).status_code == 204
    assert len([n for n in stored_names() if "uploads/" in n]) == 1
    assert client.get(f"/api/v1/jobs/{second['id']}", headers=auth).status_code == 200
    assert client.delete(f"/api/v1/jobs/{second['id']}", headers=auth).status_code == 204
    assert not [n for n in stored_names() if "uploads/" in n]

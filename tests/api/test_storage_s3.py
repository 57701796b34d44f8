"""The S3 backend against the real S3-compatible test server: multipart uploads with bounded memory, fetch, presigned
links that need no credentials, listing and deletion."""

from __future__ import annotations

import hashlib
import io
import os
import tracemalloc
import uuid
from collections.abc import Iterator

import httpx
import pytest

from api.storage_s3 import TRANSFER, S3Storage, _client
from tests.s3_server import CREDENTIALS, S3_ENDPOINT, bucket_keys, drop_bucket, new_bucket

SIZE = 48 * 1024 * 1024  # six parts


@pytest.fixture
def storage(tmp_path, monkeypatch) -> Iterator[S3Storage]:
    for name, value in CREDENTIALS.items():
        monkeypatch.setenv(name, value)
    client = _client(S3_ENDPOINT)
    bucket = new_bucket()
    yield S3Storage(bucket, "prefix", client, client, tmp_path)
    drop_bucket(bucket)


def test_a_large_upload_goes_in_parts_without_the_whole_file_in_memory(storage, tmp_path):
    data = os.urandom(SIZE)
    with storage.stage(io.BytesIO(data), SIZE) as staged:
        del data  # from here on the bytes live only in the staged file
        tracemalloc.start()
        stored = storage.keep(staged)
        _, peak = tracemalloc.get_traced_memory()
        tracemalloc.stop()
    parts = SIZE // TRANSFER["multipart_chunksize"]
    head = storage.client.head_object(Bucket=storage.bucket, Key=f"prefix/uploads/{stored.sha256}")
    assert head["ContentLength"] == SIZE and head["ETag"].strip('"').endswith(f"-{parts}")  # a multipart upload
    assert peak < SIZE * 0.8, f"peak {peak / 2**20:.0f} MiB while keeping a {SIZE / 2**20:.0f} MiB file"
    local = storage.fetch(stored.locator, tmp_path)
    digest = hashlib.sha256()
    with local.open("rb") as f:
        while chunk := f.read(1 << 20):
            digest.update(chunk)
    assert digest.hexdigest() == stored.sha256


def test_outputs_publish_list_presign_and_delete(storage, tmp_path):
    job_id = uuid.uuid4()
    work = storage.work_dir(job_id, 1)
    (work / "report.json").write_text('{"ok": true}')
    rows = storage.publish(work, job_id, 1, ["report.json"])
    assert not work.exists() and rows[0]["path"] == f"s3://{storage.bucket}/prefix/jobs/{job_id}/1/report.json"
    assert [j for j, _ in storage.job_outputs()] == [job_id]
    url = storage.presigned_url(rows[0]["path"], "report.json", "application/json", 60)
    assert url is not None
    r = httpx.get(url)  # no credentials: the signature in the URL is the permission
    assert r.status_code == 200 and r.json() == {"ok": True} and "attachment" in r.headers["content-disposition"]
    with storage.stage(io.BytesIO(b"mesh"), 10) as staged:
        upload = storage.keep(staged)
    assert [loc for loc, _ in storage.uploads()] == [upload.locator]
    storage.delete_job(job_id)
    storage.delete_upload(upload.locator)
    assert bucket_keys(storage.bucket) == []

"""S3-compatible object storage (AWS S3, MinIO, Ceph RGW, R2): `RIGFORGE_STORAGE_URL=s3://bucket/prefix`.

Credentials and region come from boto3's usual sources (AWS_ACCESS_KEY_ID, AWS_SECRET_ACCESS_KEY,
AWS_DEFAULT_REGION, a profile or an instance role); `RIGFORGE_S3_ENDPOINT_URL` points at a service other than
AWS. Transfers go through boto3's managed transfer: files above its threshold are sent as multipart uploads in
parts read from disk, never whole in memory. Downloads are presigned URLs the store serves itself.
"""

from __future__ import annotations

import uuid
from collections.abc import Iterator
from datetime import datetime, timedelta
from pathlib import Path
from typing import Any, BinaryIO, cast
from urllib.parse import quote, urlsplit

import boto3
from boto3.s3.transfer import TransferConfig
from botocore.config import Config
from botocore.exceptions import ClientError

from api.settings import Settings
from api.storage import StagedFile, Storage, StoredFile, artifact_row

# Multipart above 8 MiB, in 8 MiB parts, 4 at a time: at most 32 MiB of a file in memory, whatever its size.
TRANSFER = {"multipart_threshold": 8 * 1024 * 1024, "multipart_chunksize": 8 * 1024 * 1024, "max_concurrency": 4}


def _client(endpoint_url: str | None) -> Any:
    # Path-style addressing works on every S3-compatible service; AWS still accepts it.
    config = Config(signature_version="s3v4", s3={"addressing_style": "path"}, retries={"mode": "standard"})
    return boto3.client("s3", endpoint_url=endpoint_url, config=config)


class S3Storage(Storage):
    """Objects under s3://bucket/prefix: uploads/<sha256>, jobs/<job id>/<attempt>/<artifact>."""

    def __init__(self, bucket: str, prefix: str, client: Any, presign_client: Any, scratch_root: Path) -> None:
        super().__init__(scratch_root)
        self.bucket, self.prefix = bucket, prefix.strip("/")
        self.client, self.presign_client = client, presign_client
        self.transfer = TransferConfig(**TRANSFER)

    @classmethod
    def from_settings(cls, settings: Settings) -> S3Storage:
        url = urlsplit(settings.storage_url or "")
        client = _client(settings.s3_endpoint_url)
        public = _client(settings.s3_public_endpoint_url) if settings.s3_public_endpoint_url else client
        return cls(url.netloc, url.path, client, public, settings.storage_dir)

    def _key(self, *parts: str) -> str:
        return "/".join([self.prefix, *parts] if self.prefix else parts)

    def _locator(self, key: str) -> str:
        return f"s3://{self.bucket}/{key}"

    def _split(self, locator: str) -> tuple[str, str]:
        url = urlsplit(locator)
        if url.scheme != "s3":
            raise ValueError(f"not an object in S3 storage: {locator}")
        return url.netloc, url.path.lstrip("/")

    def check(self) -> None:
        super().check()
        self.client.head_bucket(Bucket=self.bucket)

    def keep(self, staged: StagedFile) -> StoredFile:
        key = self._key("uploads", staged.sha256)
        if not self._has(key, staged.size):  # the same bytes were kept before
            self.client.upload_file(str(staged.path), self.bucket, key, Config=self.transfer)
        return StoredFile(self._locator(key), staged.size, staged.sha256)

    def _has(self, key: str, size: int) -> bool:
        try:
            return int(self.client.head_object(Bucket=self.bucket, Key=key)["ContentLength"]) == size
        except ClientError as exc:
            if exc.response.get("Error", {}).get("Code") in ("404", "NoSuchKey", "NotFound"):
                return False
            raise

    def fetch(self, locator: str, scratch: Path) -> Path:
        bucket, key = self._split(locator)
        local = scratch / f"{uuid.uuid4().hex}-{key.rsplit('/', 1)[-1]}"
        self.client.download_file(bucket, key, str(local), Config=self.transfer)
        return local

    def publish(self, work_dir: Path, job_id: uuid.UUID, attempt: int, names: list[str]) -> list[dict]:
        rows = []
        for name in names:
            key = self._key("jobs", str(job_id), str(attempt), name)
            self.client.upload_file(str(work_dir / name), self.bucket, key, Config=self.transfer)
            rows.append(artifact_row(name, work_dir / name, self._locator(key)))
        self.discard(work_dir)
        return rows

    def open(self, locator: str) -> BinaryIO:
        bucket, key = self._split(locator)
        return cast(BinaryIO, self.client.get_object(Bucket=bucket, Key=key)["Body"])

    def presigned_url(self, locator: str, filename: str, media_type: str, seconds: int) -> str | None:
        bucket, key = self._split(locator)
        params = {"Bucket": bucket, "Key": key, "ResponseContentType": media_type,
                  "ResponseContentDisposition": f"attachment; filename*=UTF-8''{quote(filename)}"}
        return cast(str, self.presign_client.generate_presigned_url("get_object", Params=params, ExpiresIn=seconds))

    def delete_job(self, job_id: uuid.UUID) -> None:
        pages = self.client.get_paginator("list_objects_v2").paginate(Bucket=self.bucket, Prefix=self._key("jobs", str(job_id), ""))
        for page in pages:
            objects = [{"Key": item["Key"]} for item in page.get("Contents", [])]
            if objects:
                self.client.delete_objects(Bucket=self.bucket, Delete={"Objects": objects, "Quiet": True})

    def _listing(self, prefix: str) -> Iterator[dict]:
        for page in self.client.get_paginator("list_objects_v2").paginate(Bucket=self.bucket, Prefix=prefix):
            yield from page.get("Contents", [])

    def delete_upload(self, locator: str) -> None:
        bucket, key = self._split(locator)
        self.client.delete_object(Bucket=bucket, Key=key)

    def uploads(self) -> Iterator[tuple[str, datetime]]:
        for item in self._listing(self._key("uploads", "")):
            yield self._locator(item["Key"]), _written(item)

    def job_outputs(self) -> Iterator[tuple[uuid.UUID, datetime]]:
        prefix = self._key("jobs", "")
        newest: dict[uuid.UUID, datetime] = {}
        for item in self._listing(prefix):
            try:
                job_id = uuid.UUID(item["Key"][len(prefix):].split("/", 1)[0])
            except ValueError:
                continue
            newest[job_id] = max(newest.get(job_id, _written(item)), _written(item))
        yield from newest.items()


def _written(item: dict) -> datetime:
    """The latest time a listed object may have been written: S3's LastModified is rounded down to the second, so
    an object one fraction of a second old could otherwise look a whole second old to the orphan sweep."""
    return item["LastModified"] + timedelta(seconds=1)

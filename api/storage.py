"""File storage shared by the API and the workers: content-addressed uploads and per-job outputs.

Two backends behind one interface, chosen by `RIGFORGE_STORAGE_URL`: local files under the data directory (the
embedded default) and S3-compatible object storage (`api.storage_s3`), which API and workers on different hosts
share. Both stage uploads and run jobs in local scratch space (`<storage_dir>/tmp`); a stored file is named by a
*locator* kept in the database: an absolute path for local files, `s3://bucket/key` for objects.
Every name is built from server-chosen parts (hashes, UUIDs, our artifact names), never from user input.
"""

from __future__ import annotations

import hashlib
import os
import shutil
import uuid
from abc import ABC, abstractmethod
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from datetime import UTC, datetime
from functools import lru_cache
from pathlib import Path
from typing import BinaryIO

from api.settings import Settings, get_settings
from simcore.io.sniff import MEDIA_TYPES

CHUNK = 1024 * 1024
SNIFF_BYTES = 64 * 1024


class UploadTooLarge(Exception):
    """The stream passed the size cap."""


@dataclass(frozen=True)
class StagedFile:
    """An upload received into local scratch space, not yet kept."""

    path: Path
    size: int
    sha256: str
    head: bytes


@dataclass(frozen=True)
class StoredFile:
    """A kept upload: its locator and what was measured on the way in."""

    locator: str
    size: int
    sha256: str


class Storage(ABC):
    """What both backends share: local scratch space for staging uploads and running job attempts."""

    def __init__(self, scratch_root: Path) -> None:
        self.scratch = scratch_root / "tmp"
        self.scratch.mkdir(parents=True, exist_ok=True)

    @contextmanager
    def stage(self, stream: BinaryIO, max_bytes: int) -> Iterator[StagedFile]:
        """Copy a stream into a scratch file with a hard cap, hashing on the way; the file is gone afterwards."""
        digest, size, head = hashlib.sha256(), 0, b""
        tmp = self.scratch / f"upload-{uuid.uuid4().hex}"
        try:
            with tmp.open("wb") as out:
                while chunk := stream.read(CHUNK):
                    size += len(chunk)
                    if size > max_bytes:
                        raise UploadTooLarge
                    if len(head) < SNIFF_BYTES:
                        head += chunk[: SNIFF_BYTES - len(head)]
                    digest.update(chunk)
                    out.write(chunk)
            yield StagedFile(tmp, size, digest.hexdigest(), head)
        finally:
            tmp.unlink(missing_ok=True)

    def scratch_dir(self, name: str) -> Path:
        """A fresh, empty scratch directory."""
        path = self.scratch / name
        shutil.rmtree(path, ignore_errors=True)
        path.mkdir(parents=True)
        return path

    def work_dir(self, job_id: uuid.UUID, attempt: int) -> Path:
        """A fresh scratch directory for the outputs of one attempt of a job."""
        return self.scratch_dir(f"job-{job_id}-{attempt}")

    def discard(self, path: Path) -> None:
        """Remove a scratch directory."""
        shutil.rmtree(path, ignore_errors=True)

    def check(self) -> None:
        """Raise when the scratch space (and the backend) cannot be written."""
        probe = self.scratch / f"ready-{uuid.uuid4().hex}"
        probe.write_bytes(b"ok")
        probe.unlink()

    # The backend's part.

    @abstractmethod
    def keep(self, staged: StagedFile) -> StoredFile:
        """Keep a staged upload under its content hash."""

    @abstractmethod
    def fetch(self, locator: str, scratch: Path) -> Path:
        """A local path holding the stored file (downloaded into `scratch` when remote)."""

    @abstractmethod
    def publish(self, work_dir: Path, job_id: uuid.UUID, attempt: int, names: list[str]) -> list[dict]:
        """Store finished outputs under jobs/<job id>/<attempt>/ and describe them as artifact rows."""

    @abstractmethod
    def open(self, locator: str) -> BinaryIO:
        """Read a stored file."""

    @abstractmethod
    def presigned_url(self, locator: str, filename: str, media_type: str, seconds: int) -> str | None:
        """A URL the store itself serves without credentials for `seconds`, or None when downloads go through the API."""

    @abstractmethod
    def delete_job(self, job_id: uuid.UUID) -> None:
        """Remove every stored output of a job."""

    @abstractmethod
    def delete_upload(self, locator: str) -> None:
        """Remove one kept upload (gone already is fine)."""

    @abstractmethod
    def uploads(self) -> Iterator[tuple[str, datetime]]:
        """Every kept upload: (locator, last modified, UTC)."""

    @abstractmethod
    def job_outputs(self) -> Iterator[tuple[uuid.UUID, datetime]]:
        """Every job with stored outputs: (job id, newest output's last modified, UTC)."""


class LocalStorage(Storage):
    """Files under `root`: uploads/<sha256>, jobs/<job id>/<attempt>/<artifact>, tmp/ for work in progress."""

    def __init__(self, root: Path) -> None:
        super().__init__(root)
        self.root = root
        for sub in ("uploads", "jobs"):
            (root / sub).mkdir(parents=True, exist_ok=True)

    def keep(self, staged: StagedFile) -> StoredFile:
        final = self.root / "uploads" / staged.sha256
        os.replace(staged.path, final)
        return StoredFile(str(final), staged.size, staged.sha256)

    def fetch(self, locator: str, scratch: Path) -> Path:
        return Path(locator)

    def publish(self, work_dir: Path, job_id: uuid.UUID, attempt: int, names: list[str]) -> list[dict]:
        final = self.root / "jobs" / str(job_id) / str(attempt)
        final.parent.mkdir(parents=True, exist_ok=True)
        shutil.rmtree(final, ignore_errors=True)
        os.replace(work_dir, final)  # atomic: readers see all outputs of the attempt or none
        return [artifact_row(name, final / name, str(final / name)) for name in names]

    def open(self, locator: str) -> BinaryIO:
        return Path(locator).open("rb")

    def presigned_url(self, locator: str, filename: str, media_type: str, seconds: int) -> str | None:
        return None

    def delete_job(self, job_id: uuid.UUID) -> None:
        shutil.rmtree(self.root / "jobs" / str(job_id), ignore_errors=True)

    def delete_upload(self, locator: str) -> None:
        path = Path(locator)
        if path.parent != self.root / "uploads":
            raise ValueError(f"not an upload in {self.root}: {locator}")
        path.unlink(missing_ok=True)

    def uploads(self) -> Iterator[tuple[str, datetime]]:
        for path in (self.root / "uploads").iterdir():
            yield str(path), _modified(path)

    def job_outputs(self) -> Iterator[tuple[uuid.UUID, datetime]]:
        for path in (self.root / "jobs").iterdir():
            try:
                job_id = uuid.UUID(path.name)
            except ValueError:
                continue
            yield job_id, _modified(path)


def _modified(path: Path) -> datetime:
    return datetime.fromtimestamp(path.stat().st_mtime, UTC)


def artifact_row(name: str, local: Path, locator: str) -> dict:
    """An artifact row of a published output measured from its local copy."""
    return dict(name=name, media_type=media_type(name), size=local.stat().st_size, sha256=file_sha256(local), path=locator)


def open_storage(settings: Settings) -> Storage:
    """The backend named by `storage_url`: local files by default, S3 for `s3://bucket/prefix`."""
    if settings.storage_url and settings.storage_url.startswith("s3://"):
        from api.storage_s3 import S3Storage

        return S3Storage.from_settings(settings)
    return LocalStorage(settings.storage_dir)


@lru_cache
def get_storage() -> Storage:
    """The process-wide storage backend (tests clear this cache with the settings)."""
    return open_storage(get_settings())


def file_sha256(path: Path) -> str:
    digest = hashlib.sha256()
    with path.open("rb") as f:
        while chunk := f.read(CHUNK):
            digest.update(chunk)
    return digest.hexdigest()


def media_type(name: str) -> str:
    """Media type of an artifact by its extension."""
    ext = name.rsplit(".", 1)[-1].lower()
    return {
        "json": "application/json", "usdc": "model/vnd.usd", "usdz": "model/vnd.usdz+zip", "usda": "model/vnd.usda",
        "png": "image/png", "npz": "application/octet-stream",
    }.get(ext) or MEDIA_TYPES.get(ext, "application/octet-stream")

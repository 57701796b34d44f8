"""Local file storage under the data directory: content-addressed uploads and per-job outputs.

Every path is built from server-chosen names (hashes, UUIDs, our artifact names), never from user input.
"""

from __future__ import annotations

import hashlib
import os
import shutil
import uuid
from dataclasses import dataclass
from pathlib import Path
from typing import BinaryIO

from simcore.io.sniff import MEDIA_TYPES

CHUNK = 1024 * 1024
SNIFF_BYTES = 64 * 1024


class UploadTooLarge(Exception):
    """The stream passed the size cap."""


@dataclass(frozen=True)
class StoredFile:
    path: Path
    size: int
    sha256: str
    head: bytes


class LocalStorage:
    """Files under `root`: uploads/<sha256>, jobs/<job id>/<attempt>/<artifact>, tmp/ for work in progress."""

    def __init__(self, root: Path) -> None:
        self.root = root
        for sub in ("uploads", "jobs", "tmp"):
            (root / sub).mkdir(parents=True, exist_ok=True)

    def save_stream(self, stream: BinaryIO, max_bytes: int) -> StoredFile:
        """Copy a stream into content-addressed storage with a hard cap, hashing on the way."""
        digest, size, head = hashlib.sha256(), 0, b""
        tmp = self.root / "tmp" / f"upload-{uuid.uuid4().hex}"
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
            final = self.root / "uploads" / digest.hexdigest()
            os.replace(tmp, final)
            return StoredFile(final, size, digest.hexdigest(), head)
        finally:
            tmp.unlink(missing_ok=True)

    def work_dir(self, job_id: uuid.UUID, attempt: int) -> Path:
        """A fresh scratch directory for one attempt of a job."""
        path = self.root / "tmp" / f"job-{job_id}-{attempt}"
        shutil.rmtree(path, ignore_errors=True)
        path.mkdir(parents=True)
        return path

    def publish(self, work_dir: Path, job_id: uuid.UUID, attempt: int, names: list[str]) -> list[dict]:
        """Move finished outputs to their final place (atomic rename) and describe them as artifact rows."""
        final = self.root / "jobs" / str(job_id) / str(attempt)
        final.parent.mkdir(parents=True, exist_ok=True)
        shutil.rmtree(final, ignore_errors=True)
        os.replace(work_dir, final)
        rows = []
        for name in names:
            path = final / name
            rows.append(dict(name=name, media_type=media_type(name), size=path.stat().st_size, sha256=file_sha256(path), path=str(path)))
        return rows

    def discard(self, path: Path) -> None:
        shutil.rmtree(path, ignore_errors=True)


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

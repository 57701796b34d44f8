"""Responses that send a job's stored artifacts, one or all in a zip, from whichever storage backend holds them."""

from __future__ import annotations

import shutil
import tempfile
import zipfile
from collections.abc import Iterator
from pathlib import Path
from typing import BinaryIO

from fastapi.responses import FileResponse, Response, StreamingResponse

from api.errors import Problem
from api.models import Artifact, Job
from api.storage import CHUNK, LocalStorage, get_storage


def find_artifact(job: Job, name: str) -> Artifact:
    """The job's artifact called `name`, or a 404 problem."""
    artifact = next((a for a in job.artifacts if a.name == name), None)
    if artifact is None:
        raise Problem(404, "artifact_not_found", f"job has no artifact {name!r}")
    return artifact


def _chunks(stream: BinaryIO) -> Iterator[bytes]:
    with stream:
        while data := stream.read(CHUNK):
            yield data


def artifact_response(artifact: Artifact) -> Response:
    """A local file as a FileResponse (ranges, validators), an object streamed through from the store."""
    storage = get_storage()
    if isinstance(storage, LocalStorage):
        return FileResponse(Path(artifact.path), media_type=artifact.media_type, filename=artifact.name)
    headers = {"Content-Disposition": f'attachment; filename="{artifact.name}"', "Content-Length": str(artifact.size)}
    return StreamingResponse(_chunks(storage.open(artifact.path)), media_type=artifact.media_type, headers=headers)


def zip_response(job: Job) -> StreamingResponse:
    """Every artifact of `job` in one zip, spooled first (a zip's directory comes at its end), then streamed."""
    if not job.artifacts:
        raise Problem(404, "artifact_not_found", "job has no artifacts")
    storage = get_storage()
    spool = tempfile.TemporaryFile()
    with zipfile.ZipFile(spool, "w", zipfile.ZIP_DEFLATED) as archive:
        for artifact in job.artifacts:
            with storage.open(artifact.path) as source, archive.open(artifact.name, "w") as target:
                shutil.copyfileobj(source, target, CHUNK)
    spool.seek(0)
    return StreamingResponse(_chunks(spool), media_type="application/zip",
                             headers={"Content-Disposition": f'attachment; filename="rigforge-{job.id}.zip"'})

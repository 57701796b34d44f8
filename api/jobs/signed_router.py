"""/api/v1/files: artifact downloads by signed link (api.signed_urls), for browsers and tools that cannot send a key."""

from __future__ import annotations

import uuid
from typing import Annotated

from fastapi import APIRouter, Query
from fastapi.responses import Response

from api.db import session_scope
from api.errors import Problem
from api.jobs.artifact_responses import artifact_response, find_artifact, zip_response
from api.models import Job
from api.openapi import BINARY
from api.problem_schema import problem_responses
from api.signed_urls import ZIP_NAME, verify

router = APIRouter(prefix="/api/v1/files", tags=["files"])


@router.get("/{job_id}/{name}", summary="Download an artifact (or artifacts.zip) by the signed link in the job's JSON",
            response_class=Response,
            responses={200: {"description": "the file, with its media type", "content": {"application/octet-stream": BINARY}},
                       **problem_responses(403, 404, 422, examples={
                           403: ("link_expired", "the download link has expired: ask the job for a fresh one", "expires"),
                           404: ("artifact_not_found", "job has no artifact 'rigged.fbx'", None)})})
def download_signed(job_id: uuid.UUID, name: str, expires: Annotated[int, Query(description="expiry, Unix seconds")],
                    sig: Annotated[str, Query(max_length=128, description="HMAC-SHA256 of job, name and expiry")]) -> Response:
    verify(job_id, name, expires, sig)
    with session_scope() as session:
        job = session.get(Job, job_id)
        if job is None:
            raise Problem(404, "job_not_found", f"no job {job_id}")
        return zip_response(job) if name == ZIP_NAME else artifact_response(find_artifact(job, name))

"""/api/v1/jobs: submit, inspect, list, cancel, download artifacts and follow progress (SSE)."""

from __future__ import annotations

import json
import uuid
from typing import Annotated

from fastapi import APIRouter, Depends, File, Form, Header, Query, Request, Response, UploadFile
from fastapi.responses import FileResponse, StreamingResponse
from pydantic import ValidationError

from api.auth import CurrentKey
from api.db import session_scope
from api.errors import Problem
from api.http_cache import conditional
from api.jobs import lifecycle, service, state
from api.jobs.artifact_responses import artifact_response, find_artifact, zip_response
from api.jobs.events import job_stream
from api.jobs.schemas import JobOut, JobPage, JobStatus
from api.jobs.uploads import store_skeleton, store_upload
from api.jobs.views import owned_view
from api.models import Job
from api.openapi import BINARY, json_part, json_part_encoding
from api.problem_schema import problem_responses
from api.queue import enqueue_job
from api.quotas import check_submit
from api.settings import get_settings
from api.storage import get_storage
from api.webhooks.urls import checked_callback_url
from simcore.io.json_bounds import JsonTooDeep, loads_bounded
from simcore.options import JobOptions

router = APIRouter(prefix="/api/v1/jobs", tags=["jobs"], responses=problem_responses(401, 429))
MAX_OPTIONS_DEPTH = 8  # JobOptions nests 3 deep (refine.bone_stiffness)
OPTIONS_EXAMPLE = {"skeleton": "auto", "skinning": "auto", "motion": {"in_place": True}, "fbx": True}


def parse_options(raw: str | None) -> JobOptions:
    """Validate the `options` form field; errors name the offending option."""
    if not raw:
        return JobOptions()
    try:
        data = loads_bounded(raw, MAX_OPTIONS_DEPTH)
    except json.JSONDecodeError as exc:
        raise Problem(422, "invalid_options", f"options is not valid JSON: {exc.msg} at char {exc.pos}", field="options") from None
    except JsonTooDeep as exc:
        raise Problem(422, "invalid_options", f"options is {exc}", field="options") from None
    if not isinstance(data, dict):
        raise Problem(422, "invalid_options", "options must be a JSON object", field="options")
    try:
        return JobOptions.model_validate(data)
    except ValidationError as exc:
        err = exc.errors()[0]
        field = "options." + ".".join(str(p) for p in err["loc"])
        raise Problem(422, "invalid_options", f"{field}: {err['msg']}", field=field) from None


def base_url(request: Request) -> str:
    return str(request.base_url).rstrip("/")


def load_job(job_id: uuid.UUID, key: CurrentKey) -> Job:
    """The caller's job or 404 (another key's job answers exactly like a missing one)."""
    with session_scope() as session:
        job = service.owned_job(session, job_id=job_id, owner_id=key.id)
        if job is None:
            raise Problem(404, "job_not_found", f"no job {job_id}")
        return job


OwnedJob = Annotated[Job, Depends(load_job)]


@router.post("", status_code=202, response_model=JobOut,
             summary="Submit a mesh (and optional motion, or an edited skeleton to re-skin with) for rigging",
             responses=problem_responses(404, 409, 413, 415, 422, 503, examples={
                 404: ("job_not_found", "no job 3fa85f64-5717-4562-b3fc-2c963f66afa6 (source_job)", "source_job"),
                 409: ("idempotency_conflict", "this Idempotency-Key was used with a different request", "Idempotency-Key"),
                 422: ("invalid_options", "options.max_joints: Input should be less than or equal to 256", "options.max_joints")}),
             openapi_extra=json_part_encoding("options"))
def submit_job(
    request: Request,
    response: Response,
    key: CurrentKey,
    mesh: Annotated[UploadFile, File(description="GLB, glTF (embedded buffers), OBJ, PLY or STL")],
    motion: Annotated[UploadFile | None, File(description="BVH, or GLB/glTF carrying animation clips")] = None,
    options: Annotated[str | None, Form(description="JobOptions as JSON (a part of type application/json); every field has a default",
                                        json_schema_extra=json_part(JobOptions, example=OPTIONS_EXAMPLE))] = None,
    skeleton: Annotated[UploadFile | None, File(description="an edited skeleton.json to re-skin with "
                                                            "(with options.skeleton 'keep')")] = None,
    source_job: Annotated[uuid.UUID | None, Form(description="the job whose skeleton was edited (links the two)")] = None,
    callback_url: Annotated[str | None, Form(description="http(s) URL that receives the webhook events of this job "
                                                     "(default: the webhook URL of the key)")] = None,
    idempotency_key: Annotated[str | None, Header(alias="Idempotency-Key", max_length=200)] = None,
) -> JobOut:
    job_options = parse_options(options)
    callback = checked_callback_url(callback_url, field="callback_url")
    check_submit(key, get_settings().quotas, request.headers.get("content-length"))
    if skeleton is not None and job_options.skeleton != "keep":
        raise Problem(422, "invalid_options", "a skeleton file is used as it is: set options.skeleton to 'keep'",
                      field="options.skeleton")
    if source_job is not None:
        load_job(source_job, key)  # 404 unless it is the caller's
    settings = get_settings()
    storage = get_storage()
    stored_mesh = store_upload(storage, mesh, kind="mesh", field="mesh", max_bytes=settings.max_upload_bytes)
    stored_motion = store_upload(storage, motion, kind="motion", field="motion", max_bytes=settings.max_upload_bytes) if motion else None
    stored_skeleton = store_skeleton(storage, skeleton, max_bytes=settings.max_upload_bytes) if skeleton else None
    with session_scope() as session:
        try:
            job, created = service.create_job(session, owner_id=key.id, mesh=stored_mesh, motion=stored_motion,
                                              options=job_options, idempotency_key=idempotency_key,
                                              skeleton=stored_skeleton, source_job_id=source_job,
                                              callback_url=callback)
        except service.IdempotencyConflict:
            raise Problem(409, "idempotency_conflict", "this Idempotency-Key was used with a different request",
                          field="Idempotency-Key") from None
        job_id = job.id
    if created:
        enqueue_job(job_id)
    response.headers["Location"] = f"{router.prefix}/{job_id}"
    with session_scope() as session:
        return service.to_schema(session.get_one(Job, job_id), base_url(request))


@router.get("", response_model=JobPage, summary="List your jobs, newest first", responses=problem_responses(422, examples={
    422: ("invalid_cursor", "cursor is malformed", "cursor")}))
def list_jobs(
    request: Request, key: CurrentKey, status: JobStatus | None = None,
    limit: Annotated[int, Query(ge=1, le=100)] = 20, cursor: str | None = None,
) -> JobPage:
    with session_scope() as session:
        try:
            jobs, next_cursor = service.list_jobs(session, owner_id=key.id, status=status, limit=limit, cursor=cursor)
        except ValueError:
            raise Problem(422, "invalid_cursor", "cursor is malformed", field="cursor") from None
        return JobPage(items=[service.to_schema(j, base_url(request)) for j in jobs], next_cursor=next_cursor)


@router.get("/{job_id}", response_model=JobOut, summary="One job's status, progress, error and artifacts",
            responses={304: {"description": "Not Modified: the job is as the If-None-Match ETag says"}, **problem_responses(404, 422)})
async def get_job(request: Request, job_id: uuid.UUID, key: CurrentKey,
                  if_none_match: Annotated[str | None, Header(alias="If-None-Match", description="an ETag from an earlier answer: "
                                                              "304 when the job has not changed")] = None) -> Response:
    view = await owned_view(job_id, key, base_url(request))  # no database read while the job is unchanged (api.jobs.views)
    return conditional(view.body, view.etag, if_none_match, request.headers.get("accept-encoding"), lambda: view.body_gzip)


@router.post("/{job_id}/cancel", status_code=202, response_model=JobOut, summary="Cancel a queued or running job",
             responses=problem_responses(404, 409, 422))
def cancel_job(request: Request, response: Response, job: OwnedJob) -> JobOut:
    with session_scope() as session:
        if not state.cancel(session, job.id):
            raise Problem(409, "job_finished", f"job is already {job.status}")
        response.headers["Location"] = f"{router.prefix}/{job.id}"
        return service.to_schema(session.get_one(Job, job.id), base_url(request))


@router.get("/{job_id}/artifacts/{name}", summary="Download an artifact", response_class=FileResponse,
            responses={200: {"description": "the artifact's bytes", "content": {"application/octet-stream": BINARY}},
                       **problem_responses(404, 422, examples={404: ("artifact_not_found", "job has no artifact 'rigged.fbx'", None)})})
def download_artifact(job: OwnedJob, name: str) -> Response:
    return artifact_response(find_artifact(job, name))


@router.get("/{job_id}/artifacts.zip", summary="Download every artifact as one zip", response_class=StreamingResponse,
            operation_id="downloadAllArtifacts",
            responses={200: {"description": "a zip of every artifact", "content": {"application/zip": BINARY}},
                       **problem_responses(404, 422, examples={404: ("artifact_not_found", "job has no artifacts", None)})})
def download_all(job: OwnedJob) -> StreamingResponse:
    return zip_response(job)


@router.post("/{job_id}/rerun", status_code=202, response_model=JobOut, summary="Run a job again on the same inputs and options",
             responses=problem_responses(404, 422))
def rerun_job(request: Request, response: Response, key: CurrentKey, job: OwnedJob) -> JobOut:
    check_submit(key, get_settings().quotas, None)
    with session_scope() as session:
        again = service.rerun_job(session, job=session.get_one(Job, job.id))
        again_id = again.id
    enqueue_job(again_id)
    response.headers["Location"] = f"{router.prefix}/{again_id}"
    with session_scope() as session:
        return service.to_schema(session.get_one(Job, again_id), base_url(request))


@router.delete("/{job_id}", status_code=204, summary="Delete a job with its artifacts and uploads (canceled first when active)",
               responses=problem_responses(404, 422))
def delete_job(job: OwnedJob) -> Response:
    lifecycle.delete_job(job.id)
    return Response(status_code=204)


@router.get("/{job_id}/events", summary="Server-sent events: one per status/stage/progress change",
            response_class=StreamingResponse, operation_id="streamJobEvents",
            responses={200: {"description": "`event: job` with the job's JSON as data, until it ends",
                             "content": {"text/event-stream": {"schema": {"type": "string"}}}}, **problem_responses(404, 422)})
async def job_events(request: Request, job_id: uuid.UUID, key: CurrentKey) -> StreamingResponse:
    base = base_url(request)
    await owned_view(job_id, key, base)  # 404 before the stream starts
    return StreamingResponse(job_stream(job_id, base), media_type="text/event-stream",
                             headers={"Cache-Control": "no-cache", "X-Accel-Buffering": "no"})

"""Response models of the jobs API."""

from __future__ import annotations

import uuid
from datetime import datetime
from typing import Literal

from pydantic import BaseModel, ConfigDict, Field

from api.jobs.examples import JOB_EXAMPLE
from api.webhooks.schemas import WebhookDeliveryOut

JobStatus = Literal["queued", "running", "succeeded", "failed", "canceled"]


class JobError(BaseModel):
    code: str
    message: str


class JobWarning(BaseModel):
    """A stage notice or a quality check past its threshold (`hard`: past the failing one)."""

    code: str
    stage: str
    message: str
    figure: float | None = None
    threshold: float | None = None
    hard: bool = False
    frame: int | None = Field(None, description="worst animation frame, for checks over a clip")


class ArtifactOut(BaseModel):
    name: str
    media_type: str
    size: int
    sha256: str
    url: str = Field(description="the API download (send the key in the Authorization header)")
    download_url: str = Field(description="a short-lived link that needs no key (signed, or presigned by the object store)")


class InputFile(BaseModel):
    filename: str
    format: str
    size: int
    sha256: str


class JobOut(BaseModel):
    model_config = ConfigDict(json_schema_extra={"examples": [JOB_EXAMPLE]})

    id: uuid.UUID
    status: JobStatus
    stage: str | None
    progress: float
    created_at: datetime
    started_at: datetime | None
    finished_at: datetime | None
    options: dict
    attempts: int
    mesh: InputFile
    motion: InputFile | None
    skeleton: InputFile | None = Field(None, description="the edited skeleton.json this job re-skins with")
    source_job_id: uuid.UUID | None = Field(None, description="the job whose skeleton was edited into this one")
    error: JobError | None
    warnings: list[JobWarning]
    artifacts: list[ArtifactOut]
    callback_url: str | None = Field(None, description="where this job's webhook events go (else the key's default URL)")
    webhooks: list[WebhookDeliveryOut] = Field(default_factory=list, description="delivery log of this job's webhook events")
    download_all_url: str | None = Field(None, description="a short-lived link to every artifact in one zip, no key needed")


class JobPage(BaseModel):
    items: list[JobOut]
    next_cursor: str | None

"""Response models of the jobs API."""

from __future__ import annotations

import uuid
from datetime import datetime
from typing import Literal

from pydantic import BaseModel

JobStatus = Literal["queued", "running", "succeeded", "failed", "canceled"]


class JobError(BaseModel):
    code: str
    message: str


class ArtifactOut(BaseModel):
    name: str
    media_type: str
    size: int
    sha256: str
    url: str


class InputFile(BaseModel):
    filename: str
    format: str
    size: int
    sha256: str


class JobOut(BaseModel):
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
    error: JobError | None
    artifacts: list[ArtifactOut]


class JobPage(BaseModel):
    items: list[JobOut]
    next_cursor: str | None

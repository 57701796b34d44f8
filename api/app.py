"""The FastAPI application factory."""

from __future__ import annotations

import tempfile
from pathlib import Path

from fastapi import FastAPI
from fastapi.middleware.gzip import GZipMiddleware
from fastapi.staticfiles import StaticFiles

from api import access_log, docs_pages, errors, health
from api.http_cache import GZIP_MIN_BYTES
from api.jobs.router import router as jobs_router
from api.jobs.signed_router import router as files_router
from api.keys.router import router as keys_router
from api.metrics import router as metrics_router
from api.openapi import DocumentedAPI, operation_id
from api.security_headers import SecurityHeaders
from api.settings import get_settings
from api.upload_limit import UploadLimit
from api.webhooks.router import router as webhook_router

WEB_DIR = Path(__file__).resolve().parents[1] / "web"
# Room for the multipart envelope and a motion file next to a mesh at the cap.
BODY_SLACK_BYTES = 1024 * 1024


API_DESCRIPTION = """Automatic rigging and skinning of 3D characters.

Every `/api/v1` route needs an API key as `Authorization: Bearer <key>` (`rigforge keys create` on the server),
but the signed download links a job's JSON gives (`/api/v1/files/...`).
Every error is `application/problem+json` (the `ProblemDetails` schema) with a stable `code`, and `field` when one
input is to blame. Upload a mesh with `submitJob`, follow it with `getJob` or `streamJobEvents`, then download
its artifacts."""


def create_app() -> FastAPI:
    settings = get_settings()
    settings.data_dir.mkdir(parents=True, exist_ok=True)
    spool = settings.storage_dir / "tmp"
    spool.mkdir(parents=True, exist_ok=True)
    tempfile.tempdir = str(spool)  # multipart spooling stays inside the data directory
    app = DocumentedAPI(title="RigForge", version="0.1.0", generate_unique_id_function=operation_id, docs_url=None, redoc_url=None,
                        description=API_DESCRIPTION)
    errors.install(app)
    access_log.install()  # no keys or signed links in access log lines
    app.include_router(docs_pages.router)
    app.include_router(health.router)
    app.include_router(jobs_router)
    app.include_router(files_router)
    app.include_router(keys_router)
    app.include_router(webhook_router)
    app.include_router(metrics_router)
    app.add_middleware(GZipMiddleware, minimum_size=GZIP_MIN_BYTES)  # the viewer bundle is ~660 KB raw, ~170 KB gzipped; SSE is excluded
    app.add_middleware(UploadLimit, max_bytes=2 * settings.max_upload_bytes + BODY_SLACK_BYTES)
    app.add_middleware(SecurityHeaders)  # outermost: also on 413s from UploadLimit
    dist = WEB_DIR / "dist"
    if dist.is_dir():
        app.mount("/", StaticFiles(directory=dist, html=True), name="web")
    return app

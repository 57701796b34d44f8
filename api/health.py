"""/healthz (process up) and /readyz (database, broker and storage reachable; the embedded worker alive)."""

from __future__ import annotations

from fastapi import APIRouter
from fastapi.responses import JSONResponse
from pydantic import BaseModel, Field
from sqlalchemy import text

from api.db import get_engine

router = APIRouter(tags=["health"])


class Readiness(BaseModel):
    """What /readyz answers, ready (200) or not (503)."""

    status: str = Field(examples=["ready"], description="`ready` or `not_ready`")
    checks: dict[str, str] = Field(examples=[{"database": "ok", "broker": "ok", "storage": "ok"}],
                                   description="`ok`, or the error of each check")


@router.get("/healthz", summary="The process is up", operation_id="getHealth")
async def healthz() -> dict:
    """On the event loop: a liveness probe costs no thread."""
    return {"status": "ok"}


def _check_broker() -> None:
    from worker.celery_app import make_celery

    with make_celery().connection_for_write() as conn:
        conn.ensure_connection(max_retries=1, timeout=2)


def _check_storage() -> None:
    from api.storage import get_storage

    get_storage().check()


def _check_database() -> None:
    with get_engine().connect() as conn:
        conn.execute(text("SELECT 1"))


@router.get("/readyz", summary="Database, broker and storage are reachable", operation_id="getReadiness", response_model=Readiness,
            responses={503: {"model": Readiness, "description": "a check failed (the same body, `not_ready`)"}})
def readyz() -> JSONResponse:
    checks = {}
    for name, check in (("database", _check_database), ("broker", _check_broker), ("storage", _check_storage)):
        try:
            check()
            checks[name] = "ok"
        except Exception as exc:  # noqa: BLE001 - report any failure as not ready
            checks[name] = f"error: {type(exc).__name__}: {exc}"[:300]
    from worker.embedded import active

    if (embedded := active()) is not None:  # `rigforge serve` supervising its own worker
        checks["worker"] = embedded.status()
    ready = all(v == "ok" for v in checks.values())
    return JSONResponse({"status": "ready" if ready else "not_ready", "checks": checks}, status_code=200 if ready else 503)

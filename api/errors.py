"""RFC 9457 problem+json for every error, with a stable `code` (and `field` where one is to blame)."""

from __future__ import annotations

import logging

from fastapi import FastAPI, Request
from fastapi.exceptions import RequestValidationError
from fastapi.responses import JSONResponse
from starlette.exceptions import HTTPException as StarletteHTTPException

from simcore.errors import InvalidInput, LimitExceeded, SimcoreError, UnsupportedFormat

log = logging.getLogger("rigforge.api")
PROBLEM = "application/problem+json"
TITLES = {400: "Bad Request", 401: "Unauthorized", 403: "Forbidden", 404: "Not Found", 405: "Method Not Allowed", 409: "Conflict",
          429: "Too Many Requests",
          413: "Content Too Large", 415: "Unsupported Media Type", 422: "Unprocessable Content", 500: "Internal Server Error",
          503: "Service Unavailable"}


class Problem(Exception):
    """An error answered as problem+json."""

    def __init__(self, status: int, code: str, detail: str, *, field: str | None = None, headers: dict | None = None) -> None:
        super().__init__(detail)
        self.status, self.code, self.detail, self.field, self.headers = status, code, detail, field, headers


def problem_body(status: int, code: str, detail: str, field: str | None = None, errors: list | None = None) -> dict:
    body = {"type": f"https://rigforge.dev/problems/{code}", "title": TITLES.get(status, "Error"), "status": status,
            "detail": detail, "code": code}
    if field:
        body["field"] = field
    if errors:
        body["errors"] = errors
    return body


def problem_response(status: int, code: str, detail: str, field: str | None = None, errors: list | None = None,
                     headers: dict | None = None) -> JSONResponse:
    return JSONResponse(problem_body(status, code, detail, field, errors), status_code=status, media_type=PROBLEM, headers=headers)


def status_for(exc: SimcoreError) -> int:
    if isinstance(exc, UnsupportedFormat):
        return 415
    if isinstance(exc, LimitExceeded):
        return 413
    return 422 if isinstance(exc, InvalidInput) else 400


def install(app: FastAPI) -> None:
    """Register the handlers that turn every error into problem+json."""

    @app.exception_handler(Problem)
    async def _problem(_: Request, exc: Problem) -> JSONResponse:
        return problem_response(exc.status, exc.code, exc.detail, exc.field, headers=exc.headers)

    @app.exception_handler(SimcoreError)
    async def _simcore(_: Request, exc: SimcoreError) -> JSONResponse:
        return problem_response(status_for(exc), exc.code, str(exc), exc.field)

    @app.exception_handler(RequestValidationError)
    async def _validation(_: Request, exc: RequestValidationError) -> JSONResponse:
        errors = [{"field": ".".join(str(p) for p in e["loc"] if p != "body"), "message": e["msg"]} for e in exc.errors()]
        first = errors[0] if errors else {"field": None, "message": "invalid request"}
        return problem_response(422, "validation_error", f"{first['field']}: {first['message']}", first["field"], errors)

    @app.exception_handler(StarletteHTTPException)
    async def _http(_: Request, exc: StarletteHTTPException) -> JSONResponse:
        code = {400: "invalid_request", 404: "not_found", 405: "method_not_allowed", 401: "unauthorized"}.get(exc.status_code, "http_error")
        return problem_response(exc.status_code, code, str(exc.detail), headers=getattr(exc, "headers", None))

    @app.exception_handler(Exception)
    async def _unexpected(_: Request, exc: Exception) -> JSONResponse:
        log.exception("unhandled error", exc_info=exc)
        return problem_response(500, "internal_error", "an unexpected error occurred; it has been logged")

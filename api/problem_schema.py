"""The problem+json schema of every API error, and the OpenAPI `responses` entries that document it."""

from __future__ import annotations

from typing import Any

from pydantic import BaseModel, ConfigDict, Field

from api.errors import PROBLEM, TITLES, problem_body

PROBLEM_REF = "#/components/schemas/ProblemDetails"

Example = tuple[str, str, str | None]  # (code, detail, field)
# One typical problem per status; routes give their own where theirs differ.
TYPICAL: dict[int, Example] = {
    400: ("invalid_request", "the request could not be read", None),
    401: ("unauthorized", "send an API key as 'Authorization: Bearer <key>'", None),
    403: ("admin_required", "only an admin key manages keys (`rigforge keys create --admin` on the server)", None),
    404: ("job_not_found", "no job 3fa85f64-5717-4562-b3fc-2c963f66afa6", None),
    409: ("job_finished", "job is already succeeded", None),
    413: ("upload_too_large", "'mesh' is larger than 200 MB", "mesh"),
    415: ("unsupported_format", "FBX meshes are not supported: export GLB, glTF, OBJ, PLY or STL", "mesh"),
    422: ("validation_error", "limit: Input should be less than or equal to 100", "limit"),
    429: ("rate_limited", "too many requests for this API key; retry after the Retry-After seconds", None),
    503: ("server_busy", "too many uploads are being checked right now; retry shortly", None),
}


class FieldError(BaseModel):
    """One invalid input of a 422 `validation_error`."""

    field: str
    message: str


class ProblemDetails(BaseModel):
    """An RFC 9457 problem: every error of the API is answered with one, as `application/problem+json`."""

    model_config = ConfigDict(extra="forbid")

    type: str = Field(description="URI of the problem type, ending with `code`", examples=["https://rigforge.dev/problems/job_not_found"])
    title: str = Field(description="the HTTP status' reason phrase", examples=["Not Found"])
    status: int = Field(description="the HTTP status code", examples=[404])
    detail: str = Field(description="what went wrong, for a person", examples=["no job 3fa85f64-5717-4562-b3fc-2c963f66afa6"])
    code: str = Field(description="stable machine-readable cause (`job_not_found`, `invalid_options`, ...)", examples=["job_not_found"])
    field: str | None = Field(None, description="the input to blame, dotted for nested options (`options.max_joints`)")
    errors: list[FieldError] | None = Field(None, description="every invalid input of a `validation_error`")


def problem_responses(*statuses: int, examples: dict[int, Example] | None = None) -> dict[int | str, dict[str, Any]]:
    """OpenAPI `responses` for these error statuses, each a problem+json body with an example.

    `examples` gives a route's own (code, detail, field) by status, e.g. `{409: ("job_active", "job is running", None)}`.
    """
    out: dict[int | str, dict[str, Any]] = {}
    for status in statuses:
        code, detail, field = (examples or {}).get(status, TYPICAL[status])
        example = problem_body(status, code, detail, field)
        out[status] = {"description": f"{TITLES.get(status, 'Error')} (`{code}`, ...)",
                       "content": {PROBLEM: {"schema": {"$ref": PROBLEM_REF}, "example": example}}}
    return out

"""/openapi.json is client-ready: camelCase operation ids, the bearer scheme, problem+json errors, typed options."""

from __future__ import annotations

import re

from api.jobs.examples import JOB_EXAMPLE
from api.jobs.schemas import JobOut
from api.problem_schema import ProblemDetails
from simcore.options import JobOptions

PROBLEM_REF = {"$ref": "#/components/schemas/ProblemDetails"}


def _operations(spec: dict) -> list[tuple[str, str, dict]]:
    return [(method, path, op) for path, ops in spec["paths"].items() for method, op in ops.items()]


def test_operation_ids_are_camel_case_verbs_and_the_job_ones_have_their_names(client):
    spec = client.get("/openapi.json").json()
    ids = {op["operationId"] for _, _, op in _operations(spec)}
    assert all(re.fullmatch(r"[a-z]+(?:[A-Z][a-z]+)*", i) for i in ids), ids
    assert {"submitJob", "getJob", "listJobs", "cancelJob", "deleteJob", "downloadArtifact", "streamJobEvents"} <= ids


def test_every_api_route_needs_the_bearer_scheme_or_a_signed_link_and_documents_its_401(client):
    spec = client.get("/openapi.json").json()
    assert spec["components"]["securitySchemes"]["bearerAuth"] == {
        "type": "http", "scheme": "bearer", "description": "an API key: `Authorization: Bearer <key>`"}
    for method, path, op in _operations(spec):
        signed = any(p["name"] == "sig" for p in op.get("parameters", []))
        if path.startswith("/api/v1/") and not signed:
            assert op.get("security") == [{"bearerAuth": []}], (method, path)
            assert "401" in op["responses"], (method, path)


def test_every_error_response_is_problem_json_with_an_example_that_fits_the_schema(client):
    spec = client.get("/openapi.json").json()
    assert "HTTPValidationError" not in spec["components"]["schemas"]  # FastAPI's default 422 never answers here
    for method, path, op in _operations(spec):
        for status, response in op["responses"].items():
            if int(status) < 400 or path == "/readyz":
                continue
            assert list(response["content"]) == ["application/problem+json"], (method, path, status)
            body = response["content"]["application/problem+json"]
            assert body["schema"] == PROBLEM_REF
            example = ProblemDetails.model_validate(body["example"])
            assert example.status == int(status) and example.type.endswith(example.code), (method, path, status)


def test_real_errors_fit_the_documented_problem_schema(client, auth):
    answers = [client.get("/api/v1/jobs"), client.get("/api/v1/jobs/not-a-uuid", headers=auth),
               client.get("/api/v1/jobs?limit=0", headers=auth),
               client.post("/api/v1/jobs", headers=auth, files={"mesh": ("m.glb", b"glTF")}, data={"options": '{"max_joints": 1}'})]
    for r in answers:
        assert r.headers["content-type"] == "application/problem+json" and r.status_code >= 400
        ProblemDetails.model_validate(r.json())
    assert answers[-1].json()["field"] == "options.max_joints"


def test_more_sequence_bones_than_max_joints_is_a_problem_naming_the_field(client, auth):
    r = client.post("/api/v1/jobs", headers=auth, files={"mesh": ("m.glb", b"glTF")},
                    data={"options": '{"max_joints": 16, "sequence_bones": 32}'})
    assert r.status_code == 422 and r.headers["content-type"] == "application/problem+json"
    assert r.json()["field"] == "options.sequence_bones" and "max_joints" in r.json()["detail"]


def test_the_options_part_is_documented_as_json_of_job_options(client):
    spec = client.get("/openapi.json").json()
    body = spec["paths"]["/api/v1/jobs"]["post"]["requestBody"]["content"]["multipart/form-data"]
    assert body["encoding"]["options"] == {"contentType": "application/json"}
    form = spec["components"]["schemas"][body["schema"]["$ref"].rsplit("/", 1)[1]]
    options = form["properties"]["options"]
    assert options["allOf"] == [{"$ref": "#/components/schemas/JobOptions"}]
    JobOptions.model_validate(options["examples"][0])
    assert set(spec["components"]["schemas"]["JobOptions"]["properties"]) == set(JobOptions.model_fields)


def test_the_job_example_fits_the_job_schema(client):
    job = JobOut.model_validate(JOB_EXAMPLE)
    assert job.status == "succeeded" and job.artifacts and job.warnings
    [shown] = client.get("/openapi.json").json()["components"]["schemas"]["JobOut"]["examples"]
    assert shown == _without_nulls(JOB_EXAMPLE)  # FastAPI leaves nulls out of the document


def _without_nulls(node: object) -> object:
    if isinstance(node, dict):
        return {k: _without_nulls(v) for k, v in node.items() if v is not None}
    return [_without_nulls(v) for v in node] if isinstance(node, list) else node

"""The OpenAPI document generated clients are built from.

camelCase operation ids (`submitJob`), the problem+json schema of every error, and JobOptions as a component:
the `options` part of the upload form is documented as JSON of it, though the route reads it as a string to
answer its own problem (`invalid_options` naming the option).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from fastapi import FastAPI
from fastapi.routing import APIRoute
from pydantic import BaseModel
from pydantic.json_schema import models_json_schema

from api.problem_schema import ProblemDetails
from simcore.options import JobOptions

REF_TEMPLATE = "#/components/schemas/{model}"
BINARY = {"schema": {"type": "string", "format": "binary"}}  # a response body that is a file
# Models that only `responses` entries and JSON form parts refer to, so FastAPI does not collect them itself.
COMPONENT_MODELS: tuple[type[BaseModel], ...] = (ProblemDetails, JobOptions)


def operation_id(route: APIRoute) -> str:
    """The route function's name in camelCase (`submit_job` → `submitJob`): generated clients' method names."""
    head, *rest = route.name.split("_")
    return head + "".join(word.capitalize() for word in rest)


def json_part(model: type[BaseModel], example: dict[str, Any] | None = None) -> Callable[[dict[str, Any]], None]:
    """`json_schema_extra` for a form field that carries `model` as JSON: its schema becomes the model's."""
    ref = REF_TEMPLATE.format(model=model.__name__)

    def as_reference(schema: dict[str, Any]) -> None:
        description = schema.get("description")
        schema.clear()
        schema["allOf"] = [{"$ref": ref}]  # a bare $ref here would make pydantic look the model up among its own
        if description:
            schema["description"] = description
        if example is not None:
            schema["examples"] = [example]

    return as_reference


def json_part_encoding(*fields: str) -> dict[str, Any]:
    """`openapi_extra` saying these multipart parts are sent as `application/json`."""
    encoding = {name: {"contentType": "application/json"} for name in fields}
    return {"requestBody": {"content": {"multipart/form-data": {"encoding": encoding}}}}


def mark_binary(node: Any) -> None:
    """Add `format: binary` to OpenAPI 3.1 file schemas (`contentMediaType: application/octet-stream`), in place:
    generators (openapi-python-client, openapi-generator) still recognise uploads by the 3.0 form."""
    if isinstance(node, dict):
        if node.get("type") == "string" and node.get("contentMediaType") == "application/octet-stream":
            node.setdefault("format", "binary")
        for value in node.values():
            mark_binary(value)
    elif isinstance(node, list):
        for value in node:
            mark_binary(value)


class DocumentedAPI(FastAPI):
    """FastAPI whose document also holds the component models listed in COMPONENT_MODELS, uploads marked binary."""

    def openapi(self) -> dict[str, Any]:
        if self.openapi_schema is None:
            spec = super().openapi()
            _, defs = models_json_schema([(m, "validation") for m in COMPONENT_MODELS], ref_template=REF_TEMPLATE)
            schemas = spec.setdefault("components", {}).setdefault("schemas", {})
            schemas.update(defs.get("$defs", {}))
            spec["components"]["schemas"] = dict(sorted(schemas.items()))
            mark_binary(spec["components"]["schemas"])
        return self.openapi_schema  # type: ignore[return-value]  # set by super().openapi()

"""web/dump_openapi.py: the document the dashboard's typed client is generated from."""

from __future__ import annotations

import importlib.util
import json
from pathlib import Path

from simcore.options import JobOptions

DUMP = Path(__file__).resolve().parents[2] / "web" / "dump_openapi.py"


def _refs(node: object) -> set[str]:
    if isinstance(node, dict):
        own = {node["$ref"]} if isinstance(node.get("$ref"), str) else set()
        return own.union(*(_refs(v) for v in node.values()))
    if isinstance(node, list):
        return set().union(*(_refs(v) for v in node))
    return set()


def test_dump_has_the_endpoints_the_page_calls_and_a_resolvable_job_options_schema(tmp_path, monkeypatch):
    import os
    import tempfile

    monkeypatch.chdir(tmp_path)  # the dump must not create .rigforge/ where it runs
    before = (os.environ.get("RIGFORGE_DATA_DIR"), tempfile.tempdir)
    spec_loader = importlib.util.spec_from_file_location("dump_openapi", DUMP)
    assert spec_loader is not None and spec_loader.loader is not None
    module = importlib.util.module_from_spec(spec_loader)
    spec_loader.loader.exec_module(module)
    spec = json.loads(json.dumps(module.openapi_document()))
    schemas = spec["components"]["schemas"]
    assert set(schemas["JobOptions"]["properties"]) == set(JobOptions.model_fields)
    assert {"MotionOptions", "RefineOptions", "JobOut", "JobPage", "KeyOut", "KeyCreated"} <= set(schemas)
    assert {f"#/components/schemas/{name}" for name in schemas} >= _refs(spec)  # every $ref resolves
    for path in ("/api/v1/jobs", "/api/v1/jobs/{job_id}", "/api/v1/jobs/{job_id}/events", "/api/v1/keys",
                 "/api/v1/keys/me", "/api/v1/keys/{key_id}/revoke"):
        assert path in spec["paths"], path
    assert not (tmp_path / ".rigforge").exists()
    assert (os.environ.get("RIGFORGE_DATA_DIR"), tempfile.tempdir) == before  # no leak into the calling process

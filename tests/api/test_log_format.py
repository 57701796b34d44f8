"""Logs: one JSON object per line with RIGFORGE_LOG_FORMAT=json, the job id on records about a job, text by default."""

from __future__ import annotations

import json
import logging

import pytest

from api.log_format import configure, job_context
from api.settings import Settings


@pytest.fixture
def restore_logging():
    root = logging.getLogger()
    handlers, level = root.handlers[:], root.level
    yield
    root.handlers[:] = handlers
    root.setLevel(level)


@pytest.mark.parametrize("fmt", ["json", "text"])
def test_records_about_a_job_carry_its_id(fmt, capsys, restore_logging):
    configure(Settings(log_format=fmt))
    with job_context("3fa85f64"):
        logging.getLogger("rigforge.worker").info("stage %s done", "skin")
    logging.getLogger("uvicorn.error").info("Started", extra={"color_message": "\x1b[36mStarted\x1b[0m"})
    first, second = capsys.readouterr().err.splitlines()
    if fmt == "json":
        record, other = json.loads(first), json.loads(second)
        assert record["message"] == "stage skin done" and record["job_id"] == "3fa85f64" and record["level"] == "INFO"
        assert record["logger"] == "rigforge.worker" and other["job_id"] is None and "color_message" not in other
    else:
        assert first.endswith("rigforge.worker: [job 3fa85f64] stage skin done") and second.endswith("uvicorn.error: Started")

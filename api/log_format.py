"""Log configuration of the API, `serve` and workers: human-readable lines by default, one JSON object per line with
`RIGFORGE_LOG_FORMAT=json` (python-json-logger), each carrying the job id of the job it is about, when known."""

from __future__ import annotations

import logging
import logging.config
from collections.abc import Iterator
from contextlib import contextmanager
from contextvars import ContextVar
from typing import Any

from pythonjsonlogger.core import RESERVED_ATTRS

from api.settings import Settings

_job_id: ContextVar[str | None] = ContextVar("job_id", default=None)
TEXT = "%(asctime)s %(levelname)s %(name)s: %(message)s"
JSON_FIELDS = "%(asctime)s %(levelname)s %(name)s %(message)s %(job_id)s %(process)d"


class JobIdFilter(logging.Filter):
    """Gives every record a `job_id`: its own (`extra={"job_id": ...}`) or that of the job this thread runs."""

    def filter(self, record: logging.LogRecord) -> bool:
        if getattr(record, "job_id", None) is None:
            record.job_id = _job_id.get()
        return True


class TextFormatter(logging.Formatter):
    """Human-readable lines; records about a job start with `[job <id>]`."""

    def formatMessage(self, record: logging.LogRecord) -> str:  # noqa: N802 - logging's naming
        line = super().formatMessage(record)
        job_id = getattr(record, "job_id", None)
        return line.replace(f"{record.name}: ", f"{record.name}: [job {job_id}] ", 1) if job_id else line


@contextmanager
def job_context(job_id: object) -> Iterator[None]:
    """Log records made inside (in this thread) carry `job_id`."""
    token = _job_id.set(str(job_id))
    try:
        yield
    finally:
        _job_id.reset(token)


def log_config(settings: Settings, level: str = "INFO") -> dict[str, Any]:
    """A logging.config.dictConfig for the root, uvicorn and celery loggers in the configured format."""
    formatter: dict[str, Any] = ({"()": "pythonjsonlogger.json.JsonFormatter", "fmt": JSON_FIELDS, "rename_fields": {
        "asctime": "time", "levelname": "level", "name": "logger"}, "reserved_attrs": [*RESERVED_ATTRS, "color_message"]}
        if settings.log_format == "json" else {"()": TextFormatter, "fmt": TEXT})
    handler = {"class": "logging.StreamHandler", "formatter": "main", "filters": ["job_id"], "stream": "ext://sys.stderr"}
    return {
        "version": 1,
        "disable_existing_loggers": False,
        "filters": {"job_id": {"()": JobIdFilter}},
        "formatters": {"main": formatter},
        "handlers": {"main": handler},
        "root": {"handlers": ["main"], "level": level},
        # uvicorn's own config would add handlers of its own: route its loggers through ours instead
        "loggers": {name: {"handlers": [], "propagate": True, "level": level} for name in ("uvicorn", "uvicorn.error", "uvicorn.access")},
    }


def configure(settings: Settings, level: str = "INFO") -> None:
    logging.config.dictConfig(log_config(settings, level))

"""Access log lines without secrets: the values of `key`, `sig` and `token` query parameters are masked.

The API takes keys only in the Authorization header and refuses them in URLs, but a client that still puts one
there must not get it written to the log; signed download links are masked too (they grant a download until they expire).
"""

from __future__ import annotations

import logging
import re

SECRET_QUERY = re.compile(r"(?<=[?&])(key|sig|token|api_key)=[^&#\s]*", re.IGNORECASE)
ACCESS_LOGGER = "uvicorn.access"


def redact(text: str) -> str:
    """`text` with the values of secret query parameters replaced by ***."""
    return SECRET_QUERY.sub(r"\1=***", text) if "=" in text else text  # most access log fields hold no query


class RedactSecrets(logging.Filter):
    """Masks secret query values in uvicorn's access records (args: client, method, path with query, version, status)."""

    def filter(self, record: logging.LogRecord) -> bool:
        if isinstance(record.args, tuple):
            record.args = tuple(redact(a) if isinstance(a, str) else a for a in record.args)
        elif isinstance(record.msg, str):
            record.msg = redact(record.msg)
        return True


def install() -> None:
    """Attach the filter to uvicorn's access logger (once; it then applies whatever handlers log it)."""
    logger = logging.getLogger(ACCESS_LOGGER)
    if not any(isinstance(f, RedactSecrets) for f in logger.filters):
        logger.addFilter(RedactSecrets())

"""Domain errors of the compute core, each with a stable machine-readable code."""

from __future__ import annotations


class SimcoreError(Exception):
    """Base class: `code` is stable and safe to show to API clients."""

    code = "simcore_error"

    def __init__(self, message: str, *, code: str | None = None, field: str | None = None) -> None:
        super().__init__(message)
        if code is not None:
            self.code = code
        self.field = field
        self.warnings: list[dict] = []  # the job's warnings up to the failure (set by the pipeline)


class InvalidInput(SimcoreError):
    """The user's file or options cannot be processed as given."""

    code = "invalid_input"


class UnsupportedFormat(SimcoreError):
    """The file is in a format we recognise but cannot read (e.g. FBX)."""

    code = "unsupported_format"


class LimitExceeded(SimcoreError):
    """The input is over a configured cap (vertices, joints, frames...)."""

    code = "limit_exceeded"


class Canceled(SimcoreError):
    """The job was canceled between stages."""

    code = "canceled"

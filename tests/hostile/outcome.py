"""Run a case through the layer that decides it and classify what happened.

File cases run the API's upload check (sniff, kind, glTF structure) and then what the worker reads
(ingest for meshes, the motion reader for clips) directly, without a job; options run the API's parser.
Anything but a domain error (SimcoreError/Problem) propagates: that is a 500 or an internal_error.
"""

from __future__ import annotations

import tempfile
from dataclasses import dataclass
from pathlib import Path
from types import SimpleNamespace
from typing import TYPE_CHECKING, cast

from api.errors import Problem, status_for
from api.jobs.router import parse_options
from api.jobs.uploads import check_structure, upload_format
from simcore.errors import SimcoreError
from simcore.options import JobOptions
from tests.hostile.case import OK, Case

if TYPE_CHECKING:
    from simcore.pipeline import PipelineState


@dataclass(frozen=True)
class Outcome:
    """rejected (a 4xx problem at submit), failed (a job that fails) or ok; code and field of the error."""

    kind: str
    code: str
    status: int | None = None
    field: str | None = None


def _rejected(exc: Problem | SimcoreError) -> Outcome:
    if isinstance(exc, Problem):
        return Outcome("rejected", exc.code, exc.status, exc.field)
    return Outcome("rejected", exc.code, status_for(exc), exc.field)


def _read_as_worker(path: Path, fmt: str, kind: str) -> None:
    if kind == "mesh":
        from simcore.ingest import ingest

        ingest(path.read_bytes(), fmt)
        return
    from simcore.motion.stage import load_uploaded_clip

    state = SimpleNamespace(options=JobOptions(), inputs=SimpleNamespace(motion_name="clip"))  # what the reader uses
    load_uploaded_clip(path, fmt, cast("PipelineState", state))


def file_outcome(case: Case, workdir: Path) -> Outcome:
    path = workdir / case.name
    path.write_bytes(case.data)
    try:
        fmt = upload_format(case.data[:64 * 1024], len(case.data), kind=case.kind, field=case.kind)
        check_structure(path, fmt, field=case.kind)
    except (Problem, SimcoreError) as exc:
        return _rejected(exc)
    try:
        _read_as_worker(path, fmt, case.kind)
    except SimcoreError as exc:
        return Outcome("failed", exc.code, None, exc.field)
    return Outcome("ok", OK)


def options_outcome(case: Case) -> Outcome:
    try:
        parse_options(case.data.decode("utf-8", "replace"))
    except Problem as exc:
        return _rejected(exc)
    return Outcome("ok", OK)


def outcome(case: Case) -> Outcome:
    """The outcome of a file or options case (request cases need the HTTP app)."""
    if case.kind == "options":
        return options_outcome(case)
    with tempfile.TemporaryDirectory() as tmp:
        return file_outcome(case, Path(tmp))

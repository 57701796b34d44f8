"""`--options JSON` of the local commands: JobOptions validated, or exit code 2 with the reason."""

from __future__ import annotations

import json

import typer
from pydantic import ValidationError

from simcore.options import JobOptions


def parse_job_options(text: str) -> JobOptions:
    """JobOptions from a JSON object; prints the error and exits with code 2 when it is not valid JSON or options."""
    try:
        return JobOptions.model_validate(json.loads(text))
    except (json.JSONDecodeError, ValidationError) as exc:
        typer.echo(f"invalid --options: {exc}", err=True)
        raise typer.Exit(2) from exc

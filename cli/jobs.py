"""`rigforge jobs list | get | cancel | delete | download | logs`: manage jobs on a running service.

Every command finds the service and key as cli.service_client says (the local install needs neither flag),
prints text or, with `--json`, the API's JSON, and exits 1 with the service's problem on one line (2 when
the service cannot be reached).
"""

from __future__ import annotations

import json
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Annotated, Any

import httpx
import typer
from rich.console import Console
from rich.table import Table

from cli.progress import stage_bar
from cli.service_client import JsonOption, KeyOption, ServiceError, UrlOption, call, connect, fetch_artifact, follow_job

app = typer.Typer(help="Manage jobs on a running service (list, get, cancel, delete, download, logs).", no_args_is_help=True)
JobId = Annotated[str, typer.Argument(help="job id")]
TERMINAL = ("succeeded", "failed", "canceled")


@contextmanager
def service(url: str | None, key: str | None) -> Iterator[httpx.Client]:
    """A client for the service; a ServiceError anywhere inside ends the command with its message."""
    try:
        with connect(url, key) as client:
            yield client
    except ServiceError as exc:
        typer.echo(f"error: {exc}", err=True)
        raise typer.Exit(exc.exit_code) from None


def _print_json(data: Any) -> None:
    typer.echo(json.dumps(data, indent=2))


def _size(n: int) -> str:
    size = float(n)
    for unit in ("B", "KB", "MB"):
        if size < 1024:
            return f"{size:.0f} {unit}" if unit == "B" else f"{size:.1f} {unit}"
        size /= 1024
    return f"{size:.1f} GB"


def _state(job: dict) -> str:
    if job["status"] in ("queued", "running") and job.get("stage"):
        return f"{job['status']} ({job['stage']} {job['progress']:.0%})"
    return job["status"]


@app.command("list")
def list_jobs(
    url: UrlOption = None, key: KeyOption = None, json_out: JsonOption = False,
    status: Annotated[str | None, typer.Option(help="only jobs with this status (queued, running, succeeded, failed, canceled)")] = None,
    limit: Annotated[int, typer.Option(min=1, max=100, help="jobs per page")] = 20,
    cursor: Annotated[str | None, typer.Option(help="the next_cursor of a previous page")] = None,
) -> None:
    """List your jobs, newest first."""
    with service(url, key) as client:
        params = {k: v for k, v in (("status", status), ("limit", limit), ("cursor", cursor)) if v is not None}
        page = call(client, "GET", "/api/v1/jobs", params=params).json()
    if json_out:
        _print_json(page)
        return
    table = Table("id", "status", "created", "mesh", "error", box=None)
    for job in page["items"]:
        error = job.get("error") or {}
        table.add_row(job["id"], _state(job), job["created_at"][:19], job["mesh"]["filename"], error.get("code") or "")
    Console(width=200).print(table)
    if page.get("next_cursor"):
        typer.echo(f"more: --cursor {page['next_cursor']}")


def describe(job: dict) -> list[str]:
    """The job as `label  value` lines: state, inputs, times, error, warnings, artifacts."""
    lines = [f"id         {job['id']}", f"status     {_state(job)}"]
    for label in ("mesh", "motion", "skeleton"):
        if job.get(label):
            lines.append(f"{label:<10} {job[label]['filename']} ({job[label]['format']}, {_size(job[label]['size'])})")
    lines += [f"{label:<10} {job[f'{label}_at']}" for label in ("created", "started", "finished") if job.get(f"{label}_at")]
    if job.get("error"):
        lines.append(f"error      [{job['error']['code']}] {job['error']['message']}")
    lines += [f"warning    [{w['code']}] {w['stage']}: {w['message']}" for w in job.get("warnings", [])]
    lines += [f"artifact   {a['name']}  {a['media_type']}  {_size(a['size'])}" for a in job.get("artifacts", [])]
    return lines


@app.command("get")
def get_job(job_id: JobId, url: UrlOption = None, key: KeyOption = None, json_out: JsonOption = False,
            wait: Annotated[bool, typer.Option("--wait", help="follow the job to its end first (exit 1 unless it succeeds)")] = False,
            ) -> None:
    """Show one job: status, stage, inputs, times, error, warnings and artifacts."""
    with service(url, key) as client:
        job = call(client, "GET", f"/api/v1/jobs/{job_id}").json()
        if wait and job["status"] not in TERMINAL:
            with stage_bar(f"job {job_id[:8]}") as update:
                job = follow_job(client, job, lambda j: update(j.get("stage") or j["status"], j["progress"]))
    if json_out:
        _print_json(job)
    else:
        typer.echo("\n".join(describe(job)))
    if wait and job["status"] != "succeeded":
        raise typer.Exit(1)


@app.command("cancel")
def cancel_job(job_id: JobId, url: UrlOption = None, key: KeyOption = None, json_out: JsonOption = False) -> None:
    """Cancel a queued or running job."""
    with service(url, key) as client:
        job = call(client, "POST", f"/api/v1/jobs/{job_id}/cancel", ok=(202,)).json()
    if json_out:
        _print_json(job)
    else:
        typer.echo(f"{job['id']} {job['status']}")


@app.command("delete")
def delete_job(job_id: JobId, url: UrlOption = None, key: KeyOption = None) -> None:
    """Delete a job with its artifacts and uploads (an active job is canceled first)."""
    with service(url, key) as client:
        call(client, "DELETE", f"/api/v1/jobs/{job_id}", ok=(204,))
    typer.echo(f"{job_id} deleted")


@app.command("download")
def download(
    job_id: JobId, url: UrlOption = None, key: KeyOption = None, json_out: JsonOption = False,
    output: Annotated[Path | None, typer.Option("-o", "--output", file_okay=False, help="folder (default: ./<job id>)")] = None,
    names: Annotated[list[str] | None, typer.Option("--name", help="only this artifact (repeatable)")] = None,
) -> None:
    """Download a job's artifacts (each checked against its sha256)."""
    out = output or Path(job_id)
    with service(url, key) as client:
        job = call(client, "GET", f"/api/v1/jobs/{job_id}").json()
        artifacts = [a for a in job["artifacts"] if not names or a["name"] in names]
        missing = sorted(set(names or []) - {a["name"] for a in artifacts})
        if missing or not artifacts:
            have = ", ".join(a["name"] for a in job["artifacts"]) or "none"
            raise ServiceError(f"job {job_id} ({job['status']}) has no artifact {' '.join(missing)}".rstrip() + f"; it has: {have}")
        out.mkdir(parents=True, exist_ok=True)
        written = [(fetch_artifact(client, job_id, a, out), a) for a in artifacts]
    if json_out:
        _print_json([{"name": a["name"], "path": str(p), "size": a["size"], "sha256": a["sha256"]} for p, a in written])
        return
    for path, artifact in written:
        typer.echo(f"{path}  ({_size(artifact['size'])})")


def _day_time(stamp: str | None) -> str:
    return (stamp or "")[:19].replace("T", " ").ljust(19)


def opening(job: dict) -> list[str]:
    """The job's first lines: submitted, and started when it has."""
    lines = [f"{_day_time(job['created_at'])}  submitted {job['mesh']['filename']}"]
    if job.get("started_at"):
        lines.append(f"{_day_time(job['started_at'])}  started (attempt {job['attempts']})")
    return lines


def closing(job: dict) -> list[str]:
    """The job's last lines: warnings, webhook deliveries and its end, once it has ended."""
    lines = [f"{'':19}  warning [{w['code']}] {w['stage']}: {w['message']}" for w in job.get("warnings", [])]
    for d in job.get("webhooks", []):
        last = d["attempts"][-1] if d["attempts"] else {}
        outcome = f"HTTP {last['status_code']}" if last.get("status_code") else last.get("error") or ""
        lines.append(f"{_day_time(last.get('at'))}  webhook {d['event']} {d['status']} after {len(d['attempts'])} attempt(s) {outcome}".rstrip())
    if job["status"] in TERMINAL:
        error = job.get("error")
        lines.append(f"{_day_time(job.get('finished_at'))}  {job['status']}" + (f" [{error['code']}] {error['message']}" if error else ""))
    return lines


@app.command("logs")
def logs(job_id: JobId, url: UrlOption = None, key: KeyOption = None,
         follow: Annotated[bool, typer.Option("-f", "--follow", help="then print each stage change until the job ends")] = False,
         ) -> None:
    """Print a job's history (submitted, started, warnings, webhook deliveries, end); -f follows a running job."""
    with service(url, key) as client:
        job = call(client, "GET", f"/api/v1/jobs/{job_id}").json()
        typer.echo("\n".join(opening(job)))
        if follow and job["status"] not in TERMINAL:
            last = [job.get("stage")]

            def stage_line(change: dict) -> None:
                if change["status"] not in TERMINAL and change.get("stage") and change["stage"] != last[-1]:
                    last.append(change["stage"])
                    typer.echo(f"{_day_time(None)}  {change['stage']} {change['progress']:.0%}")

            job = follow_job(client, job, stage_line)
    typer.echo("\n".join(closing(job)))

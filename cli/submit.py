"""`rigforge submit INPUT --url --key`: the HTTP client a studio's CI calls."""

from __future__ import annotations

import json
import uuid
from pathlib import Path
from typing import Annotated

import httpx
import typer

from cli.progress import stage_bar


def _fail(message: str, code: int = 1) -> typer.Exit:
    typer.echo(message, err=True)
    return typer.Exit(code)


def _problem(response: httpx.Response) -> str:
    try:
        body = response.json()
        return f"HTTP {response.status_code} [{body.get('code')}]{' ' + body['field'] if body.get('field') else ''}: {body.get('detail')}"
    except ValueError:
        return f"HTTP {response.status_code}: {response.text[:300]}"


def follow(client: httpx.Client, job: dict) -> dict:
    """Follow the job's SSE stream with a progress bar until it ends; returns the final job."""
    with stage_bar(f"job {job['id'][:8]}") as update, client.stream("GET", f"/api/v1/jobs/{job['id']}/events", timeout=None) as stream:
        for line in stream.iter_lines():
            if line.startswith("data: "):
                job = json.loads(line[6:])
                update(job.get("stage") or job["status"], job["progress"])
    return job


def submit(
    input: Annotated[Path, typer.Argument(exists=True, dir_okay=False, help="mesh file")],
    url: Annotated[str, typer.Option(envvar="RIGFORGE_URL", help="service URL, e.g. http://127.0.0.1:8000")],
    key: Annotated[str, typer.Option(envvar="RIGFORGE_KEY", help="API key")],
    motion: Annotated[Path | None, typer.Option(exists=True, dir_okay=False, help="motion clip")] = None,
    options: Annotated[str | None, typer.Option(help="JobOptions as JSON")] = None,
    wait: Annotated[bool, typer.Option("--wait", help="follow the job to its end")] = False,
    output: Annotated[Path | None, typer.Option("-o", "--output", help="download artifacts here (implies --wait)")] = None,
    idempotency_key: Annotated[str | None, typer.Option(help="retry-safe submission key (default: random)")] = None,
) -> None:
    """Upload a mesh, print the job id; with --wait, exit non-zero if the job does not succeed."""
    headers = {"Authorization": f"Bearer {key}", "Idempotency-Key": idempotency_key or str(uuid.uuid4())}
    with httpx.Client(base_url=url.rstrip("/"), headers=headers, timeout=httpx.Timeout(30, read=600)) as client:
        files = {"mesh": (input.name, input.open("rb"))}
        if motion:
            files["motion"] = (motion.name, motion.open("rb"))
        try:
            response = client.post("/api/v1/jobs", files=files, data={"options": options} if options else None)
        except httpx.HTTPError as exc:
            raise _fail(f"cannot reach {url}: {exc}", 2) from exc
        if response.status_code != 202:
            raise _fail(_problem(response))
        job = response.json()
        typer.echo(job["id"])
        if not (wait or output):
            return
        job = follow(client, job)
        if job["status"] != "succeeded":
            err = job.get("error") or {}
            raise _fail(f"job {job['status']}: [{err.get('code')}] {err.get('message')}")
        if output:
            output.mkdir(parents=True, exist_ok=True)
            for art in job["artifacts"]:
                with client.stream("GET", f"/api/v1/jobs/{job['id']}/artifacts/{art['name']}") as r, (output / art["name"]).open("wb") as f:
                    for chunk in r.iter_bytes():
                        f.write(chunk)
                typer.echo(f"{output / art['name']}  ({art['size']} bytes)")

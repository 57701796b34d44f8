"""`rigforge submit INPUT...`: the HTTP client a studio's CI calls (service and key as cli.service_client finds them).

One mesh: prints the job id; `--wait` follows it with a progress bar, `-o DIR` downloads its artifacts.
Several meshes or a folder (its .glb/.gltf/.zip/.obj/.ply/.stl files, sorted): at most `--concurrency` jobs in
flight, one line per job as it ends (`file<TAB>job id<TAB>status[<TAB>error]`, a count bar on a terminal),
artifacts in `DIR/<file stem>/`; the exit status is 1 when any job did not succeed.
"""

from __future__ import annotations

import hashlib
import uuid
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor, as_completed
from contextlib import ExitStack
from dataclasses import dataclass
from pathlib import Path
from typing import Annotated

import httpx
import typer

from cli.progress import count_bar, stage_bar
from cli.service_client import KeyOption, ServiceError, UrlOption, api_key, fetch_artifact, follow_job, problem_message, service_url

MESH_SUFFIXES = (".glb", ".gltf", ".zip", ".obj", ".ply", ".stl")
ClientFactory = Callable[[str], httpx.Client]  # idempotency key → a client for one job


@dataclass
class BatchResult:
    """One line of a batch: the file, its job id (None when the upload failed), final status, error text."""

    path: Path
    job_id: str | None
    status: str
    error: str = ""

    def line(self) -> str:
        return "\t".join([str(self.path), self.job_id or "-", self.status] + ([self.error] if self.error else []))


def _fail(message: str, code: int = 1) -> typer.Exit:
    typer.echo(message, err=True)
    return typer.Exit(code)


def _events(client: httpx.Client, job: dict, update: Callable[[str, float], None]) -> dict:
    return follow_job(client, job, lambda change: update(change.get("stage") or change["status"], change["progress"]))


def follow(client: httpx.Client, job: dict) -> dict:
    """Follow the job's SSE stream with a progress bar until it ends; returns the final job."""
    with stage_bar(f"job {job['id'][:8]}") as update:
        return _events(client, job, update)


def post_job(client: httpx.Client, mesh: Path, motion: Path | None, options: str | None,
             skeleton: Path | None = None, source_job: str | None = None) -> dict:
    """Upload one mesh (and motion, or an edited skeleton.json), streamed from disk; returns the queued job.
    Raises ServiceError."""
    data = {k: v for k, v in (("options", options), ("source_job", source_job)) if v}
    with ExitStack() as stack:
        files = {field: (path.name, stack.enter_context(path.open("rb")))
                 for field, path in (("mesh", mesh), ("motion", motion), ("skeleton", skeleton)) if path}
        try:
            response = client.post("/api/v1/jobs", files=files, data=data or None)
        except httpx.HTTPError as exc:
            raise ServiceError(f"cannot reach {client.base_url}: {exc}", 2) from exc
    if response.status_code != 202:
        raise ServiceError(problem_message(response))
    return response.json()


def download(client: httpx.Client, job: dict, output: Path) -> list[Path]:
    """Stream every artifact of a finished job into `output` (each checked against its sha256); returns the paths.
    Raises ServiceError."""
    output.mkdir(parents=True, exist_ok=True)
    return [fetch_artifact(client, job["id"], art, output) for art in job["artifacts"]]


def mesh_files(inputs: list[Path]) -> list[Path]:
    """Files named on the command line, and the mesh files (by suffix, sorted) inside named folders."""
    out: list[Path] = []
    for path in inputs:
        if path.is_dir():
            out += sorted(p for p in path.iterdir() if p.is_file() and p.suffix.lower() in MESH_SUFFIXES)
        else:
            out.append(path)
    return out


def _batch_job(make_client: ClientFactory, key: str, mesh: Path, motion: Path | None, options: str | None,
               wait: bool, output: Path | None) -> BatchResult:
    with make_client(key) as client:
        try:
            job = post_job(client, mesh, motion, options)
        except ServiceError as exc:
            return BatchResult(mesh, None, "rejected", str(exc))
        if not wait:
            return BatchResult(mesh, job["id"], job["status"])
        try:
            job = _events(client, job, lambda stage, fraction: None)
        except ServiceError as exc:
            return BatchResult(mesh, job["id"], "lost", str(exc))
        if job["status"] != "succeeded":
            err = job.get("error") or {}
            return BatchResult(mesh, job["id"], job["status"], f"[{err.get('code')}] {err.get('message')}")
        if output is not None:
            try:
                download(client, job, output / mesh.stem)
            except ServiceError as exc:
                return BatchResult(mesh, job["id"], "download_failed", str(exc))
        return BatchResult(mesh, job["id"], job["status"])


def run_batch(make_client: ClientFactory, meshes: list[Path], *, motion: Path | None = None,
              options: str | None = None, wait: bool = False, output: Path | None = None, concurrency: int = 4,
              idempotency_key: str | None = None, report: Callable[[BatchResult], None] = lambda r: None,
              ) -> list[BatchResult]:
    """Submit every mesh with at most `concurrency` jobs in flight; `report` sees each result as it ends.

    A retried batch with the same `idempotency_key` resubmits nothing: each file's key is derived from it.
    Returns the results in input order.
    """
    base = idempotency_key or str(uuid.uuid4())
    keys = [hashlib.sha256(f"{base}\0{k}\0{m}".encode()).hexdigest()[:32] for k, m in enumerate(meshes)]
    results: dict[int, BatchResult] = {}
    with ThreadPoolExecutor(max_workers=max(1, concurrency)) as pool:
        futures = {pool.submit(_batch_job, make_client, keys[k], m, motion, options, wait, output): k
                   for k, m in enumerate(meshes)}
        for future in as_completed(futures):
            results[futures[future]] = result = future.result()
            report(result)
    return [results[k] for k in range(len(meshes))]


def submit(
    inputs: Annotated[list[Path], typer.Argument(exists=True, help="mesh files or folders of them")],
    url: UrlOption = None,
    key: KeyOption = None,
    motion: Annotated[Path | None, typer.Option(exists=True, dir_okay=False, help="motion clip (for every mesh)")] = None,
    options: Annotated[str | None, typer.Option(help="JobOptions as JSON")] = None,
    wait: Annotated[bool, typer.Option("--wait", help="follow the jobs to their end")] = False,
    output: Annotated[Path | None, typer.Option("-o", "--output", help="download artifacts here (implies --wait)")] = None,
    idempotency_key: Annotated[str | None, typer.Option(help="retry-safe submission key (default: random)")] = None,
    concurrency: Annotated[int, typer.Option(min=1, max=64, help="jobs in flight at once (several inputs)")] = 4,
    skeleton: Annotated[Path | None, typer.Option(exists=True, dir_okay=False,
                                                  help="an edited skeleton.json to re-skin with (one mesh)")] = None,
    source_job: Annotated[str | None, typer.Option(help="the job whose skeleton was edited (links the two)")] = None,
) -> None:
    """Upload meshes and print their job ids; with --wait, exit non-zero if a job does not succeed."""
    meshes = mesh_files(inputs)
    if not meshes:
        raise _fail("no mesh files found (.glb .gltf .zip .obj .ply .stl)")

    try:
        base, secret = service_url(url), api_key(key)
    except ServiceError as exc:
        raise _fail(f"error: {exc}", exc.exit_code) from None

    def make_client(idem: str) -> httpx.Client:
        headers = {"Authorization": f"Bearer {secret}", "Idempotency-Key": idem}
        return httpx.Client(base_url=base, headers=headers, timeout=httpx.Timeout(30, read=600))

    if len(inputs) == 1 and not inputs[0].is_dir():
        _submit_one(make_client(idempotency_key or str(uuid.uuid4())), meshes[0], motion, options, wait, output,
                    skeleton, source_job)
        return
    if skeleton or source_job:
        raise _fail("--skeleton and --source-job go with one mesh")
    with count_bar("jobs") as update:
        done: list[BatchResult] = []

        def report(result: BatchResult) -> None:
            done.append(result)
            update(result.line(), len(done), len(meshes))

        results = run_batch(make_client, meshes, motion=motion, options=options, wait=wait or output is not None,
                            output=output, concurrency=concurrency, idempotency_key=idempotency_key, report=report)
    failed = [r for r in results if r.status not in ("succeeded", "queued", "running")]
    if failed:
        raise _fail(f"{len(failed)} of {len(results)} jobs did not succeed")


def _submit_one(client: httpx.Client, mesh: Path, motion: Path | None, options: str | None, wait: bool,
                output: Path | None, skeleton: Path | None, source_job: str | None) -> None:
    with client:
        try:
            job = post_job(client, mesh, motion, options, skeleton, source_job)
        except ServiceError as exc:
            raise _fail(str(exc), exc.exit_code) from exc
        typer.echo(job["id"])
        if not (wait or output):
            return
        try:
            job = follow(client, job)
        except ServiceError as exc:
            raise _fail(str(exc), exc.exit_code) from exc
        if job["status"] != "succeeded":
            err = job.get("error") or {}
            raise _fail(f"job {job['status']}: [{err.get('code')}] {err.get('message')}")
        if output:
            try:
                written = download(client, job, output)
            except ServiceError as exc:
                raise _fail(str(exc), exc.exit_code) from exc
            for path, art in zip(written, job["artifacts"]):
                typer.echo(f"{path}  ({art['size']} bytes)")

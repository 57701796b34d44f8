"""Where the CLI finds the service and its key, and how it turns HTTP failures into one clear line.

URL: `--url`, else `RIGFORGE_URL`, else the local `rigforge serve` (RIGFORGE_HOST/RIGFORGE_PORT, default
http://127.0.0.1:8000). Key: `--key`, else `RIGFORGE_API_KEY` (or the older `RIGFORGE_KEY`), else the local
install's `.rigforge/local-api-key` (under RIGFORGE_DATA_DIR) when it exists.
"""

from __future__ import annotations

import hashlib
import json
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Annotated, Any

import httpx
import typer

from api.settings import get_settings

UrlOption = Annotated[str | None, typer.Option("--url", envvar="RIGFORGE_URL", show_envvar=True,
                                               help="service URL (default: the local `rigforge serve`)")]
KeyOption = Annotated[str | None, typer.Option("--key", envvar=["RIGFORGE_API_KEY", "RIGFORGE_KEY"], show_envvar=True,
                                               help="API key (default: .rigforge/local-api-key when present)")]
JsonOption = Annotated[bool, typer.Option("--json", help="print the API's JSON instead of text")]
TIMEOUT = httpx.Timeout(30, read=600)


class ServiceError(Exception):
    """A request the service refused or could not answer; `exit_code` 2 when it is unreachable."""

    def __init__(self, message: str, exit_code: int = 1) -> None:
        super().__init__(message)
        self.exit_code = exit_code


def service_url(url: str | None) -> str:
    """The URL given, or the local service's."""
    if url:
        return url.rstrip("/")
    settings = get_settings()
    host = "127.0.0.1" if settings.host in ("0.0.0.0", "::", "") else settings.host  # a wildcard bind is reached locally
    return f"http://{host}:{settings.port}"


def api_key(key: str | None) -> str:
    """The key given, or the local install's; raises ServiceError saying how to get one."""
    if key:
        return key.strip()
    local = get_settings().local_key_file
    if local.is_file():
        return local.read_text().strip()
    raise ServiceError(f"no API key: pass --key, set RIGFORGE_API_KEY, or run this where `rigforge serve` keeps {local}")


def connect(url: str | None, key: str | None, headers: dict[str, str] | None = None) -> httpx.Client:
    """An HTTP client for the service with the key in the Authorization header."""
    return httpx.Client(base_url=service_url(url), headers={"Authorization": f"Bearer {api_key(key)}", **(headers or {})},
                        timeout=TIMEOUT)


def problem_message(response: httpx.Response) -> str:
    """One line from a problem+json answer (or the start of any other body)."""
    try:
        body = response.json()
        field = f" {body['field']}" if body.get("field") else ""
        return f"HTTP {response.status_code} [{body.get('code')}]{field}: {body.get('detail')}"
    except (ValueError, AttributeError):
        return f"HTTP {response.status_code}: {response.text[:300]}"


def call(client: httpx.Client, method: str, path: str, ok: tuple[int, ...] = (200,), **kwargs: Any) -> httpx.Response:
    """Send one request; raises ServiceError with the problem's line, or saying the service is unreachable."""
    try:
        response = client.request(method, path, **kwargs)
    except httpx.HTTPError as exc:
        raise ServiceError(f"cannot reach {client.base_url}: {exc}", 2) from exc
    if response.status_code not in ok:
        raise ServiceError(problem_message(response))
    return response


def job_events(client: httpx.Client, job_id: str) -> Iterator[dict]:
    """The job's JSON at each status, stage or progress change (its server-sent events), until it ends."""
    try:
        with client.stream("GET", f"/api/v1/jobs/{job_id}/events", timeout=httpx.Timeout(30, read=None)) as stream:
            if stream.status_code != 200:
                stream.read()
                raise ServiceError(problem_message(stream))
            for line in stream.iter_lines():
                if line.startswith("data: "):
                    yield json.loads(line[6:])
    except httpx.HTTPError as exc:
        raise ServiceError(f"lost the event stream of job {job_id} from {client.base_url}: {exc}", 2) from exc


def follow_job(client: httpx.Client, job: dict, on_change: Callable[[dict], None]) -> dict:
    """Feed each change of the job to `on_change` until it ends; returns the last state seen."""
    last = job
    for change in job_events(client, job["id"]):
        on_change(change)
        last = change
    return last


def fetch_artifact(client: httpx.Client, job_id: str, artifact: dict, out: Path) -> Path:
    """Stream one artifact to `out`/name and check its sha256 against the job's record; raises ServiceError."""
    path = out / artifact["name"]
    digest = hashlib.sha256()
    try:
        with client.stream("GET", f"/api/v1/jobs/{job_id}/artifacts/{artifact['name']}") as response:
            if response.status_code != 200:
                response.read()
                raise ServiceError(f"{artifact['name']}: {problem_message(response)}")
            with path.open("wb") as f:
                for chunk in response.iter_bytes():
                    digest.update(chunk)
                    f.write(chunk)
    except httpx.HTTPError as exc:
        raise ServiceError(f"cannot download {artifact['name']} from {client.base_url}: {exc}", 2) from exc
    if digest.hexdigest() != artifact["sha256"]:
        raise ServiceError(f"{path}: sha256 differs from the job's record (a damaged transfer): download again")
    return path

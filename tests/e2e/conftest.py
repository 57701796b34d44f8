"""Browser fixtures: a real `rigforge serve` on a free port and Debian's Chromium driven by Playwright."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path

import httpx
import pytest

from tests.integration.conftest import free_port

REPO = Path(__file__).resolve().parents[2]
CHROMIUM = Path(os.environ.get("RIGFORGE_CHROMIUM", "/usr/bin/chromium"))
ARTIFACTS = REPO / "test-artifacts"
PAGE_TIMEOUT_MS = 60_000  # every wait and action: the suite's 2-core CI box also runs the service and a browser
CHROMIUM_ARGS = ["--no-sandbox", "--disable-gpu", "--disable-background-networking"]


class Server:
    def __init__(self, url: str, data_dir: Path, log: Path) -> None:
        self.url, self.data_dir, self.log = url, data_dir, log

    @property
    def local_key(self) -> str:
        return (self.data_dir / "local-api-key").read_text().strip()


@pytest.fixture(scope="session")
def dashboard_build() -> Path:
    """web/dist, built by `npm run build` (the README's install step); fails with the command when missing."""
    dist = REPO / "web" / "dist"
    if not (dist / "index.html").exists() or not (dist / "assets" / "main.js").exists():
        pytest.fail("web/dist is missing: build the dashboard with `npm ci && npm run build` (make install does both)")
    return dist


@pytest.fixture(scope="session")
def dashboard_server(tmp_path_factory, dashboard_build) -> Iterator[Server]:
    """`rigforge serve` (API + embedded worker) on a free port with a fresh data directory."""
    data_dir = tmp_path_factory.mktemp("dashboard-data")
    port = free_port()
    log = data_dir / "serve.log"
    env = {**os.environ, "RIGFORGE_DATA_DIR": str(data_dir)}
    env.pop("RIGFORGE_DATABASE_URL", None)
    env.pop("RIGFORGE_BROKER_URL", None)
    with log.open("wb") as out:
        proc = subprocess.Popen([sys.executable, "-m", "cli.main", "serve", "--port", str(port)], cwd=REPO, env=env,
                                stdout=out, stderr=subprocess.STDOUT, start_new_session=True)
    url = f"http://127.0.0.1:{port}"
    try:
        deadline = time.monotonic() + 60
        while True:
            if proc.poll() is not None:
                pytest.fail(f"rigforge serve exited with {proc.returncode}:\n{log.read_text()[-3000:]}")
            try:
                if httpx.get(f"{url}/healthz", timeout=1).status_code == 200 and (data_dir / "local-api-key").exists():
                    break
            except httpx.HTTPError:
                pass
            if time.monotonic() > deadline:
                pytest.fail(f"rigforge serve did not answer /healthz within 60 s:\n{log.read_text()[-3000:]}")
            time.sleep(0.3)
        yield Server(url, data_dir, log)
    finally:
        proc.terminate()  # serve stops its embedded worker on SIGTERM
        try:
            proc.wait(20)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait()
        if os.environ.get("RIGFORGE_KEEP_SERVE_LOG"):
            shutil.copy(log, ARTIFACTS / "serve.log")


@pytest.fixture(scope="session")
def browser() -> Iterator[object]:
    if not CHROMIUM.exists():
        pytest.fail(f"Chromium not found at {CHROMIUM}: `make test` installs it (apt-get install -y chromium)")
    from playwright.sync_api import sync_playwright

    with sync_playwright() as p:
        b = p.chromium.launch(executable_path=str(CHROMIUM), args=CHROMIUM_ARGS)
        yield b
        b.close()


@pytest.fixture
def page(browser, dashboard_server):
    """A 1280×800 page whose requests outside the server are recorded (the dashboard must make none)."""
    ARTIFACTS.mkdir(exist_ok=True)
    context = browser.new_context(viewport={"width": 1280, "height": 800}, accept_downloads=True, base_url=dashboard_server.url)
    pg = context.new_page()
    pg.set_default_timeout(PAGE_TIMEOUT_MS)
    pg.external_requests = []
    pg.console_errors = []
    pg.on("request", lambda r: None if r.url.startswith((dashboard_server.url, "blob:", "data:")) else pg.external_requests.append(r.url))
    pg.on("console", lambda m: pg.console_errors.append(m.text) if m.type == "error" else None)
    pg.on("pageerror", lambda e: pg.console_errors.append(str(e)))
    yield pg
    context.close()

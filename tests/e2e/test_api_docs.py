"""/docs (Swagger UI) and /redoc (ReDoc) render in Chromium with nothing fetched from outside the server.
Screenshots land in test-artifacts/ (look at them)."""

from __future__ import annotations

import pytest
from playwright.sync_api import expect

from tests.e2e.conftest import ARTIFACTS

pytestmark = pytest.mark.browser


def test_swagger_ui_renders_offline_with_the_bearer_scheme_and_typed_options(page):
    page.goto("/docs")
    page.wait_for_selector("#operations-jobs-submitJob")
    assert page.locator(".opblock").count() >= 10
    assert page.locator("button.authorize").is_visible()  # the bearerAuth scheme
    page.screenshot(path=str(ARTIFACTS / "api-docs.png"))
    page.click("#operations-jobs-submitJob .opblock-summary")
    body = page.locator("#operations-jobs-submitJob .opblock-section-request-body")
    body.wait_for()
    options = body.locator("tr", has=page.get_by_text("options", exact=True))
    expect(options).to_contain_text("object")  # the JobOptions schema, not a string
    body.screenshot(path=str(ARTIFACTS / "api-docs-submit-job.png"))
    assert page.external_requests == [] and page.console_errors == []


def test_redoc_renders_offline(page):
    failed: list[tuple[str, str | None]] = []
    page.on("requestfailed", lambda r: failed.append((r.url, r.failure)))
    page.goto("/redoc")
    page.wait_for_selector("h2 >> text=Submit a mesh (and optional motion")  # the operation's heading, not the menu entry
    page.wait_for_selector("text=application/problem+json")
    page.screenshot(path=str(ARTIFACTS / "api-redoc.png"), full_page=False)
    # ReDoc 2 always tries its logo from cdn.redoc.ly: the docs CSP refuses it in the browser, nothing leaves.
    assert failed == [(url, "csp") for url in page.external_requests]
    assert all("violates the following Content Security Policy" in e for e in page.console_errors), page.console_errors

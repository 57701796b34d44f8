"""Editing a rig in the dashboard (real Chromium): move a joint, rename one, add and delete one, re-skin; the new
job is linked to the first and its skeleton has the moved joint. Screenshots: test-artifacts/edit-*.png."""

from __future__ import annotations

import json
import re

import httpx
import numpy as np
import pytest

from tests.e2e.conftest import ARTIFACTS
from tests.e2e.test_dashboard import JOB_TIMEOUT_MS, sign_in
from tests.e2e.test_pose_test import _rigged_fox

pytestmark = pytest.mark.browser


def _skeleton(server, job_id: str) -> dict:
    auth = {"Authorization": f"Bearer {server.local_key}"}
    return httpx.get(f"{server.url}/api/v1/jobs/{job_id}/artifacts/skeleton.json", headers=auth).json()


def test_move_a_joint_and_reskin_as_a_linked_job(page, dashboard_server, dev_assets):
    first = _rigged_fox(dashboard_server, dev_assets)
    before = _skeleton(dashboard_server, first)
    sign_in(page, dashboard_server.local_key)
    page.goto(f"/#/jobs/{first}")
    page.wait_for_selector("#viewer-stage[data-state=ready]", timeout=60_000)
    page.click("#edit-open")
    page.wait_for_selector("#edit-joint option >> nth=3", state="attached")

    j = before["names"].index("head")
    page.select_option("#edit-joint", str(j))
    x = float(page.input_value("#edit-x"))
    page.fill("#edit-x", f"{x + 0.05:.4f}")
    page.press("#edit-x", "Enter")
    page.fill("#edit-name", "skull")
    page.press("#edit-name", "Enter")
    page.click("#edit-add")  # a new child of the head...
    assert page.input_value("#edit-name") == "joint_new_1" and page.input_value("#edit-parent") == str(j)
    page.select_option("#edit-parent", "0")  # ...re-parented to the root...
    assert page.input_value("#edit-parent") == "0"
    page.select_option("#edit-parent", str(j))  # ...and back
    page.click("#edit-delete")  # ...and deleted again: the head is selected once more
    assert page.input_value("#edit-name") == "skull"
    page.locator("#viewer-canvas").screenshot(path=str(ARTIFACTS / "edit-1-moved.png"))

    page.click("#edit-reskin")
    page.wait_for_url(re.compile(rf"#/jobs/(?!{first})[0-9a-f-]{{36}}$"))
    page.wait_for_selector("#job-head .badge[data-status=succeeded], #job-head .badge[data-status=failed]",
                           timeout=JOB_TIMEOUT_MS)
    assert page.get_attribute("#job-head .badge", "data-status") == "succeeded", page.inner_text("#job-head")
    assert first in page.inner_text("#job-source")
    page.wait_for_selector("#viewer-stage[data-state=ready]", timeout=60_000)
    page.locator("#viewer-canvas").screenshot(path=str(ARTIFACTS / "edit-2-reskinned.png"))

    second = page.url.rsplit("/", 1)[-1]
    after = _skeleton(dashboard_server, second)
    assert json.loads(json.dumps(after["names"])) == before["names"][:j] + ["skull"] + before["names"][j + 1:]
    moved = np.array(after["positions"][j]) - np.array(before["positions"][j])
    np.testing.assert_allclose(moved, [0.05, 0, 0], atol=2e-4)
    assert after["method"] == "given"
    assert "skull" in page.evaluate("window.rigforgeViewer.view.boneNames()")
    assert not page.console_errors and not page.external_requests

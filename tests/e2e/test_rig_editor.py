"""Editing a rig in the dashboard (real Chromium): pick a joint by clicking its sphere; move a joint, rename one, add
and delete one, re-skin; the new job is linked to the first, its skeleton has the moved joint and it plays the first
job's clip. Screenshots: test-artifacts/edit-*.png."""

from __future__ import annotations

import json
import re
import time

import httpx
import numpy as np
import pytest

from tests.e2e.conftest import ARTIFACTS
from tests.e2e.test_dashboard import JOB_TIMEOUT_MS, sign_in

pytestmark = pytest.mark.browser
JOB_TIMEOUT_S = 240
# Canvas point (CSS px) of skeleton.json joint j, as the editor's spheres hang under the model's root.
JOINT_ON_CANVAS = """([p]) => { const v = window.rigforgeViewer.view, c = v.canvas;
  const q = v.models[0].root.localToWorld(v.camera.position.clone().set(p[0], p[1], p[2])).project(v.camera);
  return [(q.x + 1) / 2 * c.clientWidth, (1 - q.y) / 2 * c.clientHeight]; }"""


@pytest.fixture(scope="module")
def walking_fox(dashboard_server, dev_assets) -> str:
    """A finished job on fox.glb's own rig (skeleton: keep, the quick path) and its Walk clip (animated.glb)."""
    auth = {"Authorization": f"Bearer {dashboard_server.local_key}"}
    with httpx.Client(base_url=dashboard_server.url, headers=auth, timeout=60) as client:
        job = client.post("/api/v1/jobs", files={"mesh": ("fox.glb", (dev_assets / "fox.glb").read_bytes())},
                          data={"options": json.dumps({"skeleton": "keep", "motion": {"clip": "Walk"}})}).json()
        deadline = time.monotonic() + JOB_TIMEOUT_S
        while job["status"] in ("queued", "running") and time.monotonic() < deadline:
            time.sleep(0.5)
            job = client.get(f"/api/v1/jobs/{job['id']}").json()
    assert job["status"] == "succeeded", job
    return job["id"]


def _artifact(server, job_id: str, name: str) -> dict:
    auth = {"Authorization": f"Bearer {server.local_key}"}
    return httpx.get(f"{server.url}/api/v1/jobs/{job_id}/artifacts/{name}", headers=auth).json()


def _open_editor(page, server, job_id: str) -> None:
    sign_in(page, server.local_key)
    page.goto(f"/#/jobs/{job_id}")
    page.wait_for_selector("#viewer-stage[data-state=ready]", timeout=60_000)
    page.click("#edit-open")
    page.wait_for_selector("#edit-joint option >> nth=3", state="attached")


def test_clicking_a_joint_sphere_picks_it(page, dashboard_server, walking_fox):
    skeleton = _artifact(dashboard_server, walking_fox, "skeleton.json")
    _open_editor(page, dashboard_server, walking_fox)
    canvas = page.locator("#viewer-canvas").bounding_box()
    assert page.input_value("#edit-joint") == "0"
    root = page.evaluate(JOINT_ON_CANVAS, [skeleton["positions"][0]])
    points = [page.evaluate(JOINT_ON_CANVAS, [p]) for p in skeleton["positions"]]
    # the joint farthest on screen from the root (and its gizmo), with no other joint's sphere near it
    clear = [j for j, p in enumerate(points) if min(np.hypot(p[0] - q[0], p[1] - q[1]) for k, q in enumerate(points) if k != j) > 12]
    j = max(clear, key=lambda k: np.hypot(points[k][0] - root[0], points[k][1] - root[1]))
    page.mouse.click(canvas["x"] + points[j][0], canvas["y"] + points[j][1])
    assert page.input_value("#edit-joint") == str(j)
    assert page.input_value("#edit-name") == skeleton["names"][j]
    assert float(page.input_value("#edit-x")) == pytest.approx(skeleton["positions"][j][0], abs=1e-4)
    page.locator("#viewer-canvas").screenshot(path=str(ARTIFACTS / "edit-0-picked.png"))
    page.mouse.click(canvas["x"] + 5, canvas["y"] + 5)  # empty space: the pick stays
    assert page.input_value("#edit-joint") == str(j)
    assert not page.console_errors and not page.external_requests


def test_move_a_joint_and_reskin_as_a_linked_job(page, dashboard_server, walking_fox):
    first = walking_fox
    before = _artifact(dashboard_server, first, "skeleton.json")
    _open_editor(page, dashboard_server, first)

    j = next(i for i, name in enumerate(before["names"]) if "head" in name.lower())
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
    after = _artifact(dashboard_server, second, "skeleton.json")
    assert json.loads(json.dumps(after["names"])) == before["names"][:j] + ["skull"] + before["names"][j + 1:]
    moved = np.array(after["positions"][j]) - np.array(before["positions"][j])
    np.testing.assert_allclose(moved, [0.05, 0, 0], atol=2e-4)
    assert after["method"] == "given"
    assert "skull" in page.evaluate("window.rigforgeViewer.view.boneNames()")
    clip, replayed = (_artifact(dashboard_server, job, "report.json")["motion"] for job in (first, second))
    assert replayed["status"] == "retargeted" and replayed["joint_map"]["skull"] == before["names"][j]  # renamed, still driven
    assert (replayed["clip"]["frames"], replayed["clip"]["fps"]) == (clip["clip"]["frames"], clip["clip"]["fps"])
    assert page.input_value("#viewer-model") == "animated.glb"
    assert not page.console_errors and not page.external_requests

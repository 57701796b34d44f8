"""The viewer's pose test in real Chromium: sliders turn the picked bone, the skinned mesh follows, Reset puts it
back. Screenshots land in test-artifacts/pose-*.png (look at them)."""

from __future__ import annotations

import math
import time

import httpx
import numpy as np
import pytest

from tests.e2e.test_dashboard import canvas_pixels, sign_in, vertices_per_joint

pytestmark = pytest.mark.browser
BONE_ANGLE = """(name) => { const m = window.rigforgeViewer.view.models[0]; const b = m.bones.find((x) => x.name === name);
  return b.quaternion.toArray(); }"""


def _rigged_fox(server, dev_assets) -> str:
    """A finished job rigging fox.glb with a predicted skeleton (no motion: the viewer shows rigged.glb)."""
    auth = {"Authorization": f"Bearer {server.local_key}"}
    with httpx.Client(base_url=server.url, headers=auth, timeout=60) as client:
        job = client.post("/api/v1/jobs", files={"mesh": ("fox.glb", (dev_assets / "fox.glb").read_bytes())}).json()
        deadline = time.monotonic() + 240
        while job["status"] in ("queued", "running") and time.monotonic() < deadline:
            time.sleep(0.5)
            job = client.get(f"/api/v1/jobs/{job['id']}").json()
    assert job["status"] == "succeeded", job
    return job["id"]


def _changed(a: np.ndarray, b: np.ndarray) -> float:
    return float((np.abs(a.astype(int) - b.astype(int)).sum(axis=2) > 40).mean())


def test_sliders_pose_the_picked_bone_and_reset_restores(page, dashboard_server, dev_assets):
    job_id = _rigged_fox(dashboard_server, dev_assets)
    sign_in(page, dashboard_server.local_key)
    page.goto(f"/#/jobs/{job_id}")
    page.wait_for_selector("#viewer-stage[data-state=ready]", timeout=60_000)
    assert page.is_disabled("#viewer-pose-x")  # nothing to turn before a bone is picked

    heavy = vertices_per_joint(dashboard_server, page)
    bone = max((n for n in heavy if n != "root" and n != "hips"), key=heavy.__getitem__)  # a limb or the spine, not the root
    page.select_option("#viewer-bone", bone)
    page.check("#viewer-color-texture")
    rest = canvas_pixels(page, "pose-1-rest")
    rest_quaternion = page.evaluate(BONE_ANGLE, bone)

    page.fill("#viewer-pose-z", "60")
    assert page.inner_text("#viewer-pose-z-value") == "60°"
    posed = canvas_pixels(page, "pose-2-turned")
    moved = _changed(rest, posed)
    assert moved > 0.005, moved  # the skinned mesh deformed on screen
    q0, q1 = np.array(rest_quaternion), np.array(page.evaluate(BONE_ANGLE, bone))
    turned = math.degrees(2 * math.acos(min(1.0, abs(float(np.dot(q0, q1))))))
    assert abs(turned - 60) < 0.5, turned

    page.click("#viewer-pose-reset")
    back = canvas_pixels(page, "pose-3-reset")
    assert _changed(rest, back) < 0.001 and page.input_value("#viewer-pose-z") == "0"
    assert np.allclose(page.evaluate(BONE_ANGLE, bone), rest_quaternion)
    assert not page.console_errors and not page.external_requests

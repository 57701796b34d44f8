"""The dashboard in real Chromium against a real `rigforge serve`: sign in, upload fox.glb by drag and drop,
follow progress to the end, inspect the job in the three.js viewer, pick a bone, download an artifact.
Screenshots land in test-artifacts/ (look at them)."""

from __future__ import annotations

import base64
import io
import json
import os
import re
import time

import httpx
import numpy as np
import pytest
from PIL import Image
from playwright.sync_api import expect

from tests.e2e.conftest import ARTIFACTS

pytestmark = pytest.mark.browser
JOB_TIMEOUT_MS = 240_000

# Record every value an element shows (the page re-renders it), so the test can check the sequence.
RECORD = """([sel, name, attr]) => {
  window[name] = [];
  const read = () => { const el = document.querySelector(sel); if (!el) return;
    const v = attr ? Number(el.getAttribute(attr)) : el.textContent; const seen = window[name];
    if (seen[seen.length - 1] !== v) seen.push(v); };
  new MutationObserver(read).observe(document.body, { subtree: true, childList: true, characterData: true, attributes: true });
  read();
}"""


def record_progress(page, selector: str, name: str = "__progress") -> None:
    page.evaluate(RECORD, [selector, name, "aria-valuenow"])


def record_text(page, selector: str, name: str) -> None:
    page.evaluate(RECORD, [selector, name, None])


def canvas_pixels(page, name: str) -> np.ndarray:
    """(H, W, 3) uint8 screenshot of the viewer canvas, also saved as test-artifacts/<name>.png."""
    png = page.locator("#viewer-canvas").screenshot(path=str(ARTIFACTS / f"{name}.png"))
    return np.asarray(Image.open(io.BytesIO(png)).convert("RGB"))


def sign_in(page, key: str) -> None:
    page.goto("/")
    page.wait_for_url(re.compile(r"#/keys$"))  # nothing works before signing in
    page.fill("#api-key", key)
    page.click("#signin-form button[type=submit]")
    page.wait_for_selector("#signin-message >> text=Signed in as local")


def block_events(page, pattern: str = "**/events*") -> list[str]:
    """Abort the page's requests for job event streams; returns the URLs refused, filled as they come."""
    blocked: list[str] = []

    def block(route) -> None:
        blocked.append(route.request.url)
        route.abort()

    page.route(pattern, block)
    return blocked


def drop_file(page, selector: str, path, name: str) -> None:
    """Drag-and-drop a real file onto a drop zone (a DataTransfer built in the page from the file's bytes)."""
    data = base64.b64encode(path.read_bytes()).decode()
    transfer = page.evaluate_handle("""([b64, name]) => { const bin = atob(b64); const bytes = new Uint8Array(bin.length);
      for (let i = 0; i < bin.length; i++) bytes[i] = bin.charCodeAt(i);
      const dt = new DataTransfer(); dt.items.add(new File([bytes], name)); return dt; }""", [data, name])
    page.dispatch_event(selector, "dragover", {"dataTransfer": transfer})
    page.dispatch_event(selector, "drop", {"dataTransfer": transfer})


def vertices_per_joint(server, page) -> dict[str, int]:
    """Joint name → number of vertices it weights above 0.5, from the shown job's rigged.glb."""
    from simcore.io.gltf_document import GltfDocument
    from simcore.io.gltf_rig import read_rigged_asset

    job_id = page.url.rsplit("/", 1)[-1]
    glb = httpx.get(f"{server.url}/api/v1/jobs/{job_id}/artifacts/rigged.glb", headers={"Authorization": f"Bearer {server.local_key}"})
    asset = read_rigged_asset(GltfDocument.from_bytes(glb.content))
    counts = (asset.weights.toarray() > 0.5).sum(axis=0)
    return dict(zip(asset.skeleton.names, counts.tolist()))


def page_weight_and_tti(page) -> dict:
    """JS bytes loaded so far and the time (ms since navigation) the jobs list became interactive."""
    return page.evaluate("""() => {
      const js = performance.getEntriesByType('resource').filter((e) => e.name.endsWith('.js'));
      const mark = performance.getEntriesByName('rigforge:interactive')[0];
      const nav = performance.getEntriesByType('navigation')[0];
      return { js_files: js.length, js_bytes: js.reduce((a, e) => a + e.decodedBodySize, 0),
               js_transfer_bytes: js.reduce((a, e) => a + e.transferSize, 0),
               tti_ms: mark ? Math.round(mark.startTime) : null, dom_content_loaded_ms: Math.round(nav.domContentLoadedEventEnd) };
    }""")


def test_upload_follow_view_pick_bone_and_download(page, dashboard_server, dev_assets):
    sign_in(page, dashboard_server.local_key)
    page.screenshot(path=str(ARTIFACTS / "01-signed-in.png"))

    page.goto("/#/jobs")
    page.reload()  # a fresh navigation with the stored key, so the timings below are the jobs page's own
    page.wait_for_selector("#jobs-table, .empty")  # "No jobs yet" on a fresh server
    first_load = page_weight_and_tti(page)

    page.click("a[href='#/new']")
    drop_file(page, "label.dropzone[for=mesh]", dev_assets / "fox.glb", "fox.glb")
    page.wait_for_selector("label[for=mesh] >> text=fox.glb")
    page.select_option("#opt-max-influences", "4")
    page.fill("#opt-exclude", "*_nope")  # a pattern that matches no joint: the job goes on and the report says so
    page.screenshot(path=str(ARTIFACTS / "02-new-job.png"), full_page=True)
    record_progress(page, "[aria-label='upload progress']")
    page.click("#submit-job")
    page.wait_for_url(re.compile(r"#/jobs/[0-9a-f-]{36}$"))
    upload_progress = page.evaluate("window.__progress")
    assert upload_progress[-1] == 100, upload_progress  # XHR upload events drove the bar to the end

    record_progress(page, "#job-head [role=progressbar]")
    page.wait_for_selector("#job-head .badge[data-status=succeeded], #job-head .badge[data-status=failed]", timeout=JOB_TIMEOUT_MS)
    job_progress = page.evaluate("window.__progress")
    status = page.get_attribute("#job-head .badge", "data-status")
    page.screenshot(path=str(ARTIFACTS / "03-job-finished.png"), full_page=True)
    if status == "failed":  # the failure must be explained on the page
        assert page.inner_text("#job-error").strip()
        pytest.fail(f"fox job failed: {page.inner_text('#job-error')}")
    assert job_progress == sorted(job_progress) and job_progress[-1] == 100, job_progress
    assert "done" in page.inner_text("#job-stage")

    # plain summary on top, report tables folded below it
    summary = page.inner_text("#job-summary")
    assert "Skeleton: RigForge" in summary and "descriptive joint names" in summary and "warning" in summary, summary
    assert "under a root joint at the file's origin" in summary, summary  # the fox stands on its file's origin
    page.click("#report-details > summary")
    page.wait_for_selector("#report-mesh")
    assert "'*_nope' matches no joint" in page.inner_text("#report-warnings")
    assert "1,728" in page.inner_text("#report-mesh")  # fox.glb vertices
    assert {"ingest", "skeleton", "skin", "export"} <= set(re.findall(r"^(\w+)\t", page.inner_text("#timings").lower(), re.M))

    # viewer: something is drawn
    page.wait_for_selector("#viewer-stage[data-state=ready]", timeout=60_000)
    textured = canvas_pixels(page, "04-viewer-textured")
    background = np.array([0x2A, 0x2F, 0x3A])
    covered = (np.abs(textured.astype(int) - background).sum(axis=2) > 30).mean()
    assert textured.std() > 10 and covered > 0.03, (textured.std(), covered)

    # click the visible joint that moves the most vertices (read from the job's rigged.glb): its heat map must show
    joints = page.evaluate("window.rigforgeViewer.jointScreenPoints()")
    assert len(joints) >= 10, joints
    heavy = vertices_per_joint(dashboard_server, page)
    joint = max(joints, key=lambda j: heavy.get(j["name"], 0))
    box = page.locator("#viewer-canvas").bounding_box()
    page.mouse.move(box["x"] + joint["x"], box["y"] + joint["y"])
    page.wait_for_selector(f"#viewer-stage .tip:not([hidden]) >> text={joint['name']}")  # name on hover
    page.mouse.click(box["x"] + joint["x"], box["y"] + joint["y"])
    page.wait_for_selector(f"#viewer-status >> text=bone {joint['name']}")
    heat = canvas_pixels(page, "05-viewer-heatmap")
    changed = (np.abs(heat.astype(int) - textured.astype(int)).sum(axis=2) > 40).mean()
    assert changed > 0.02, changed
    hot = ((heat[..., 0] > 150) & (heat[..., 2] < 100)).mean()  # red/orange/yellow pixels: weight near 1
    assert hot > 0.005, hot
    assert page.input_value("#viewer-bone") == joint["name"]

    page.check("#viewer-color-dominant")
    dominant = canvas_pixels(page, "06-viewer-dominant")
    assert (np.abs(dominant.astype(int) - heat.astype(int)).sum(axis=2) > 40).mean() > 0.01

    # download an artifact through its link
    sizes = {a["name"]: a["size"] for a in page.evaluate(
        "async () => (await (await fetch(location.pathname + 'api/v1/jobs/' + location.hash.split('/')[2],"
        " {headers: {Authorization: 'Bearer ' + localStorage.getItem('rigforge.apiKey')}})).json()).artifacts")}
    with page.expect_download() as info:
        page.click("a[aria-label='Download rigged.glb']")
    saved = ARTIFACTS / "downloaded-rigged.glb"
    info.value.save_as(saved)
    assert saved.read_bytes()[:4] == b"glTF" and saved.stat().st_size == sizes["rigged.glb"]

    viewer_load = page_weight_and_tti(page)
    page.goto("/#/jobs")
    page.wait_for_selector("#jobs-table .badge[data-status=succeeded]")
    assert page.get_attribute("#jobs-table [role=progressbar]", "aria-valuenow") == "100"
    page.screenshot(path=str(ARTIFACTS / "07-jobs-list.png"))

    figures = {"jobs_page": first_load, "picked_joint": joint["name"], "heatmap_hot": round(float(hot), 3),
               "after_viewer_js_bytes": viewer_load["js_bytes"], "upload_progress": upload_progress, "job_progress": job_progress,
               "canvas_covered": round(float(covered), 3), "heatmap_changed": round(float(changed), 3)}
    print("dashboard figures:", json.dumps(figures))
    (ARTIFACTS / "dashboard-figures.json").write_text(json.dumps(figures, indent=2))
    assert first_load["tti_ms"] is not None and first_load["js_bytes"] < 200_000  # three.js is loaded only by the viewer
    assert page.external_requests == [], page.external_requests
    assert page.console_errors == [], page.console_errors


def test_bad_uploads_show_the_servers_message_inline(page, dashboard_server, tmp_path):
    sign_in(page, dashboard_server.local_key)
    page.goto("/#/new")
    noise = tmp_path / "noise.glb"
    noise.write_bytes(os.urandom(4096))
    page.set_input_files("#mesh", str(noise))
    page.click("#submit-job")
    message = page.wait_for_selector("#mesh-error:not([hidden])")
    assert "unrecognised file format" in message.inner_text()
    assert "unknown_format" in page.inner_text("#form-errors")
    assert page.get_attribute("#mesh", "aria-invalid") == "true"
    page.screenshot(path=str(ARTIFACTS / "08-bad-upload.png"), full_page=True)

    # an option out of range is named by the server and shown next to its input
    page.fill("#opt-fps", "1000")
    page.click("#submit-job")
    fps = page.wait_for_selector("#opt-fps-error:not([hidden])")
    assert "240" in fps.inner_text()
    assert page.locator("#mesh-error").is_hidden()  # the earlier message is cleared
    page.fill("#opt-fps", "")
    page.fill("#opt-max-joints", "16")
    page.fill("#opt-sequence-bones", "32")  # a fixed bone count above the cap
    page.click("#submit-job")
    bones = page.wait_for_selector("#opt-sequence-bones-error:not([hidden])")
    assert "max_joints" in bones.inner_text()
    assert page.url.endswith("#/new")  # nothing was submitted
    assert [e for e in page.console_errors if "status of 422" not in e] == []  # Chromium logs the refused uploads


def test_keys_page_creates_and_revokes_a_key(page, dashboard_server):
    sign_in(page, dashboard_server.local_key)
    assert "local-api-key" in page.inner_text("#local-key-help")
    page.wait_for_selector("#keys-table")
    page.fill("#new-key-name", "render farm")
    page.click("#create-key-form button")
    secret = page.wait_for_selector("#new-key-secret").inner_text()
    assert secret.startswith("rf_")
    page.screenshot(path=str(ARTIFACTS / "09-keys.png"), full_page=True)
    page.click("button[aria-label='Revoke key render farm']")
    page.wait_for_selector("#keys-table tr:has-text('render farm') >> text=revoked")
    r = page.request.get("/api/v1/keys/me", headers={"Authorization": f"Bearer {secret}"})
    assert r.status == 401

    page.fill("#api-key", secret)  # a revoked key is refused with the server's message
    page.click("#signin-form button[type=submit]")
    assert "unauthorized" in page.wait_for_selector("#signin-message .error").inner_text()
    page.click("#sign-out")
    page.goto("/#/jobs")
    page.wait_for_url(re.compile(r"#/keys$"))
    assert page.inner_text("#who") == "not signed in"


def test_animation_playback_and_lbs_vs_physics_side_by_side(page, dashboard_server, dev_assets):
    sign_in(page, dashboard_server.local_key)
    page.goto("/#/new")
    page.set_input_files("#mesh", str(dev_assets / "fox.glb"))
    page.fill("#opt-clip", "Walk")  # fox.glb carries its own clips
    page.check("#opt-refine")
    page.click("#submit-job")
    page.wait_for_url(re.compile(r"#/jobs/[0-9a-f-]{36}$"))
    job_id = page.url.rsplit("/", 1)[-1]

    # follow it from the jobs list: the row's bar and stage name update live
    page.click("header a[href='#/jobs']")
    row = f"#jobs-table tr[data-job-id='{job_id}']"
    page.wait_for_selector(row)
    record_progress(page, f"{row} [role=progressbar]", "__row_progress")
    record_text(page, f"{row} .stage", "__row_stages")
    page.wait_for_selector(f"{row} .badge[data-status=succeeded], {row} .badge[data-status=failed]", timeout=JOB_TIMEOUT_MS)
    row_progress, row_stages = page.evaluate("[window.__row_progress, window.__row_stages]")
    assert page.get_attribute(f"{row} .badge", "data-status") == "succeeded", page.inner_text(row)
    assert row_progress == sorted(row_progress) and row_progress[-1] == 100 and len(row_progress) >= 3, row_progress
    assert any(s.startswith("refine") for s in row_stages), row_stages  # stage names shown while running
    print("jobs list row:", row_progress, row_stages)

    page.click(f"{row} a")
    page.wait_for_selector("#viewer-stage[data-state=ready]", timeout=60_000)

    assert page.input_value("#viewer-model") == "__compare__"  # both files exist: side by side by default
    assert page.locator("#viewer-stage .labels span").all_inner_texts() == ["LBS", "Physics (MPM)"]
    frames = len(page.get_attribute("#volume-plot polyline[data-series=refined]", "points").split())
    assert frames == len(page.get_attribute("#volume-plot polyline[data-series=lbs]", "points").split()) > 2
    assert page.input_value("#viewer-clip") == "Walk"

    start = canvas_pixels(page, "10-compare-t0")
    cursor_x0 = page.get_attribute("#volume-plot line[stroke-dasharray]", "x1")
    page.eval_on_selector("#viewer-scrub", "(el) => { el.value = '0.5'; el.dispatchEvent(new Event('input')); }")
    assert page.inner_text("#viewer-time").startswith("0.35")
    middle = canvas_pixels(page, "11-compare-mid-walk")
    assert (np.abs(middle.astype(int) - start.astype(int)).sum(axis=2) > 40).mean() > 0.003  # the legs moved
    assert page.get_attribute("#volume-plot line[stroke-dasharray]", "x1") != cursor_x0
    page.screenshot(path=str(ARTIFACTS / "12-compare-page.png"), full_page=True)

    page.click("#viewer-play")
    expect(page.locator("#viewer-time")).not_to_have_text(re.compile(r"^0\.35"))  # locator waits: the page's CSP forbids eval
    page.click("#viewer-play")
    assert page.get_attribute("#viewer-play", "aria-pressed") == "false"

    page.click("#viewer-toggle")  # one model at a time, LBS ⇄ physics
    page.wait_for_selector("#viewer-stage[data-state=ready]")
    assert page.input_value("#viewer-model") in {"animated.glb", "refined.glb"}
    assert page.locator("#viewer-stage .labels span").count() == 0
    assert page.external_requests == [] and page.console_errors == []


def _submit(server, fox: bytes, options: dict) -> str:
    r = httpx.post(f"{server.url}/api/v1/jobs", headers={"Authorization": f"Bearer {server.local_key}"},
                   files={"mesh": ("fox.glb", fox)}, data={"options": json.dumps(options)}, timeout=60)
    assert r.status_code == 202, r.text
    return r.json()["id"]


def test_jobs_list_filters_pages_and_explains_failures(page, dashboard_server, dev_assets):
    fox = (dev_assets / "fox.glb").read_bytes()
    failing = _submit(dashboard_server, fox, {"motion": {"clip": "no such clip"}})
    ids = [failing] + [_submit(dashboard_server, fox, {"stages": []}) for _ in range(11)]  # ingest only: quick
    auth = {"Authorization": f"Bearer {dashboard_server.local_key}"}
    for job_id in ids:
        for _ in range(300):
            if httpx.get(f"{dashboard_server.url}/api/v1/jobs/{job_id}", headers=auth).json()["status"] in {"succeeded", "failed"}:
                break
            time.sleep(0.2)

    sign_in(page, dashboard_server.local_key)
    page.goto("/#/jobs")
    page.wait_for_selector("#jobs-table")
    page.select_option("#status-filter", "failed")
    expect(page.locator("#jobs-table .badge:not([data-status='failed'])")).to_have_count(0)
    assert page.locator(f"#jobs-table tr[data-job-id='{failing}']").count() == 1
    error = page.inner_text(f"#jobs-table tr[data-job-id='{failing}'] .job-error")
    assert error.startswith("unknown_clip") and "no such clip" in error
    page.screenshot(path=str(ARTIFACTS / "13-jobs-failed-filter.png"))

    page.click(f"#jobs-table tr[data-job-id='{failing}'] a")
    assert "unknown_clip" in page.wait_for_selector("#job-error").inner_text()
    page.go_back()

    page.select_option("#status-filter", "")
    page.select_option("#page-size", "10")
    expect(page.locator("#jobs-table tbody tr")).to_have_count(10)
    first_page = page.eval_on_selector_all("#jobs-table tbody tr", "(rows) => rows.map((r) => r.dataset.jobId)")
    assert first_page[0] == ids[-1]  # newest first
    page.click("text=Older →")
    page.wait_for_selector("text=page 2")
    second_page = page.eval_on_selector_all("#jobs-table tbody tr", "(rows) => rows.map((r) => r.dataset.jobId)")
    assert second_page and not set(second_page) & set(first_page)
    page.click("text=← Newer")
    page.wait_for_selector("text=page 1")
    assert page.eval_on_selector("#jobs-table tbody tr", "(r) => r.dataset.jobId") == ids[-1]
    assert page.console_errors == []


def test_progress_falls_back_to_polling_when_events_are_blocked(page, dashboard_server, dev_assets):
    blocked = block_events(page)
    sign_in(page, dashboard_server.local_key)
    page.goto("/#/new")
    page.set_input_files("#mesh", str(dev_assets / "fox.glb"))
    page.fill("#opt-clip", "Survey")  # a motion job: long enough to be followed while it runs
    page.click("#submit-job")
    page.wait_for_url(re.compile(r"#/jobs/[0-9a-f-]{36}$"))
    page.wait_for_selector("#job-head .badge[data-status=succeeded]", timeout=JOB_TIMEOUT_MS)
    assert blocked, "the page never tried the event stream"
    assert page.get_attribute("#job-head [role=progressbar]", "aria-valuenow") == "100"
    page.wait_for_selector("#viewer-stage[data-state=ready]", timeout=60_000)
    assert page.input_value("#viewer-clip") == "Survey"  # the animated result plays the chosen clip
    assert "Weights relaxed under the clip at" in page.inner_text("#job-summary")  # the fox's Survey bends its legs


def test_camera_follows_a_clip_that_walks_away_and_stays_put_when_told(page, dashboard_server, dev_assets):
    from tests.simcore.motion.motion_samples import bvh_text, humanoid

    skel = humanoid(prefix="")
    frames = 24
    roots = np.stack([np.zeros(frames), np.full(frames, 1.0), np.arange(frames) * 0.1], axis=1)  # walks 2.3 m
    bvh = bvh_text(skel, roots, np.zeros((frames, skel.num_joints, 3)), ["ZXY"] * skel.num_joints).encode()
    r = httpx.post(f"{dashboard_server.url}/api/v1/jobs", headers={"Authorization": f"Bearer {dashboard_server.local_key}"},
                   files={"mesh": ("rigged_figure.glb", (dev_assets / "rigged_figure.glb").read_bytes()), "motion": ("walk.bvh", bvh)},
                   # warn: the toy's shoulders come near the gate's floor in the clip's T-pose; this test is about the camera
                   data={"options": json.dumps({"skeleton": "keep", "quality_gate": "warn"})}, timeout=60)
    assert r.status_code == 202, r.text
    sign_in(page, dashboard_server.local_key)
    page.goto(f"/#/jobs/{r.json()['id']}")
    page.wait_for_selector("#job-head .badge[data-status=succeeded]", timeout=JOB_TIMEOUT_MS)
    page.wait_for_selector("#viewer-stage[data-state=ready]", timeout=60_000)
    state = """() => { const v = window.rigforgeViewer.view; const p = v.models[0].bones[0].getWorldPosition(v.camera.position.clone());
      return { root: p.toArray(), target: v.controls.target.toArray(), camera: v.camera.position.toArray() }; }"""

    def scrub(fraction: str) -> dict:
        page.eval_on_selector("#viewer-scrub", f"(el) => {{ el.value = '{fraction}'; el.dispatchEvent(new Event('input')); }}")
        return page.evaluate(state)

    start, end = scrub("0"), scrub("1")
    moved = np.subtract(end["root"], start["root"])
    assert np.hypot(moved[0], moved[2]) > 0.5  # the character really walked away
    followed = np.subtract(end["target"], start["target"])
    assert np.allclose(followed, [moved[0], 0.0, moved[2]], atol=1e-3)  # horizontal only: the camera keeps its height
    assert np.allclose(np.subtract(end["camera"], start["camera"]), followed, atol=1e-3)

    page.uncheck("#viewer-follow")
    again = scrub("0")
    assert np.allclose(again["target"], end["target"]) and np.allclose(again["camera"], end["camera"])

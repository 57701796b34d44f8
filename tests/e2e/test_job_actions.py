"""A finished job's page in real Chromium: download all as a zip, re-run, delete."""

from __future__ import annotations

import re
import zipfile

import pytest

from tests.e2e.conftest import ARTIFACTS
from tests.e2e.test_dashboard import JOB_TIMEOUT_MS, sign_in
from tests.e2e.test_pose_test import _rigged_fox

pytestmark = pytest.mark.browser


def test_download_all_rerun_and_delete(page, dashboard_server, dev_assets):
    first = _rigged_fox(dashboard_server, dev_assets)
    sign_in(page, dashboard_server.local_key)
    page.goto(f"/#/jobs/{first}")
    page.wait_for_selector("#download-all")

    with page.expect_download() as info:
        page.click("#download-all")
    saved = ARTIFACTS / "downloaded-all.zip"
    info.value.save_as(saved)
    names = set(zipfile.ZipFile(saved).namelist())
    assert {"rigged.glb", "rigged.usdz", "report.json", "skeleton.json"} <= names, names

    page.click("#rerun-job")
    page.wait_for_url(re.compile(rf"#/jobs/(?!{first})[0-9a-f-]{{36}}$"))
    page.wait_for_selector("#job-head .badge[data-status=succeeded]", timeout=JOB_TIMEOUT_MS)
    again = page.url.rsplit("/", 1)[-1]

    page.once("dialog", lambda dialog: dialog.accept())
    page.click("#delete-job")
    page.wait_for_url(re.compile(r"#/jobs$"))
    page.wait_for_selector("#jobs-table")
    assert page.locator(f"#jobs-table a[href='#/jobs/{again}']").count() == 0
    assert page.locator(f"#jobs-table a[href='#/jobs/{first}']").count() == 1
    assert not page.console_errors and not page.external_requests


def test_the_upload_form_asks_for_unreal_names(page, dashboard_server, dev_assets):
    from tests.e2e.test_dashboard import drop_file

    sign_in(page, dashboard_server.local_key)
    page.goto("/#/new")
    drop_file(page, "label.dropzone[for=mesh]", dev_assets / "rigged_figure.glb", "rigged_figure.glb")
    page.wait_for_selector("label[for=mesh] >> text=rigged_figure.glb")
    page.select_option("#opt-naming", "unreal")
    page.click("#submit-job")
    page.wait_for_url(re.compile(r"#/jobs/[0-9a-f-]{36}$"))
    page.wait_for_selector("#job-head .badge[data-status=succeeded]", timeout=JOB_TIMEOUT_MS)
    assert "named for unreal" in page.inner_text("#job-summary")
    page.wait_for_selector("#viewer-stage[data-state=ready]", timeout=60_000)
    bones = page.evaluate("window.rigforgeViewer.view.boneNames()")
    assert {"pelvis", "spine_01", "head", "upperarm_l", "lowerarm_r", "thigh_l", "calf_r"} <= set(bones), bones

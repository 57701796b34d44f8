"""Thresholds come from the artists' rigs: every artist sample passes, and failing needs 1.15× the worst."""

from __future__ import annotations

import json

import pytest

from simcore.gate.thresholds import CALIBRATED, FAIL_FACTOR, THRESHOLDS_PATH, derive, thresholds


def calibration() -> dict:
    rig = {"joints_inside": 0.95, "zero_length_bone_share": 0.0}
    clip = {"stretch_low": 0.7, "stretch_high": 1.3, "volume_low": 0.97, "volume_high": 1.01}
    worse = {"stretch_low": 0.6, "stretch_high": 1.5, "volume_low": 0.9, "volume_high": None}  # a sheet: no volume
    return {"rigs": [{"name": "a", **rig}, {"name": "b", **rig, "joints_inside": 0.9}],
            "clips": [{"name": "a", "clip": "walk", **clip}, {"name": "b", "clip": "run", **worse}]}


def test_envelope_is_the_worst_artist_sample_and_failing_needs_a_further_15_percent():
    figures = derive(calibration())["figures"]
    assert figures["stretch_low"]["warn"] == 0.6 and figures["stretch_low"]["set_by"] == "b/run"
    assert figures["stretch_low"]["fail"] == pytest.approx(1 - 1.15 * 0.4)
    assert figures["stretch_high"]["fail"] == pytest.approx(1 + 1.15 * 0.5)
    assert figures["volume_high"] == {"bad": "above", "warn": 1.01, "fail": pytest.approx(1.0115), "set_by": "a/walk", "samples": 1}
    assert figures["joints_inside"]["warn"] == 0.9 and figures["joints_inside"]["fail"] is None


def test_committed_thresholds_follow_the_rule():
    data = json.loads(THRESHOLDS_PATH.read_text())
    assert data["fail_factor"] == FAIL_FACTOR and set(data["figures"]) == set(CALIBRATED)
    for name, t in thresholds().items():
        if name in CALIBRATED and t.fail is not None:
            rest = CALIBRATED[name][1]
            assert t.fail - rest == pytest.approx(FAIL_FACTOR * (t.warn - rest))
            assert t.past(t.fail, t.warn) and not t.past(t.warn, t.warn)  # failing lies beyond warning
    assert THRESHOLDS_PATH.with_suffix(".md").read_text().count("|") > 100  # the table they came from

"""Motion evaluation: the self-check onto the artist's own rig reproduces the artist's animation."""

from __future__ import annotations

from simcore.evaluation.motion_eval import evaluate_motion


def test_artist_rig_self_check_is_exact(dev_assets):
    report = evaluate_motion(dev_assets, use_predicted=False, only={"fox", "cesium_man"})
    rows = {r.name: r for r in report.rows}
    assert set(rows) == {"fox", "cesium_man"} and all(r.target == "artist" and r.error is None for r in rows.values())
    fox_error, man_error = rows["fox"].vertex_error, rows["cesium_man"].vertex_error
    assert fox_error is not None and man_error is not None
    assert fox_error < 1e-6 and rows["fox"].mapped == rows["fox"].joints == 24
    assert man_error < 2e-3  # its arm joints carry small keyed translations we keep rigid
    assert rows["cesium_man"].mocap_sliding is not None and rows["fox"].mocap_sliding is None  # mocap: humanoids only

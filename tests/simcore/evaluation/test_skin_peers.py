"""Peer rows in `rigforge eval skin` (issue 23, honest peers): a peer solve that failed is scored and marked as
failed, never taken for a result, and peer means are shown with and without it, ours beside them on the same assets."""

from __future__ import annotations

import io

import numpy as np
import pytest
from rich.console import Console

from cli.eval_skin import render
from simcore.evaluation.skin_eval import evaluate_skinning
from simcore.io.gltf_document import GltfDocument
from simcore.io.gltf_rig import read_rigged_asset
from tests.simcore.io.studio_rig_fixtures import studio_rig, to_glb


@pytest.fixture()
def two_assets_one_failed_peer(tmp_path, request):
    """Two copies of a small rig; the peer solved one cleanly (the artist's weights) and failed on the other
    (an all-zero matrix, with Blender's status and message, or bare as files written before statuses were kept)."""
    assets, peers = tmp_path / "assets", tmp_path / "peers" / "blender"
    assets.mkdir()
    peers.mkdir(parents=True)
    glb = to_glb(studio_rig(["hips", "spine", "head"]))
    for name in ("solved", "failed"):
        (assets / f"{name}.glb").write_bytes(glb)
    weights = read_rigged_asset(GltfDocument.from_bytes(glb)).weights.toarray()
    np.savez(peers / "solved.npz", weights=weights, seconds=0.01, status="ok", unweighted_share=0.0)
    failed = {"weights": np.zeros_like(weights), "seconds": 0.01}
    if request.param == "with_status":
        failed.update(status="failed", unweighted_share=1.0,
                      messages="Warning: Bone Heat Weighting: failed to find solution for one or more bones")
    np.savez(peers / "failed.npz", **failed)
    return assets, peers.parent


@pytest.mark.parametrize("two_assets_one_failed_peer", ["with_status", "legacy"], indirect=True)
def test_a_failed_peer_solve_is_marked_and_left_out_of_the_solved_means(two_assets_one_failed_peer):
    assets, peers = two_assets_one_failed_peer

    report = evaluate_skinning(assets, ["geodesic"], peers=peers)

    rows = {(r.name, r.method): r.to_dict() for r in report.rows}
    assert rows["failed", "blender"]["status"] == "failed" and rows["failed", "blender"]["unweighted_share"] == 1.0
    assert "failed" in rows["failed", "blender"]["note"]
    assert rows["solved", "blender"]["status"] == "ok" and rows["solved", "blender"]["l1"] == pytest.approx(0.0, abs=1e-6)
    means = report.to_dict()["peer_means"]["blender"]
    assert (means["ok"], means["partial"], means["failed"], means["error"]) == (1, 0, 1, 0)
    assert means["scored"]["blender"]["assets"] == means["scored"]["geodesic"]["assets"] == 2
    assert means["solved"]["blender"]["assets"] == means["solved"]["geodesic"]["assets"] == 1
    assert means["solved"]["blender"]["l1"] == pytest.approx(0.0, abs=1e-6)
    assert means["scored"]["blender"]["l1"] > 0.4  # the failed solve counts there, as a user would get it
    out = io.StringIO()
    render(report, Console(file=out, width=250))
    assert "blender (failed 100%)" in out.getvalue() and "MEAN (blender solved)" in out.getvalue()

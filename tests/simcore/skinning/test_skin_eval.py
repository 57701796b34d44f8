"""`rigforge eval skin` core on two small dev rigs (skipped without ../shared)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from simcore.errors import InvalidInput
from simcore.evaluation.methods import listed_methods
from simcore.evaluation.skin_eval import OUR_METHODS, evaluate_skinning, rigged_assets


def test_eval_rows_clip_column_and_a_perfect_peer(dev_assets: Path, tmp_path: Path) -> None:
    assets = tmp_path / "assets"
    assets.mkdir()
    for name in ("rigged_figure.glb", "rignet_15930_bat.glb"):
        (assets / name).symlink_to(dev_assets / name)
    peers = tmp_path / "peers" / "artist"
    peers.mkdir(parents=True)
    for name, _, _, asset in rigged_assets(assets):  # a "peer" that returns the artist's own weights
        np.savez(peers / f"{name}.npz", weights=asset.weights.toarray(), seconds=np.float64(0.5))
    report = evaluate_skinning(assets, ["geodesic"], peers=tmp_path / "peers").to_dict()
    rows = {(r["name"], r["method"]): r for r in report["assets"]}
    assert set(rows) == {(n, m) for n in ("rigged_figure", "rignet_15930_bat") for m in ("geodesic", "artist")}
    ours = rows[("rigged_figure", "geodesic")]
    assert 0.0 < ours["l1"] < 1.0 and 0.0 < ours["deform_mean"] < ours["deform_p95"] < 0.1
    assert 0.0 < ours["precision"] <= 1.0 and 0.5 < ours["recall"] <= 1.0
    assert ours["clip_deform_mean"] is not None  # RiggedFigure carries its walk clip
    assert rows[("rignet_15930_bat", "geodesic")]["clip_deform_mean"] is None  # RigNet files have none
    perfect = rows[("rigged_figure", "artist")]
    assert perfect["l1"] < 1e-5 and perfect["deform_mean"] < 1e-6 and perfect["seconds"] == 0.5
    assert set(report["mean"]) == {"geodesic", "artist"} and report["mean"]["artist"]["assets"] == 2


def test_joint_correspondence_matches_bones_not_names() -> None:
    """Our 4-joint chain over the artist's 3-joint chain: each of our joints follows the artist bone under it."""
    import scipy.sparse as sp

    from simcore.evaluation.skin_eval import joint_correspondence
    from simcore.skeleton.types import Skeleton

    gt = Skeleton(np.array([[0.0, 0, 0], [0, 1, 0], [0, 2, 0]]), np.array([-1, 0, 1]), ["a", "b", "c"])
    ours = Skeleton(np.array([[0.0, 0, 0], [0, 0.5, 0], [0, 1.2, 0], [0, 2.1, 0]]), np.array([-1, 0, 1, 2]), list("wxyz"))
    weights = sp.csr_matrix(np.eye(3))
    np.testing.assert_array_equal(joint_correspondence(ours, gt, weights), [0, 0, 1, 2])
    np.testing.assert_array_equal(joint_correspondence(gt, gt, weights), [0, 1, 2])


def test_method_values_expand_all_keep_order_and_reject_unknown_names(tmp_path: Path) -> None:
    """An empty folder: the methods are checked before any asset is read."""
    assert evaluate_skinning(tmp_path, ["all"]).methods() == []
    for bad in (["nonsense"], ["all", "heat"]):
        with pytest.raises(InvalidInput) as caught:
            evaluate_skinning(tmp_path, bad)
        assert caught.value.field == "method"
    assert listed_methods(["all"], OUR_METHODS, ["learned", "geodesic", "heat"], "skinning method") == \
        ["learned", "geodesic", "heat"]
    assert listed_methods(["heat", "geodesic", "heat"], OUR_METHODS, [], "skinning method") == ["heat", "geodesic"]


def test_the_command_scores_every_method_it_is_given(dev_assets: Path, tmp_path: Path) -> None:
    """`--method geodesic --method heat`: rows for both (the option repeats; it once kept only the last)."""
    from typer.testing import CliRunner

    from cli.main import app

    assets = tmp_path / "assets"
    assets.mkdir()
    (assets / "rigged_figure.glb").symlink_to(dev_assets / "rigged_figure.glb")
    out = tmp_path / "report.json"
    done = CliRunner().invoke(app, ["eval", "skin", str(assets), "--method", "geodesic", "--method", "heat",
                                    "--json", str(out)])
    assert done.exit_code == 0, done.output
    report = json.loads(out.read_text())
    assert [r["method"] for r in report["assets"]] == ["geodesic", "heat"]

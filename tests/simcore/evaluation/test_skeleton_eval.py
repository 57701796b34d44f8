"""`rigforge eval skeleton`: rows per rigged asset, skipped non-rigged files, categories, JSON report."""

from __future__ import annotations

import json
import shutil

import numpy as np
import pytest
import trimesh
import typer
from typer.testing import CliRunner

from cli.eval_skeleton import eval_skeleton
from simcore.errors import InvalidInput
from simcore.evaluation.skeleton_eval import AssetResult, SkeletonEvaluation, evaluate_directory, read_categories, resolve_methods
from simcore.evaluation.voxel_baseline import voxel_skeleton_graph
from simcore.metrics.skeleton import SkeletonScores


@pytest.fixture
def small_dir(dev_assets, tmp_path):
    """Two small rigs, one skin-less morph sequence, and a manifest naming one category."""
    for name in ("rigged_simple.glb", "rignet_15930_bat.glb", "meshseq_flamingo.glb"):
        shutil.copy(dev_assets / name, tmp_path / name)
    (tmp_path / "MANIFEST.tsv").write_text("name\tfile\tcategory\nbat\trignet_15930_bat.glb\tflyer\n")
    return tmp_path


def test_voxel_baseline_follows_the_capsule_axis() -> None:
    capsule = trimesh.creation.capsule(height=2.0, radius=0.25)  # axis along z, from -1.25 to 1.25
    joints, edges = voxel_skeleton_graph(capsule.vertices, capsule.faces)
    assert len(joints) > 10 and len(edges) >= len(joints) - 1
    assert np.abs(joints[:, :2]).max() < 0.1  # medial voxels hug the axis
    assert np.ptp(joints[:, 2]) > 1.5


def test_directory_evaluation_rows_categories_and_skips(small_dir) -> None:
    report = evaluate_directory(small_dir, "voxel").to_dict()
    names = [(a["name"], a["category"], a["method"]) for a in report["assets"]]
    assert names == [("rigged_simple", "unknown", "voxel"), ("rignet_15930_bat", "flyer", "voxel")]
    assert "meshseq_flamingo" in report["skipped"] and report["skipped"]["meshseq_flamingo"].startswith("no_skin")
    bat = report["assets"][1]
    assert bat["joints_gt"] == 12 and 0 < bat["j2j"] < 0.2 and 0 <= bat["inside"] <= 1
    mean = report["mean"]["voxel"]
    assert mean["assets"] == 2 and mean["j2j"] == pytest.approx((report["assets"][0]["j2j"] + bat["j2j"]) / 2, abs=1e-6)
    assert report["by_category"]["voxel"]["flyer"]["assets"] == 1
    assert report["tokens"]["skeletons"] == 2 and 0 < report["tokens"]["saving"] < 1


def test_cli_writes_json(small_dir, tmp_path) -> None:
    app = typer.Typer()
    app.command()(eval_skeleton)
    out = tmp_path / "report.json"
    result = CliRunner().invoke(app, [str(small_dir), "--method", "voxel", "--method", "geometric", "--json", str(out)])
    assert result.exit_code == 0, result.output
    assert "MEAN" in result.output and "skipped meshseq_flamingo" in result.output
    data = json.loads(out.read_text())
    assert [a["method"] for a in data["assets"]] == ["voxel", "geometric"] * 2  # the option repeats
    assert {"name", "category", "method", "j2j", "j2b", "b2b", "joints_pred", "joints_gt", "inside", "seconds"} <= set(data["assets"][0])


def test_methods_and_manifest_parsing(dev_assets, tmp_path) -> None:
    assert resolve_methods("all") == ["voxel", "auto", "learned"]
    with pytest.raises(InvalidInput) as err:
        resolve_methods("magic")
    assert err.value.field == "method"
    assert resolve_methods(("learned", "auto")) == ["learned", "auto"]  # a list runs as it is, each file read once
    for bad in (["auto", "magic"], ["all", "auto"]):
        with pytest.raises(InvalidInput):
            resolve_methods(bad)
    assert read_categories(dev_assets)["fox"] == "quadruped"
    assert read_categories(tmp_path) == {}


def test_split_keeps_the_files_the_manifest_lists_for_it(small_dir) -> None:
    (small_dir / "MANIFEST.tsv").write_text("name\tfile\tcategory\tsplit\nbat\trignet_15930_bat.glb\tflyer\tval\n"
                                            "simple\trigged_simple.glb\ttoy\ttrain\n")
    report = evaluate_directory(small_dir, "voxel", split="val").to_dict()
    assert [(a["name"], a["category"]) for a in report["assets"]] == [("rignet_15930_bat", "flyer")]


def test_means_count_plausible_joint_counts_and_wins_over_the_voxel_baseline() -> None:
    def row(name: str, method: str, j2j: float, joints: int) -> AssetResult:
        return AssetResult(name, "x", method, SkeletonScores(j2j, j2j, j2j, joints, 10, 1.0), 0.1)

    evaluation = SkeletonEvaluation([row("a", "voxel", 0.05, 90), row("b", "voxel", 0.05, 80),
                                     row("a", "auto", 0.04, 12), row("b", "auto", 0.06, 30)])
    auto, voxel = evaluation.mean("auto"), evaluation.mean("voxel")
    assert auto["joint_ratio_ok"] == 0.5 and auto["beats_voxel"] == 0.5  # b has 3x the joints and a higher J2J
    assert voxel["joint_ratio_ok"] == 0.0 and "beats_voxel" not in voxel


def test_model_option_scores_the_weights_it_is_given(small_dir, tmp_path) -> None:
    """`--model`: the learned rows come from that file (a corrupt one is each asset's error row), never the shipped one."""
    app = typer.Typer()
    app.command()(eval_skeleton)
    weights = tmp_path / "fresh.safetensors"
    weights.write_bytes(b"not a safetensors file")
    out = tmp_path / "report.json"
    result = CliRunner().invoke(app, [str(small_dir), "--method", "learned", "--model", str(weights), "--json", str(out)])
    assert result.exit_code == 0, result.output
    rows = json.loads(out.read_text())["assets"]
    assert len(rows) == 2 and all(r["error"] and "model_unavailable" in r["error"] and "fresh.safetensors" in r["error"] for r in rows)

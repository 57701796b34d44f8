"""Skeleton metrics on hand-computed tiny cases, and agreement with the independent reference tool."""

from __future__ import annotations

import json
import struct
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import scipy.sparse as sp
import trimesh

from simcore.io.gltf_document import GltfDocument
from simcore.io.gltf_rig import read_rigged_asset, used_joints
from simcore.metrics.skeleton import bone_points, ground_truth_skeleton, skeleton_scores, used_skeleton
from simcore.skeleton.types import Skeleton

REFERENCE_TOOL = Path(__file__).resolve().parents[3].parent / "shared" / "tools" / "rigmetrics.py"


@pytest.fixture
def box() -> trimesh.Trimesh:
    """A 2 × 1 × 1 m box centred at the origin: one unit-cube unit is 2 m."""
    return trimesh.creation.box(extents=[2.0, 1.0, 1.0])


def line(points: list[list[float]]) -> Skeleton:
    """A chain through `points` in order."""
    return Skeleton(np.asarray(points, float), np.arange(len(points)) - 1, [f"j{i}" for i in range(len(points))])


def test_shifted_copy_scores_the_shift_in_unit_cube_units(box) -> None:
    gt = line([[-0.8, 0, 0], [0.8, 0, 0]])
    pred = line([[-0.8, 0.2, 0], [0.8, 0.2, 0]])
    s = skeleton_scores(pred, gt, box.vertices, box.faces)
    assert s.j2j == pytest.approx(0.1) and s.j2b == pytest.approx(0.1) and s.b2b == pytest.approx(0.1)
    assert (s.joints_pred, s.joints_gt, s.joint_ratio) == (2, 2, 1.0)


def test_extra_joint_on_the_bone_costs_j2j_but_not_b2b(box) -> None:
    gt = line([[-0.5, 0, 0], [0.5, 0, 0]])  # 0.5 units long
    pred = line([[-0.5, 0, 0], [0.0, 0, 0], [0.5, 0, 0]])
    s = skeleton_scores(pred, gt, box.vertices, box.faces)
    # pred→gt: (0 + 0.25 + 0) / 3, gt→pred: 0; halved.
    assert s.j2j == pytest.approx(0.25 / 3 / 2)
    assert s.j2b == pytest.approx(0.0, abs=1e-12) and s.b2b == pytest.approx(0.0, abs=1e-12)
    assert s.j2j_matched == pytest.approx(0.0, abs=1e-12)  # the middle joint is extra: all of J2J is its cost


def test_j2j_matched_keeps_the_misplacement_of_the_matched_joints(box) -> None:
    gt = line([[-0.5, 0, 0], [0.5, 0, 0]])
    pred = line([[-0.5, 0.2, 0], [0.5, 0.2, 0], [0.5, 0.4, 0]])  # both ends 0.1 units off, one extra 0.2 off
    s = skeleton_scores(pred, gt, box.vertices, box.faces)
    assert s.j2j == pytest.approx(0.5 * ((0.1 + 0.1 + 0.2) / 3 + 0.1))
    assert s.j2j_matched == pytest.approx(0.1)


def test_inside_share_uses_the_solid_mesh(box) -> None:
    gt = line([[-0.5, 0, 0], [0.5, 0, 0]])
    pred = line([[-0.5, 0, 0], [0.0, 0.0, 0.0], [0.0, 0.9, 0.0], [0.0, 1.5, 0.0]])
    assert skeleton_scores(pred, gt, box.vertices, box.faces).inside == pytest.approx(0.5)


def test_bone_points_are_dense_and_keep_the_ends() -> None:
    pts = bone_points(np.array([[0.0, 0, 0], [0.0123, 0, 0]]), np.array([[0, 1]]), step=0.005)
    xs = np.sort(pts[:, 0])
    assert xs[0] == 0.0 and xs[-1] == pytest.approx(0.0123)
    assert np.diff(np.unique(xs)).max() <= 0.005 + 1e-12
    assert len(bone_points(np.zeros((1, 3)), np.zeros((0, 2)))) == 1


def test_ground_truth_keeps_influencing_joints_and_their_ancestors() -> None:
    # 0 root (no weight) → 1 (no weight) → 2 (weighted); 0 → 3 (no weight, no weighted descendant).
    skel = Skeleton(np.eye(4, 3), np.array([-1, 0, 1, 0]), ["root", "mid", "tip", "unused"])
    weights = sp.csr_matrix(np.array([[0.0, 0.0, 1.0, 0.0]]))
    kept = used_skeleton(skel, used_joints(skel, weights))
    assert kept.names == ["root", "mid", "tip"] and kept.parents.tolist() == [-1, 0, 1]


def _perturbed_copy(src: Path, dst: Path, sigma: float) -> None:
    """Copy a GLB, moving every skin joint's bind position by seeded noise (inverse bind matrices patched)."""
    data = bytearray(src.read_bytes())
    json_len = struct.unpack_from("<I", data, 12)[0]
    doc = json.loads(bytes(data[20:20 + json_len]))
    bin_start = 20 + json_len + 8
    rng = np.random.default_rng(0)
    for skin in doc["skins"]:
        acc = doc["accessors"][skin["inverseBindMatrices"]]
        at = bin_start + doc["bufferViews"][acc["bufferView"]].get("byteOffset", 0) + acc.get("byteOffset", 0)
        size = 64 * acc["count"]
        ibm = np.frombuffer(bytes(data[at:at + size]), np.float32).reshape(-1, 4, 4).transpose(0, 2, 1)
        bind = np.linalg.inv(ibm.astype(np.float64))
        bind[:, :3, 3] += rng.normal(0.0, sigma, (len(bind), 3))
        data[at:at + size] = np.linalg.inv(bind).transpose(0, 2, 1).astype(np.float32).tobytes()
    dst.write_bytes(bytes(data))


@pytest.mark.parametrize("name", ["fox", "cesium_man", "rignet_17364_humanoid_a", "soldier"])
def test_agrees_with_reference_tool(dev_assets, tmp_path, name) -> None:
    if not REFERENCE_TOOL.exists():
        pytest.skip(f"reference tool not found at {REFERENCE_TOOL}")
    src = dev_assets / f"{name}.glb"
    gt = read_rigged_asset(GltfDocument.from_bytes(src.read_bytes()))
    pred_path = tmp_path / f"{name}.glb"
    _perturbed_copy(src, pred_path, 0.02 * float(np.ptp(gt.vertices, axis=0).max()))
    pred = read_rigged_asset(GltfDocument.from_bytes(pred_path.read_bytes()))
    ours = skeleton_scores(ground_truth_skeleton(pred), ground_truth_skeleton(gt), gt.vertices, gt.faces)
    out = tmp_path / "ref.json"
    subprocess.run([sys.executable, str(REFERENCE_TOOL), str(pred_path), str(src), "--json", str(out)],
                   check=True, capture_output=True, timeout=120)
    ref = json.loads(out.read_text())["assets"][name]
    assert ours.j2j > 0.005  # the perturbation is visible, so agreement means something
    for key in ("j2j", "j2b", "b2b"):
        assert getattr(ours, key) == pytest.approx(ref[key], abs=1e-3), key
    assert (ours.joints_pred, ours.joints_gt) == (ref["joints_pred"], ref["joints_gt"])

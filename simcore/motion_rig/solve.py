"""Rig a mesh sequence: free bones (Dem Bones) → joint tree → bone motion and weights re-fitted on the tree →
joints the motion cannot reveal added from the mesh's shape."""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np
import scipy.sparse as sp

from simcore.geometry.voxelize import JOINT_TEST_RESOLUTION, VoxelGrid, solid_voxels
from simcore.motion.types import JointAnimation
from simcore.motion_rig.connected_solve import connected_transforms
from simcore.motion_rig.free_bones import (
    BoneFit,
    reconstruct,
    rmse,
    solve_free_bones,
    solve_from_clusters,
    solve_weights,
)
from simcore.motion_rig.hierarchy import BoneTree, bone_tree
from simcore.motion_rig.joint_animation import joint_animation
from simcore.motion_rig.joints import bone_pairs
from simcore.motion_rig.rigid_merge import merge_moving_alike
from simcore.motion_rig.sequence_weld import seam_triangles
from simcore.motion_rig.shape_joints import add_shape_joints
from simcore.skeleton.inside import snap_inside
from simcore.skeleton.types import Skeleton

Progress = Callable[[float], None]


@dataclass(frozen=True)
class MotionRigParams:
    """How a sequence is rigged.

    bones: a fixed bone count; None chooses it along `search_counts` (capped by `max_bones`): the first count whose
    free-bone fit reaches `target_rmse` (a share of the first frame's bounding-box diagonal), or that Dem Bones
    cannot fill, or the count before one that cuts the error by less than `min_gain` (when that count's error is
    below `usable_rmse`: a flat stretch of a curve still far off is a solver that stalls; a count that fits worse
    than the best smaller one is skipped, as a fit that stalled); else `max_bones`.
    The tree's weights and transforms alternate (`refit_on_tree`) until the rig is as close as free bones, the
    error stalls (`round_gain`, `patience`) or `rounds` run out. Shape joints (`shape_reach`) fill the parts the
    motion never bends, within `max_bones` joints in all.
    """

    max_influences: int = 4
    bones: int | None = None
    max_bones: int = 64
    target_rmse: float = 0.0005
    min_gain: float = 0.15
    usable_rmse: float = 0.01  # a flattening curve ends the search only at a count whose error is below this
    kmeans_margin: float = 0.5  # k-means start kept when its search error is below this share of Dem Bones' own
    search_counts: tuple[int, ...] = (2, 4, 8, 16, 24, 32, 48, 64, 96, 128, 192, 256)
    search_frames: int = 12  # frames (evenly spread) the count search fits
    search_iterations: int = 3  # Dem Bones iterations while choosing the count
    iterations: int = 12  # Dem Bones iterations of the chosen count's fit
    spread: int = 2  # 1-ring steps that make neighbouring bones' regions meet
    merge_share: float = 0.25  # touching free bones whose motions differ by under this share of the fit error merge
    pivot_regularisation: float = 3e-4
    slide_mismatch: float = 0.01  # share of the diagonal: a bone pair that far from turning about a point slides
    sweeps: int = 48  # at most this many tree transform sweeps per round
    sweep_gain: float = 0.005  # a round's sweeps stop after one that cuts the squared error by less than this
    total_sweeps: int = 200  # sweeps over all rounds (the time of the re-fit is about this many sweeps at most)
    rounds: int = 24  # at most this many weight → transform alternations on the tree
    weight_iterations: int = 3
    inside_reach: float = 2.0  # voxels: a joint the motion pins outside still moves to an inside voxel this near
    round_gain: float = 0.01  # alternations stop once `patience` rounds in a row cut the error by less than this
    patience: int = 2
    shape_reach: float | None = 1.0  # shape-skeleton joints this many local thicknesses from every motion joint
    # are added (simcore.motion_rig.shape_joints); None adds none


@dataclass
class MotionRig:
    """The recovered rig: skeleton (rest = `rest`), weights (V, J) float32 CSR rows summing to 1, its animation,
    and `report` (joint count, of them the bones read off the motion and the shape joints, per-frame RMSE of the
    rig and of free bones at the motion's bone count in units of the first frame's bounding-box diagonal, times).
    The motion's joints come first in the skeleton, the shape joints after them."""

    skeleton: Skeleton
    weights: sp.csr_matrix
    animation: JointAnimation
    report: dict[str, Any] = field(default_factory=dict)


def _counts(params: MotionRigParams) -> list[int]:
    if params.bones is not None:
        return [params.bones]
    return sorted({c for c in params.search_counts if c < params.max_bones} | {params.max_bones})


def _error(rest: np.ndarray, frames: np.ndarray, fit: BoneFit) -> float:
    """RMSE over every frame and vertex, in units of the first frame's bounding-box diagonal."""
    diag = float(np.linalg.norm(np.ptp(frames[0], axis=0)))
    return float(np.sqrt((rmse(reconstruct(rest, fit.weights, fit.transforms), frames) ** 2).mean())) / diag


def _free_fit(rest: np.ndarray, frames: np.ndarray, surface: np.ndarray, count: int, params: MotionRigParams,
              iterations: int, start: str) -> BoneFit:
    """Dem Bones from its own cluster splitting (`start` "split") or from k-means clusters of the vertex
    trajectories ("kmeans")."""
    solve = solve_free_bones if start == "split" else solve_from_clusters
    return solve(rest, frames, surface, count, max_influences=params.max_influences, iterations=iterations)


def choose_free_bones(rest: np.ndarray, frames: np.ndarray, surface: np.ndarray, params: MotionRigParams,
                      progress: Progress) -> tuple[BoneFit, list[dict[str, Any]]]:
    """The free-bone fit at the chosen count (full iterations) and the trail of the search.

    Each count is tried from both starts: Dem Bones' own splitting stalls or stays coarse on some sequences (a
    smooth tube, a pose far from the bind pose); k-means of the trajectories is taken only when clearly better
    (its bones fit as well elsewhere but join into a worse tree).
    """
    counts = _counts(params)
    trail: list[dict[str, Any]] = []
    chosen, start, before = counts[-1], "split", None
    sample = frames[np.unique(np.linspace(0, len(frames) - 1, params.search_frames).astype(np.int64))]
    for i, count in enumerate(counts):
        if len(counts) == 1:
            break
        tried = {how: _free_fit(rest, sample, surface, count, params, params.search_iterations, how)
                 for how in ("split", "kmeans") if how == "split" or count <= len(rest)}
        errors = {how: _error(rest, sample, fit) for how, fit in tried.items()}
        best = "kmeans" if errors.get("kmeans", np.inf) < params.kmeans_margin * errors["split"] else "split"
        fit, error = tried[best], errors[best]
        trail.append({"bones": fit.num_bones, "asked": count, "rmse": round(error, 6), "start": best})
        progress(0.5 * (i + 1) / len(counts))
        if before is not None and error > before[1] and fit.num_bones > before[2] and count < counts[-1]:
            continue  # more bones fitting worse is a fit that stalled, not a flat curve: try the next count
        if before is not None and error > (1.0 - params.min_gain) * before[1] and before[1] <= params.usable_rmse:
            chosen, start = before[0], before[3]  # the curve has flattened: more bones fit detail, not joints
            break
        if error <= params.target_rmse or (before is not None and fit.num_bones <= before[2]):
            chosen, start = count, best  # close enough, or no more bones to split off
            break
        before = (count, error, fit.num_bones, best)
    else:
        start = before[3] if before is not None else "split"
    return _free_fit(rest, frames, surface, chosen, params, params.iterations, start), trail


def joints_inside(grid: VoxelGrid, tree: BoneTree, loose: float = 0.01, reach: float = 0.0) -> np.ndarray:
    """(B, 3) the tree's joints with those outside the solid moved in along the directions their motion leaves
    open (stiffness below `loose` × its largest: a hinge's axis, every direction of a pair that never bends):
    towards the bone's border with its parent, else towards the nearest inside voxel. A joint the motion pins
    outside moves to the nearest inside voxel centre only when that lies within `reach` voxels (as near as the
    solid's own one-voxel surface is sure; the re-fit then takes up the small cost), and otherwise stays."""
    joints = tree.joints.copy()
    outside = np.flatnonzero(~grid.inside(joints))
    if not len(outside):
        return joints
    snapped = snap_inside(grid, joints[outside])
    for k, i in enumerate(outside.tolist()):
        values, vectors = np.linalg.eigh(tree.stiffness[i])
        free = vectors[:, values <= loose * max(float(values.max()), 1e-12)]
        for target in (tree.borders[i], snapped[k]):
            moved = joints[i] + free @ (free.T @ (target - joints[i]))
            if grid.inside(moved[None])[0]:
                joints[i] = moved
                break
        else:
            if np.linalg.norm(snapped[k] - joints[i]) <= reach * grid.pitch:
                joints[i] = snapped[k]
    return joints


def refit_on_tree(rest: np.ndarray, frames: np.ndarray, surface: np.ndarray, free: BoneFit, tree: BoneTree,
                  params: MotionRigParams, free_error: float, progress: Progress,
                  grid: VoxelGrid | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray, list[float]]:
    """Weights (V, B), transforms (T, B, 4, 4) and rest joints (B, 3) of the tree fitted to `frames`, and the
    error after each round (first frame's bounding-box diagonals, over every frame and vertex).

    Starts from the free bones' weights and motion with the joints carried by their parents, then alternates a
    weight solve (Dem Bones, transforms fixed) with a connected transform and joint fit: each alternation lets
    the weights take up what the joint constraints cost. It stops once the error reaches `free_error` (the
    unconstrained fit at this count), after `patience` rounds in a row that gain less than `round_gain`, after
    `params.rounds`, or once `params.total_sweeps` transform sweeps have run (a bound on its time); the best round
    is kept (the weight solve's smoothing can cost a round some error). With `grid` (the body's solid), a joint
    inside it stays inside through the joint moves (connected_solve's `inside`).
    """
    diag = float(np.linalg.norm(np.ptp(frames[0], axis=0)))

    def error(w: np.ndarray, m: np.ndarray) -> float:
        return float(np.sqrt((rmse(reconstruct(rest, w, m), frames) ** 2).mean())) / diag

    budget = params.total_sweeps

    def transforms_for(w: np.ndarray, m: np.ndarray, j: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        nonlocal budget
        out, moved, done = connected_transforms(rest, frames, w, tree.parents, j, tree.floating, m,
                                                sweeps=min(params.sweeps, budget),
                                                joint_regularisation=params.pivot_regularisation,
                                                min_gain=params.sweep_gain, anchors=tree.joints,
                                                inside=None if grid is None else grid.inside)
        budget -= done
        return out, moved

    weights = free.weights[:, tree.order]
    transforms, joints = transforms_for(weights, free.transforms[:, tree.order], tree.joints)
    errors = [error(weights, transforms)]
    best = (errors[0], weights, transforms, joints)
    stalled = 0
    for r in range(params.rounds):
        if best[0] <= free_error or stalled >= params.patience or budget <= 0:
            break
        weights = solve_weights(rest, frames, surface, BoneFit(weights, transforms),
                                max_influences=params.max_influences, iterations=params.weight_iterations)
        transforms, joints = transforms_for(weights, transforms, joints)
        errors.append(error(weights, transforms))
        stalled = stalled + 1 if errors[-1] > (1.0 - params.round_gain) * best[0] else 0
        if errors[-1] < best[0]:
            best = (errors[-1], weights, transforms, joints)
        progress((r + 1) / params.rounds)
    return best[1], best[2], best[3], [round(e, 7) for e in errors]


def rig_from_motion(rest: np.ndarray, faces: np.ndarray, frames: np.ndarray, fps: float,
                    params: MotionRigParams = MotionRigParams(), progress: Progress = lambda f: None,
                    name: str = "clip") -> MotionRig:
    """Skeleton, weights and animation that reproduce `frames` by LBS of `rest`.

    rest: (V, 3) float64 bind pose (metres); faces: (F, 3) int64; frames: (T, V, 3) float64, same vertex order.
    """
    started = time.perf_counter()
    rest, frames = np.asarray(rest, np.float64), np.asarray(frames, np.float64)
    diag = float(np.linalg.norm(np.ptp(frames[0], axis=0)))
    seams = seam_triangles(frames, faces)
    surface = np.concatenate([faces, seams])  # Dem Bones and bone adjacency see one surface across seams
    free, trail = choose_free_bones(rest, frames, surface, params, progress)
    free_seconds = time.perf_counter() - started
    progress(0.6)
    free_error = rmse(reconstruct(rest, free.weights, free.transforms), frames) / diag
    free_total = float(np.sqrt((free_error**2).mean()))
    bones, merged = merge_moving_alike(rest, surface, free, params.merge_share * free_total * diag)
    pairs = bone_pairs(rest, surface, bones.weights, bones.transforms, spread=params.spread,
                       pivot_regularisation=params.pivot_regularisation)
    tree = bone_tree(rest, bones.weights, pairs, params.slide_mismatch * diag)
    grid = solid_voxels(rest, faces, resolution=JOINT_TEST_RESOLUTION)  # the gate's joints-inside solid
    inside = joints_inside(grid, tree, reach=params.inside_reach)
    moved_in = np.any(inside != tree.joints, axis=1)  # joints outside the solid that could be moved in
    tree = replace(tree, joints=inside)
    weights, transforms, joints, refit = refit_on_tree(rest, frames, surface, bones, tree, params, free_total,
                                                       lambda f: progress(0.6 + 0.35 * f), grid)
    weights = weights / np.maximum(weights.sum(axis=1, keepdims=True), 1e-12)
    names = ["root"] + [f"bone_{i:02d}" for i in range(1, len(tree.order))]
    skeleton = Skeleton(joints, tree.parents, names).validate()
    added = 0
    if params.shape_reach is not None:
        grown = add_shape_joints(rest, faces, skeleton, weights, transforms, grid, reach=params.shape_reach,
                                 max_joints=params.max_bones, max_influences=params.max_influences)
        skeleton, weights, transforms, added = grown.skeleton, grown.weights, grown.transforms, len(grown.owner)
    animation = joint_animation(skeleton, transforms, fps, name)
    rig_error = rmse(reconstruct(rest, weights, transforms), frames) / diag
    report = {
        "bones": skeleton.num_joints,
        "motion_bones": skeleton.num_joints - added,  # the free-bone count the RMSE figures compare at
        "shape_joints": added,
        "sliding_joints": int(tree.sliding.sum()),
        "merged_bones": merged,
        "joints_moved_inside": int(moved_in.sum()),
        "joints_outside": int((~grid.inside(skeleton.positions)).sum()),
        "separate_part_joints": int(tree.floating.sum() - tree.sliding.sum()) - 1,
        "frames": int(frames.shape[0]),
        "vertices": int(frames.shape[1]),
        "seam_links": int(len(seams)),
        "rmse": round(float(np.sqrt((rig_error**2).mean())), 6),
        "free_bones_rmse": round(float(np.sqrt((free_error**2).mean())), 6),
        "rmse_per_frame": np.round(rig_error, 6).tolist(),
        "free_bones_rmse_per_frame": np.round(free_error, 6).tolist(),
        "rmse_unit": "first frame's bounding-box diagonal",
        "count_search": trail,
        "refit_rounds": refit,
        "free_bone_centres": np.round((free.weights.T @ rest) / free.weights.sum(axis=0)[:, None], 6).tolist(),
        "free_bones_seconds": round(free_seconds, 3),
        "seconds": round(time.perf_counter() - started, 3),
    }
    progress(1.0)
    return MotionRig(skeleton, sp.csr_matrix(weights.astype(np.float32)), animation, report)

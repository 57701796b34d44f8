"""Finger joints for a fitted humanoid: re-voxelise each hand finely and read the fingers off its medial tree.

A hand is cropped around the fitted wrist (vertices of faces inside a sphere over the hand), voxelised at a
resolution where fingers separate, thinned and pruned. Tips beyond the wrist are finger candidates; the
thumb is the one that branches off closest to the wrist, the other four are ordered index → pinky by how far
forward they are (palms down or in, the index is the front finger). Joints 1, 2, 3 sit along each finger's
branch (knuckle, then fractions of the knuckle → tip length measured on Mixamo hands). Five tips, or four (a
cartoon hand: a thumb and three fingers, named `mixamo.FOUR_FINGERS`), must stand out from any further tip (a
long one beyond them means surface noise or a mitten's folds); both hands must show the same count. When fingers
touch so closely that they share voxels, `finger_template` checks the mesh's cross-sections for separate finger
shells and lays the joints out from the Mixamo hand template instead (report: "fallback", "template").
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from simcore.arrays import unique_ints
from simcore.geometry.voxelize import VoxelGrid, solid_voxels
from simcore.skeleton.finger_template import HAND_KINDS, template_fingers
from simcore.skeleton.geometric import rank_bodies
from simcore.skeleton.graph_simplify import path_length, point_at_fraction, prune_spurs, rooted_parents
from simcore.skeleton.inside import snap_inside
from simcore.skeleton.medial import medial_forest

HAND_RESOLUTION = 96  # 64 merges fingers that are only a few millimetres apart; 128 costs 3× the time
STAND_OUT = 0.6  # a further finger-like tip longer than this × the last finger means the "fingers" are surface noise
MIN_FINGER_RATIO = 0.35  # shortest / longest free finger branch (the thumb's is the shortest on real hands)
PHALANX = {"Thumb": (0.15, 0.5, 0.8), "Other": (0.0, 0.42, 0.72)}  # fraction of knuckle-branch → tip arc


def _hand_crop(vertices: np.ndarray, faces: np.ndarray, wrist: np.ndarray,
               elbow: np.ndarray) -> tuple[np.ndarray, np.ndarray] | None:
    """The triangles inside a sphere over the hand, re-indexed: ((V', 3), (F', 3)), or None when too few."""
    forearm = float(np.linalg.norm(wrist - elbow))
    d = (wrist - elbow) / max(forearm, 1e-12)
    centre, radius = wrist + 0.35 * forearm * d, 0.75 * forearm
    near = np.linalg.norm(vertices - centre, axis=1) < radius
    keep = near[faces].all(axis=1)
    if keep.sum() < 20:
        return None
    used = unique_ints(faces[keep])
    remap = -np.ones(len(vertices), np.int64)
    remap[used] = np.arange(len(used))
    return vertices[used], remap[faces[keep]]


def _one_hand(grid: VoxelGrid, sub_v: np.ndarray, wrist: np.ndarray, elbow: np.ndarray, forward: np.ndarray,
              kinds: tuple[tuple[str, ...], ...]) -> tuple[dict[str, np.ndarray] | None, dict[str, Any]]:
    """Fingers from the medial tree of the hand crop's solid `grid` (crop vertices sub_v (V, 3)), the first of
    the finger sets `kinds` that stands out, or None."""
    forearm = float(np.linalg.norm(wrist - elbow))
    d = (wrist - elbow) / max(forearm, 1e-12)
    forest = medial_forest(grid)
    ranked, _, _ = rank_bodies(grid, forest)
    scale = float(np.ptp(sub_v, axis=0).max())
    removed = set(prune_spurs(forest.adjacency, forest.positions, forest.radius, 1.5, 0.03 * scale))
    nodes = [int(n) for n in np.flatnonzero(forest.component == ranked[0]) if n not in removed]
    pos = forest.positions
    leaves = [n for n in nodes if len(forest.adjacency[n]) == 1]
    if not leaves:
        return None, {"reason": "no medial tree in the hand crop"}
    along = {n: float((pos[n] - wrist) @ d) for n in nodes}
    root = min(leaves, key=lambda n: (along[n], n))  # the cut forearm end
    parent = rooted_parents(forest.adjacency, root)
    tips = [n for n in leaves if n != root and along[n] > 0.15 * forearm]
    if len(tips) < min(len(f) for f in kinds):
        return None, {"reason": f"fingers not separable ({len(tips)} finger tips found)", "tips": len(tips)}
    chains = {}
    for tip in tips:
        path = [tip]
        while parent[path[-1]] >= 0 and len(forest.adjacency[path[-1]]) <= 2 or len(path) == 1:
            path.append(parent[path[-1]])
        chains[tip] = path  # tip → its branch point
    tips = sorted(tips, key=lambda n: (-path_length(pos, chains[n]), n))
    lengths = [path_length(pos, chains[n]) for n in tips]
    names = next((f for f in kinds if len(tips) >= len(f) and (
        len(tips) == len(f) or lengths[len(f)] <= STAND_OUT * lengths[len(f) - 1])), None)
    if names is None:
        return None, {"reason": f"no {' or '.join(str(len(f)) for f in kinds)} finger branches stand out from the "
                                "other tips (mitten or noisy hand)", "tips": len(tips)}
    tips, lengths = tips[:len(names)], lengths[:len(names)]
    if min(lengths) < MIN_FINGER_RATIO * max(lengths) or max(lengths) < 0.2 * forearm:
        return None, {"reason": "finger-like tips are too unequal or too short to be fingers", "tips": len(tips)}
    thumb = min(tips, key=lambda n: (along[chains[n][-1]], n))
    others = sorted((n for n in tips if n != thumb), key=lambda n: (-float(pos[n] @ forward), n))
    out: dict[str, np.ndarray] = {}
    for finger, tip in zip(names, [thumb] + others):
        pts = pos[chains[tip][::-1]]  # branch point → tip
        for k, frac in enumerate(PHALANX["Thumb" if finger == "Thumb" else "Other"], start=1):
            out[f"{finger}{k}"] = point_at_fraction(pts, frac)
    return out, {"tips": len(leaves) - 1, "fingers": len(names)}


@dataclass
class _Hand:
    """One hand's finger joints (bare names without the side → (3,)), its finger set (a HAND_KINDS entry) and
    whether the template placed them."""

    joints: dict[str, np.ndarray]
    kind: tuple[str, ...]
    template: bool


def _fit_hand(v: np.ndarray, f: np.ndarray, wrist: np.ndarray, elbow: np.ndarray, forward: np.ndarray, side: str,
              kinds: tuple[tuple[str, ...], ...]) -> tuple[_Hand | None, dict[str, Any]]:
    """One hand's fingers from its medial tree, else from the template, with the report."""
    crop = _hand_crop(v, f, wrist, elbow)
    if crop is None:
        return None, {"reason": "too few triangles around the hand"}
    grid = solid_voxels(crop[0], crop[1], resolution=HAND_RESOLUTION)
    fingers, info = _one_hand(grid, crop[0], wrist, elbow, forward, kinds)
    template = fingers is None
    if template:  # touching fingers: the mesh's sections can still show them
        fingers, template_info = template_fingers(crop[0], crop[1], wrist, elbow, forward, side, kinds)
        info = {**info, "fallback": template_info}
        if fingers is not None:  # the template knows proportions, not this hand's surface
            fingers = dict(zip(fingers, snap_inside(grid, np.array(list(fingers.values())))))
    if fingers is None:
        return None, info
    kind = next(k for k in kinds if set(k) == {n.rstrip("0123456789") for n in fingers})  # "Index2" → "Index"
    return _Hand(fingers, kind, template), info


def fit_fingers(vertices: np.ndarray, faces: np.ndarray, body: dict[str, np.ndarray], up: np.ndarray,
                forward: np.ndarray, left: np.ndarray) -> tuple[dict[str, np.ndarray] | None, dict[str, Any]]:
    """The finger joints (bare Mixamo names → (3,) positions) when both hands show fingers, else None: 30 joints,
    or 24 when the hands have four fingers each.

    When one hand reads as five-fingered and the other as four, the five-fingered one is read again as
    four-fingered: a held prop or a fold adds a loop or a tip more often than touching fingers hide one.
    body: bare Mixamo body joint name → (3,) position (needs LeftHand/LeftForeArm and the Right pair).
    """
    v, f = np.asarray(vertices, np.float64), np.asarray(faces, np.int64)
    report: dict[str, Any] = {}
    hands: dict[str, _Hand] = {}
    for side in ("Left", "Right"):
        hand, report[side.lower()] = _fit_hand(v, f, body[f"{side}Hand"], body[f"{side}ForeArm"], forward, side,
                                               HAND_KINDS)
        if hand is None:
            report["separable"] = False
            return None, report
        hands[side] = hand
    more, fewer = sorted(hands, key=lambda s: (-len(hands[s].kind), s))
    if hands[more].kind != hands[fewer].kind:
        again, info = _fit_hand(v, f, body[f"{more}Hand"], body[f"{more}ForeArm"], forward, more, (hands[fewer].kind,))
        report[more.lower()] = {**report[more.lower()], "read_again": info}
        if again is None:
            report.update(separable=False, reason="the hands show different finger counts")
            return None, report
        hands[more] = again
    report["separable"] = True
    report["template"] = any(hand.template for hand in hands.values())
    return {f"{side}Hand{k}": p for side, hand in hands.items() for k, p in hand.joints.items()}, report

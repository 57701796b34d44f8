"""Finger joints for a fitted humanoid: re-voxelise each hand finely and read the fingers off its medial tree.

A hand is cropped around the fitted wrist (vertices of faces inside a sphere over the hand), voxelised at a
resolution where fingers separate, thinned and pruned. Tips beyond the wrist are finger candidates; the
thumb is the one that branches off closest to the wrist, the other four are ordered index → pinky by how far
forward they are (palms down or in, the index is the front finger). Joints 1, 2, 3 sit along each finger's
branch (knuckle, then fractions of the knuckle → tip length measured on Mixamo hands). Five tips, or four (a
cartoon hand: a thumb and three fingers, named `mixamo.FOUR_FINGERS`), must stand out from any further tip (a
long one beyond them means surface noise or a mitten's folds); both hands must show the same count. A separate
part in one hand's crop whose mirror image finds nothing of the other hand is a held prop (a gun, a wand), and
is left out of that hand's reading: its medial branches would pass for fingers. When fingers
touch so closely that they share voxels, `finger_template` checks the mesh's cross-sections for separate finger
shells and lays the joints out from the Mixamo hand template instead (report: "fallback", "template").
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy.spatial import cKDTree

from simcore.geometry.parts import surface_parts
from simcore.geometry.referenced import referenced_mesh
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
ONE_SIDED = 0.5  # × the forearm: a crop part whose mirror image lies farther (median) from the other hand is a prop

Crop = tuple[np.ndarray, np.ndarray]  # a hand crop's vertices (V', 3) and faces (F', 3)


def _hand_crop(vertices: np.ndarray, faces: np.ndarray, wrist: np.ndarray, elbow: np.ndarray) -> Crop | None:
    """The triangles inside a sphere over the hand, re-indexed: ((V', 3), (F', 3)), or None when too few."""
    forearm = float(np.linalg.norm(wrist - elbow))
    d = (wrist - elbow) / max(forearm, 1e-12)
    centre, radius = wrist + 0.35 * forearm * d, 0.75 * forearm
    near = np.linalg.norm(vertices - centre, axis=1) < radius
    keep = near[faces].all(axis=1)
    if keep.sum() < 20:
        return None
    crop = referenced_mesh(vertices, faces[keep])
    return crop.vertices, crop.faces


def _without_held_props(crop: Crop, other: Crop, wrist: np.ndarray, centre: np.ndarray, normal: np.ndarray,
                        tolerance: float) -> tuple[Crop, int]:
    """`crop` without its separate parts whose mirror images (across the plane through `centre` with unit
    `normal`) lie farther than `tolerance` (median) from the `other` hand's crop, and the number of triangles
    left out. The part nearest the wrist is the hand and always stays."""
    v, f = crop
    parts = surface_parts(v, f)
    if len(parts) < 2:
        return crop, 0
    other_tree = cKDTree(other[0])
    hand = min(range(len(parts)), key=lambda k: (float(np.linalg.norm(parts[k].points - wrist, axis=1).min()), k))
    keep = np.ones(len(f), bool)
    for k, part in enumerate(parts):
        if k != hand and float(np.median(other_tree.query(_reflect(part.points, centre, normal))[0])) > tolerance:
            keep[part.faces] = False
    if keep.all():
        return crop, 0
    rest = referenced_mesh(v, f[keep])
    return (rest.vertices, rest.faces), int((~keep).sum())


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


def _fit_hand(crop: Crop, wrist: np.ndarray, elbow: np.ndarray, forward: np.ndarray, side: str,
              kinds: tuple[tuple[str, ...], ...]) -> tuple[_Hand | None, dict[str, Any]]:
    """One hand's fingers from the medial tree of its `crop`, else from the template, with the report."""
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

    Held props are left out of each hand's crop first (`_props_left_out`); a hand that then shows no fingers
    while the other does takes the other's, mirrored. When one hand reads as five-fingered and the other as four,
    the five-fingered one is read again as four-fingered: a fold adds a loop or a tip more often than touching
    fingers hide one.
    body: bare Mixamo body joint name → (3,) position (needs LeftHand/LeftForeArm, the Right pair, and Hips on the
    body's midplane).
    """
    v, f = np.asarray(vertices, np.float64), np.asarray(faces, np.int64)
    report: dict[str, Any] = {}
    found: dict[str, Crop] = {}
    for side in ("Left", "Right"):
        crop = _hand_crop(v, f, body[f"{side}Hand"], body[f"{side}ForeArm"])
        if crop is None:
            report.update(separable=False, **{side.lower(): {"reason": "too few triangles around the hand"}})
            return None, report
        found[side] = crop
    crops = _props_left_out(found, body, left, report)
    hands: dict[str, _Hand] = {}
    for side in ("Left", "Right"):
        hand, info = _fit_hand(crops[side], body[f"{side}Hand"], body[f"{side}ForeArm"], forward, side, HAND_KINDS)
        report[side.lower()] = {**report.get(side.lower(), {}), **info}
        if hand is not None:
            hands[side] = hand
    for side, other in (("Left", "Right"), ("Right", "Left")):
        if side not in hands and other in hands and "prop_triangles" in report[side.lower()]:
            hands[side] = _mirrored(hands[other], body, left)  # a prop's grip hides this hand's fingers
            report[side.lower()]["mirrored_from"] = other.lower()
    if len(hands) < 2:
        report["separable"] = False
        return None, report
    more, fewer = sorted(hands, key=lambda s: (-len(hands[s].kind), s))
    if hands[more].kind != hands[fewer].kind:
        again, info = _fit_hand(crops[more], body[f"{more}Hand"], body[f"{more}ForeArm"], forward, more,
                                (hands[fewer].kind,))
        report[more.lower()] = {**report[more.lower()], "read_again": info}
        if again is None:
            report.update(separable=False, reason="the hands show different finger counts")
            return None, report
        hands[more] = again
    report["separable"] = True
    report["template"] = any(hand.template for hand in hands.values())
    return {f"{side}Hand{k}": p for side, hand in hands.items() for k, p in hand.joints.items()}, report


def _midplane(body: dict[str, np.ndarray], left: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The body's midplane: a point on it (the hips) and its unit normal (`left`)."""
    return body["Hips"], left / max(float(np.linalg.norm(left)), 1e-12)


def _reflect(points: np.ndarray, centre: np.ndarray, normal: np.ndarray) -> np.ndarray:
    """(N, 3) mirror images of `points` across the plane through `centre` with unit `normal`."""
    points = np.atleast_2d(points)
    return points - 2.0 * np.outer((points - centre) @ normal, normal)


def _mirrored(hand: _Hand, body: dict[str, np.ndarray], left: np.ndarray) -> _Hand:
    """`hand`'s joints mirrored across the body's midplane."""
    names = list(hand.joints)
    mirrored = _reflect(np.array([hand.joints[n] for n in names]), *_midplane(body, left))
    return _Hand(dict(zip(names, mirrored)), hand.kind, hand.template)


def _props_left_out(crops: dict[str, Crop], body: dict[str, np.ndarray], left: np.ndarray,
                    report: dict[str, Any]) -> dict[str, Crop]:
    """Both hands' crops without held props (`_without_held_props`, mirrored across the body's midplane); the
    triangles left out go to the report as `prop_triangles`."""
    centre, normal = _midplane(body, left)
    out = {}
    for side, other in (("Left", "Right"), ("Right", "Left")):
        forearm = float(np.linalg.norm(body[f"{side}Hand"] - body[f"{side}ForeArm"]))
        out[side], dropped = _without_held_props(crops[side], crops[other], body[f"{side}Hand"], centre, normal,
                                                 ONE_SIDED * forearm)
        if dropped:
            report[side.lower()] = {"prop_triangles": dropped}
    return out

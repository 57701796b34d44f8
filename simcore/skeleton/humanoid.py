"""Mixamo humanoid fit: detect an upright biped on the medial tree and place the 22 body joints (+30 fingers, or
24 on four-fingered hands).

Detection works on the largest body's pruned medial tree (see `geometric`), for each candidate up axis:
head = highest tree tip; feet = the two low tips whose tree paths split highest (the crotch); arms = the two
tips hanging off the head-to-crotch spine above the crotch, on opposite sides. Each check gives a soft score;
their product is the confidence. Facing comes from the toes (feet point forward), and the character's left
is up × forward (Mixamo: facing +Z with +Y up puts the left hand at +X).

Joint placement follows the medial paths, with proportions measured on Mixamo characters (fractions along
the spine between Hips and Neck, along the lower arm to the fingertip, knee halfway between hip and ankle, ankle
at the foot's corner); the upper-arm joint goes where the arm's medial radius falls to the arm's own (it leaves
the torso). A placed body whose bones stray from the medial tree lowers the confidence. Long medial branches
the template leaves out (wings, tails) become SPRING chains (`extra_limbs`). Joints that land outside the solid
are moved to the nearest inside voxel.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np
from scipy.spatial import cKDTree

from simcore.errors import InvalidInput
from simcore.geometry.voxelize import VoxelGrid, solid_voxels
from simcore.skeleton.axes import AXES, GLTF_UP, axis
from simcore.skeleton.extra_limbs import extra_limbs
from simcore.skeleton.geometric import rank_bodies
from simcore.skeleton.graph_simplify import limb_exit, path_length, point_at_fraction, prune_spurs, rooted_parents
from simcore.skeleton.hands import fit_fingers
from simcore.skeleton.inside import snap_inside
from simcore.skeleton.medial import medial_forest
from simcore.skeleton.mixamo import BODY_JOINTS, BODY_PARENTS, HAND_JOINTS, HAND_PARENTS, full_name
from simcore.skeleton.section_centre import centre_in_section
from simcore.skeleton.spine_chain import SPINE, kept_spine
from simcore.skeleton.symmetry import body_mirror, mirror_report, mirror_twins, symmetrize
from simcore.skeleton.types import SHORT_BONE, JointKind, Skeleton

UP_ORDER = ("y", "z", "-y", "-z", "x", "-x")  # glTF's +Y first: it wins ties
CONFIDENT = 0.5
# A reading with another up than glTF's +Y, when none was given, needs more: a quadruped read tail-up can pass
# as a weak biped (its hind legs taken for arms), while a real biped in a Z-up bind pose reads clearly.
SIDEWAYS_CONFIDENT = 0.8
RESOLUTION = 112
SPINE_FRACTIONS = {"Spine": 0.21, "Spine1": 0.435, "Spine2": 0.67}  # of Hips → Neck, Mixamo characters
# Elbow and wrist: fractions of the arm's medial path from LOWER_ARM_FROM chest radii out from the spine to the
# fingertip (Mixamo characters).
ARM_FRACTIONS = {"ForeArm": 0.35, "Hand": 0.71}
LOWER_ARM_FROM = 2.0
# The upper-arm joint sits where the arm leaves the torso: the first point along the arm's medial path whose ball
# radius is down to ARM_EXIT × the arm's own radius (the median over the middle half of the path).
ARM_EXIT = 1.5
HIPS_ABOVE_CROTCH = 0.01  # × height: Hips sits just above where the leg branches meet
# An ankle found higher than this × height is the knee's bend (a leg standing straight, in a coat, has no corner
# at the foot): the ankle goes to this height instead. Anatomical ankles sit well below this, so the cap only
# acts when the foot corner is hidden (a long coat or robe) and the found corner is really the knee.
ANKLE_HIGHEST = 0.12
# The leg's medial line turns into the foot half a foot's thickness above the floor; the ankle bone is higher.
# The Foot joint is raised this × height above that corner, towards the ankle's pivot inside the foot; the knee
# and toe keep the corner.
ANKLE_ABOVE_CORNER = 0.015
FUSED_CROTCH = 0.4  # a leg split below this share of the height means the thighs are fused in the voxels
NECK_AT, HEAD_AT = 0.17, 0.35  # of shoulder line → head top (Mixamo characters' proportions)
TYPICAL_HIPS = 0.55  # then Hips goes at this share of the height (about where a standing figure's pelvis is)
# Mean distance of the placed body bones from the medial tree, × the mesh's longest side: up to RESIDUAL_OK the
# template lies along the body (a well-fitting humanoid stays well inside it); RESIDUAL_SLACK further on, the
# check reaches 0.
RESIDUAL_OK, RESIDUAL_SLACK = 0.015, 0.01
_BODY_PARENT_INDEX = [BODY_JOINTS.index(BODY_PARENTS[n]) if BODY_PARENTS[n] else -1 for n in BODY_JOINTS]


@dataclass
class HumanoidFit:
    """skeleton: the fitted Mixamo skeleton, or None when no biped was found (report says why)."""

    skeleton: Skeleton | None
    report: dict[str, Any] = field(default_factory=dict)

    @property
    def biped_layout(self) -> bool:
        """A head, two feet and two arms were found (the detection checks ran), whether or not the fit passed."""
        return "checks" in self.report


@dataclass
class _Tree:
    pos: np.ndarray  # (N, 3) medial node positions
    radius: np.ndarray  # (N,)
    adjacency: list[list[int]]
    nodes: np.ndarray  # ids of the main body's tree


@dataclass
class _Biped:
    up: np.ndarray
    confidence: float
    checks: dict[str, float]
    floor: float
    height: float
    parent: dict[int, int]  # tree rooted at the head tip
    head: int
    feet: tuple[int, int]
    pelvis: int
    hands: tuple[int, int]
    attach: tuple[int, int]


def _up_path(parent: dict[int, int], n: int, stop: int = -1) -> list[int]:
    """Nodes from n towards the root, through `stop` when met."""
    out = [n]
    while parent[out[-1]] >= 0 and out[-1] != stop:
        out.append(parent[out[-1]])
    return out


def _soft(value: float, lo: float, hi: float, slack: float) -> float:
    """1 inside [lo, hi], falling linearly to 0 at `slack` outside."""
    if value < lo:
        return max(0.0, 1.0 - (lo - value) / slack)
    if value > hi:
        return max(0.0, 1.0 - (value - hi) / slack)
    return 1.0


def _detect(tree: _Tree, up: np.ndarray, vertices: np.ndarray) -> _Biped | None:
    heights = vertices @ up
    floor, height = float(heights.min()), float(np.ptp(heights))
    if height <= 0:  # a flat mesh has no extent along this axis
        return None
    rel = (tree.pos @ up - floor) / height
    leaves = [int(n) for n in tree.nodes if len(tree.adjacency[n]) == 1]
    if len(leaves) < 4:
        return None
    # The highest medial node ends the spine even when a short head was pruned as a spur.
    head = int(max(tree.nodes, key=lambda n: (rel[n], -n)))
    parent = rooted_parents(tree.adjacency, head)
    leaves = sorted(set(leaves) | {head})
    depth_path = {n: _up_path(parent, n) for n in leaves}
    low = [n for n in leaves if rel[n] < 0.2 and n != head]
    best = None
    for i, a in enumerate(low):
        sa = set(depth_path[a])
        for b in low[i + 1:]:
            lca = next(m for m in depth_path[b] if m in sa)
            if best is None or rel[lca] > rel[best[2]]:
                best = (a, b, lca)
    if best is None:
        return None
    foot_a, foot_b, pelvis = best
    spine = _up_path(parent, pelvis)
    spine_set = set(spine)
    legs = set(depth_path[foot_a]) | set(depth_path[foot_b])
    arms = []
    extra_low = 0
    for n in leaves:
        if n in (head, foot_a, foot_b):
            continue
        path = _up_path(parent, n)
        attach = next(m for m in path if m in spine_set or m in legs)
        if attach not in spine_set or attach == pelvis:
            continue  # hangs off a leg: a heel or toe spur
        if rel[n] < 0.15:
            extra_low += 1
        length = path_length(tree.pos, path[: path.index(attach) + 1])
        if rel[attach] > rel[pelvis] and length > 0.12 * height:
            arms.append((n, attach, length))
    pair = None
    for i, (a, pa, la) in enumerate(arms):
        for b, pb, lb in arms[i + 1:]:
            side = tree.pos[a] - tree.pos[b]
            span = float(np.linalg.norm(side - (side @ up) * up))
            if pair is None or span > pair[0]:
                pair = (span, (a, b), (pa, pb), (la, lb))
    if pair is None:
        return None
    span, hands, shoulders, arm_len = pair
    leg_len = (path_length(tree.pos, depth_path[foot_a][: depth_path[foot_a].index(pelvis) + 1]),
               path_length(tree.pos, depth_path[foot_b][: depth_path[foot_b].index(pelvis) + 1]))
    checks = {
        "head_on_top": _soft(rel[head] + float(tree.radius[head]) / height, 0.9, 1.01, 0.1),  # the ball reaches up
        "crotch_height": _soft(rel[pelvis], 0.25, 0.62, 0.1),
        "arms_above_crotch": _soft(min(rel[shoulders[0]], rel[shoulders[1]]) - rel[pelvis], 0.15, 1.0, 0.1),
        "arm_symmetry": _soft(min(arm_len) / max(arm_len), 0.7, 1.0, 0.2),
        "leg_symmetry": _soft(min(leg_len) / max(leg_len), 0.75, 1.0, 0.2),
        "hand_span": _soft(span / height, 0.3, 2.0, 0.15),
        "hands_off_floor": _soft(min(rel[hands[0]], rel[hands[1]]), 0.3, 1.0, 0.15),
        "two_feet_only": 1.0 if extra_low == 0 else 0.3,
    }
    confidence = float(np.prod(list(checks.values())))
    return _Biped(up, confidence, checks, floor, height, parent, head, (foot_a, foot_b), pelvis, hands, shoulders)


def _polyline(tree: _Tree, path: list[int]) -> np.ndarray:
    return tree.pos[path]


def _to_tip(tree: _Tree, path: list[int]) -> np.ndarray:
    """Polyline of `path` (ending at a tip node) extended by the tip's radius: thinning stops that far short."""
    pts = tree.pos[path]
    back = pts[max(len(pts) - 4, 0)]
    d = pts[-1] - back
    norm = float(np.linalg.norm(d))
    if norm < 1e-12:
        return pts
    return np.vstack([pts, pts[-1] + d / norm * float(tree.radius[path[-1]])])


def _at_height(points: np.ndarray, up: np.ndarray, target: float) -> np.ndarray:
    """First point along the polyline whose height reaches `target` (clamped to the nearer end)."""
    h = points @ up
    for i in range(len(points) - 1):
        lo, hi = sorted((h[i], h[i + 1]))
        if lo <= target <= hi and hi > lo:
            w = (target - h[i]) / (h[i + 1] - h[i])
            return points[i] + w * (points[i + 1] - points[i])
    return points[int(np.argmin(np.abs(h - target)))].copy()


def _corner(points: np.ndarray) -> int:
    """Index of the polyline point farthest from the chord between its ends (the ankle on knee → toe)."""
    a, b = points[0], points[-1]
    d = b - a
    rel = points - a
    t = np.clip(rel @ d / max(float(d @ d), 1e-12), 0, 1)
    return int(np.argmax(np.linalg.norm(rel - t[:, None] * d, axis=1)))


def _facing(tree: _Tree, biped: _Biped, leg_paths: list[list[int]], lateral: np.ndarray,
            forward: np.ndarray | None) -> tuple[np.ndarray, float]:
    """Forward unit vector ⊥ up and how sure we are (0..1): the toes point forward."""
    up = biped.up
    side_normal = np.cross(up, lateral)
    length = float(np.linalg.norm(side_normal))
    if length < 1e-9:  # one hand straight above the other: no left and right to read
        raise _NotBiped("the hands lie along the up axis")
    side_normal /= length
    if forward is not None:
        f = forward - (forward @ up) * up
        if np.linalg.norm(f) < 1e-6:
            raise InvalidInput("forward_axis is parallel to the up axis", code="invalid_option", field="options.forward_axis")
        return f / np.linalg.norm(f), 1.0
    votes = []
    for path in leg_paths:
        pts = _polyline(tree, path)
        ankle = pts[_corner(pts)]  # path runs toe tip → crotch; its corner is the ankle
        votes.append(float((pts[0] - ankle) @ side_normal))
    total = sum(votes)
    reach = sum(abs(x) for x in votes) or 1.0
    return (side_normal if total >= 0 else -side_normal), abs(total) / reach


def _arm_share(length: float, total: float) -> float:
    """`length` along an arm path `total` long, as a share kept between the first 5 % and 40 % of the arm."""
    return float(np.clip(length / max(total, 1e-9), 0.05, 0.4))


def _short_spine(skeleton: Skeleton, size: float, report: dict[str, Any]) -> Skeleton:
    """The skeleton with only the spine joints its torso carries (`spine_chain`); report["spine_joints"] says how
    many when fewer than three."""
    index = {n: k for k, n in enumerate(skeleton.names)}
    chain = skeleton.positions[[index[full_name(n)] for n in ("Hips", *SPINE, "Neck")]]
    kept = kept_spine(chain, SHORT_BONE * size)
    if len(kept) == len(SPINE):
        return skeleton
    report["spine_joints"] = len(kept)
    drop = np.zeros(skeleton.num_joints, dtype=bool)
    drop[[index[full_name(SPINE[i])] for i in range(len(SPINE)) if i not in kept]] = True
    rename = {full_name(SPINE[i]): full_name(SPINE[rank]) for rank, i in enumerate(kept)}
    shorter, _ = skeleton.without(drop)
    return replace(shorter, names=[rename.get(n, n) for n in shorter.names])


def _place_body(tree: _Tree, biped: _Biped, left: np.ndarray, forward: np.ndarray) -> dict[str, np.ndarray]:
    up, floor, height = biped.up, biped.floor, biped.height
    j: dict[str, np.ndarray] = {}
    spine = _polyline(tree, _up_path(biped.parent, biped.pelvis)[::-1])[::-1]  # pelvis → head tip
    pelvis_h = float(tree.pos[biped.pelvis] @ up)
    sides = {}
    for hand, attach in zip(biped.hands, biped.attach):
        side = "Left" if (tree.pos[hand] - tree.pos[attach]) @ left > 0 else "Right"
        sides[side] = (hand, attach)
    if len(sides) != 2:
        raise _NotBiped("both hands are on one side")
    arm_h = []
    for side, (hand, attach) in sides.items():
        path = _up_path(biped.parent, hand, stop=attach)[::-1]  # attach → fingertip
        pts = _to_tip(tree, path)
        arc = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(pts, axis=0), axis=1))])
        lower_from = _arm_share(max(LOWER_ARM_FROM * float(tree.radius[attach]), 0.05 * height), arc[-1])
        rest = pts[np.searchsorted(arc, lower_from * arc[-1]):]
        rest = np.vstack([point_at_fraction(pts, lower_from), rest if len(rest) else pts[-1:]])
        for name, frac in ARM_FRACTIONS.items():
            j[f"{side}{name}"] = point_at_fraction(rest, frac)
        arm = point_at_fraction(pts, _arm_share(arc[limb_exit(tree.radius[path], ARM_EXIT)], arc[-1]))
        j[f"{side}Arm"] = arm
        j[f"{side}Shoulder"] = pts[0] + 0.35 * (arm - pts[0]) + 0.01 * height * up
        arm_h.append(float(arm @ up))
    shoulder_h = float(np.mean(arm_h))
    top = floor + height
    hips_h = pelvis_h + HIPS_ABOVE_CROTCH * height
    if pelvis_h - floor < FUSED_CROTCH * height:  # thighs touch in the solid: the medial split is near the knees
        hips_h = floor + TYPICAL_HIPS * height
    j["Hips"] = _at_height(spine, up, hips_h)
    j["Neck"] = _at_height(spine, up, shoulder_h + NECK_AT * (top - shoulder_h))
    j["Head"] = _at_height(spine, up, shoulder_h + HEAD_AT * (top - shoulder_h))
    hips_up, neck_up = float(j["Hips"] @ up), float(j["Neck"] @ up)
    for name, frac in SPINE_FRACTIONS.items():
        j[name] = _at_height(spine, up, hips_up + frac * (neck_up - hips_up))
    for foot in biped.feet:
        path = _up_path(biped.parent, foot, stop=biped.pelvis)[::-1]  # pelvis → toe tip
        pts = _to_tip(tree, path)
        side = "Left" if (pts[-1] - spine[0]) @ left > 0 else "Right"
        up_leg_h = hips_up - 0.035 * height
        below = _at_height(pts, up, pelvis_h - 0.05 * height)
        up_leg = below + (up_leg_h - float(below @ up)) * up
        j[f"{side}UpLeg"] = up_leg
        lower = pts[int(np.argmin(np.abs(pts @ up - (pelvis_h - 0.05 * height)))):]
        ankle_i = _corner(lower)
        straight = float(lower[ankle_i] @ up) > floor + ANKLE_HIGHEST * height
        if straight:
            ankle_i = int(np.argmax(lower @ up <= floor + ANKLE_HIGHEST * height))
        ankle = lower[ankle_i]
        knee_h = 0.5 * (up_leg_h + float(ankle @ up))
        if float(lower[0] @ up) >= knee_h:
            j[f"{side}Leg"] = _at_height(lower[: ankle_i + 1], up, knee_h)
        else:  # the leg's own medial line starts below the knee (fused thighs): straight thigh-shin line
            j[f"{side}Leg"] = 0.5 * (up_leg + ankle)
        j[f"{side}ToeBase"] = point_at_fraction(lower[ankle_i:], 0.6)
        j[f"{side}Foot"] = ankle if straight else ankle + ANKLE_ABOVE_CORNER * height * up
    missing = [n for n in BODY_JOINTS if n not in j]
    if missing:
        raise _NotBiped(f"could not place {missing}")
    return j


class _NotBiped(Exception):
    """Internal: the tree looked like a biped but a limb could not be laid out."""


def _main_tree(vertices: np.ndarray, faces: np.ndarray) -> tuple[VoxelGrid, _Tree]:
    grid = solid_voxels(vertices, faces, resolution=RESOLUTION)
    forest = medial_forest(grid)
    ranked, _, _ = rank_bodies(grid, forest)
    scale = float(np.ptp(vertices, axis=0).max())
    removed = prune_spurs(forest.adjacency, forest.positions, forest.radius, 1.2, 0.02 * scale)
    alive = np.ones(len(forest.positions), bool)
    alive[removed] = False
    nodes = np.flatnonzero((forest.component == ranked[0]) & alive)
    return grid, _Tree(forest.positions, forest.radius, forest.adjacency, nodes)


def fit_residual(medial: np.ndarray, positions: np.ndarray, parents: np.ndarray, samples: int = 9) -> float:
    """Mean distance (metres) from points along the bones of `positions` (J, 3) / `parents` (J,) to the nearest
    of the medial nodes `medial` (N, 3): how far a placed template strays from the body's medial axis."""
    child = np.flatnonzero(parents >= 0)
    t = np.linspace(0.0, 1.0, samples)[None, :, None]
    heads, tails = positions[parents[child]][:, None], positions[child][:, None]
    points = (heads + t * (tails - heads)).reshape(-1, 3)
    return float(cKDTree(medial).query(points)[0].mean())


def _facing_label(forward: np.ndarray) -> str:
    name = max(AXES, key=lambda k: float(AXES[k] @ forward))
    return name if name.startswith("-") else "+" + name


def _placed(tree: _Tree, biped: _Biped, forward_given: np.ndarray | None, scale: float
            ) -> tuple[_Biped, dict[str, np.ndarray], np.ndarray, float, float]:
    """Place the Mixamo body for one detected up axis and fold how far it strays from the medial tree into the
    biped's confidence (`on_medial_axis`). Returns (biped, joints by name, forward, facing confidence, residual
    as a share of `scale`); raises _NotBiped when the layout cannot be placed."""
    lateral = tree.pos[biped.hands[0]] - tree.pos[biped.hands[1]]
    lateral -= (lateral @ biped.up) * biped.up
    lateral /= max(np.linalg.norm(lateral), 1e-12)
    leg_paths = [_up_path(biped.parent, f, stop=biped.pelvis) for f in biped.feet]
    forward, facing_conf = _facing(tree, biped, leg_paths, lateral, forward_given)
    joints = _place_body(tree, biped, np.cross(biped.up, forward), forward)
    positions = np.asarray([joints[n] for n in BODY_JOINTS])
    residual = fit_residual(tree.pos[tree.nodes], positions, np.asarray(_BODY_PARENT_INDEX)) / scale
    checks = {**biped.checks, "on_medial_axis": _soft(residual, 0.0, RESIDUAL_OK, RESIDUAL_SLACK)}
    scored = replace(biped, checks=checks, confidence=float(np.prod(list(checks.values()))))
    return scored, joints, forward, facing_conf, residual


def fit_humanoid(vertices: np.ndarray, faces: np.ndarray, *, max_joints: int = 64, up_axis: str | None = None,
                 forward_axis: str | None = None, force: bool = False) -> HumanoidFit:
    """Fit the Mixamo skeleton when the mesh is an upright biped.

    vertices: (V, 3) float64, faces: (F, 3) int64, any frame (up detected unless `up_axis` is given).
    force: accept a biped below the confidence threshold (options.skeleton = "humanoid"); a mesh with no biped
    layout at all still returns skeleton None. The confidence multiplies the detection checks with one on the
    placed body (`on_medial_axis`: its bones must run along the medial tree, see `fit_residual`), so a biped
    layout whose template lands off the body (odd proportions) falls back to the geometric skeleton.
    Report: detected, confidence, checks, residual, up, facing, fingers.
    """
    up_given, forward_given = axis(up_axis, "up_axis"), axis(forward_axis, "forward_axis")
    report: dict[str, Any] = {"detected": False}
    if max_joints < len(BODY_JOINTS):
        report["reason"] = f"max_joints {max_joints} is below the {len(BODY_JOINTS)} Mixamo body joints"
        return HumanoidFit(None, report)
    v = np.asarray(vertices, dtype=np.float64)
    grid, tree = _main_tree(v, faces)
    candidates = [up_given] if up_given is not None else [AXES[a] for a in UP_ORDER]
    found = [b for b in (_detect(tree, up, v) for up in candidates) if b is not None]
    if not found:
        report.update(confidence=0.0, reason="no head, two feet and two arms on the medial tree")
        return HumanoidFit(None, report)
    scale = float(np.ptp(v, axis=0).max())
    placed, failures = [], []
    for b in found:  # each axis's reading is placed and judged by how well its template lies on the body
        try:
            placed.append(_placed(tree, b, forward_given, scale))
        except _NotBiped as exc:
            failures.append(str(exc))
    if not placed:
        best = max(found, key=lambda b: b.confidence)
        report.update(confidence=round(best.confidence, 3), checks={k: round(x, 3) for k, x in best.checks.items()},
                      up=_facing_label(best.up), reason=failures[0])
        return HumanoidFit(None, report)
    # An upside-down reading can pass detection and then strays from the body: the best placed one wins
    # (max keeps the first, glTF +Y, on ties).
    biped, joints, forward, facing_conf, residual = max(placed, key=lambda p: p[0].confidence)
    left = np.cross(biped.up, forward)
    report.update(confidence=round(biped.confidence, 3), checks={k: round(x, 3) for k, x in biped.checks.items()},
                  up=_facing_label(biped.up), residual=round(residual, 4))
    sideways = up_given is None and not np.array_equal(biped.up, GLTF_UP)
    if biped.confidence < (SIDEWAYS_CONFIDENT if sideways else CONFIDENT) and not force:
        if biped.confidence >= CONFIDENT:  # only SIDEWAYS_CONFIDENT refused it
            report["reason"] = f"a biped only when read {_facing_label(biped.up)} up, and not confidently"
        elif biped.checks["on_medial_axis"] < 1.0:
            report["reason"] = "the fitted template strays from the medial axis"
        else:
            report["reason"] = "biped detection below the confidence threshold"
        return HumanoidFit(None, report)
    names = list(BODY_JOINTS)
    positions = [joints[n] for n in names]
    kinds = [JointKind.BODY] * len(names)
    parents = list(_BODY_PARENT_INDEX)
    fingers: dict[str, np.ndarray] | None = None
    if max_joints >= len(BODY_JOINTS) + len(HAND_JOINTS):
        fingers, finger_report = fit_fingers(v, faces, joints, biped.up, forward, left)
        report["fingers"] = finger_report
    if fingers is not None:
        for n in (n for n in HAND_JOINTS if n in fingers):  # a four-fingered hand has no Ring slots
            names.append(n)
            positions.append(fingers[n])
            kinds.append(JointKind.HAND)
            parents.append(names.index(HAND_PARENTS[n]))
    names = [full_name(n) for n in names]
    extras = extra_limbs(tree.pos, tree.radius, tree.adjacency, tree.nodes, biped.parent,
                         [biped.head, *biped.feet, *biped.hands], np.asarray(positions), biped.height, scale)
    added = 0
    for k, chain in enumerate(extras, start=1):
        if len(positions) + len(chain.positions) > max_joints:
            break
        first = len(positions)
        for i, p in enumerate(chain.positions):
            names.append(f"extra{k:02d}_{i + 1:02d}")
            positions.append(p)
            kinds.append(JointKind.SPRING)
            parents.append(chain.parent if i == 0 else first + i - 1)
        added += 1
    report["extra_limbs"] = added
    pos = centre_in_section(np.asarray(positions), np.asarray(parents), grid)
    plane = body_mirror(v)
    twins = None if plane is None else mirror_twins(pos, np.asarray(parents), grid, plane, names)
    report["mirror"] = mirror_report(twins)
    pos = snap_inside(grid, pos if twins is None else symmetrize(pos, twins))
    skeleton = _short_spine(Skeleton(pos, np.asarray(parents), names, kinds).validate(), scale, report)
    report.update(detected=True, facing=_facing_label(forward), facing_vector=np.round(forward, 4).tolist(),
                  facing_confidence=round(facing_conf, 3), joints=skeleton.num_joints)
    return HumanoidFit(skeleton, report)

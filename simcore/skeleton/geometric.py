"""Geometric skeleton for any mesh: solid voxels → medial forest → joint graph → rooted tree.

Works on real game meshes (holes, several components, self-intersections) because everything downstream of
`solid_voxels` sees only a closed voxel solid. Joints are medial voxel centres (inside the solid). Several
disconnected bodies each get their own tree and are then hung under the largest body's tree at their
closest joint pair, so the result is one Skeleton; the report says how many bodies were joined.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp
from scipy import ndimage
from scipy.sparse.csgraph import dijkstra

from simcore.geometry.parts import SurfacePart, flat_normal, principal_frame, surface_parts
from simcore.geometry.voxelize import VoxelGrid, solid_voxels
from simcore.skeleton.axes import GLTF_UP
from simcore.skeleton.edge_loops import edge_loops
from simcore.skeleton.graph_simplify import (branch_joints, branches, limb_exit, merge_junctions, path_length,
                                             prune_spurs)
from simcore.skeleton.hub_split import HubSplit, split_hubs
from simcore.skeleton.inside import snap_inside
from simcore.skeleton.medial import MedialForest, medial_forest
from simcore.skeleton.mirror import MirrorPlane, mirror_plane
from simcore.skeleton.section_centre import SECTION_LIMIT, centre_in_section
from simcore.skeleton.symmetry import (MirrorTwins, body_mirror, complete_twins, lopsided_branches, mirror_report,
                                      mirror_twins, symmetrize)
from simcore.skeleton.types import JointKind, Skeleton


STUB_VOXELS = 0.5  # a bone shorter than this many voxels is no bone: its child joint goes
RADIUS_SMOOTH = 5  # medial voxels averaged when a limb's thickness profile is read
SHEET_PART_AREA = 0.01  # parts with less of the area (a button on a flag) do not decide whether it is a sheet


@dataclass(frozen=True)
class GeometricParams:
    """Tuning of the geometric method; lengths are fractions of the mesh's longest bounding-box side."""

    resolution: int = 96  # voxels along the longest side
    spur_ratio: float = 2.0  # a leaf branch shorter than this × the junction radius is a surface bump
    spur_min: float = 0.02
    twin_slender: float = 4.0  # mirror-twin spurs longer than this × their radius are both kept (fins), else both go
    merge_ratio: float = 1.5  # junctions closer than this × their radius are one junction
    turn_ratio: float = 0.6  # Douglas-Peucker tolerance, × the branch's median radius
    turn_min: float = 0.015
    spacing: float = 0.12  # longest stretch of a branch without a joint
    min_part: float = 0.002  # bodies with less than this share of the solid's voxels get no joints
    tip_pull: float = 0.7  # leaf joints move this share towards their parent: rigs end where the end part starts
    close_radius: int = 1  # voxel closing of the surface shell before filling
    close_retry: int = 2  # a stronger closing tried on every mesh...
    close_drop: float = 0.25  # ...and kept when it shortens the medial axis by more than this share
    close_inside: float = 0.97  # ...with at least this share of it inside the lightly closed solid (no bridging)
    sheet_ratio: float = 0.02  # thinner than this × the length: a flat sheet, rigged as a principal-axis chain
    tube_ratio: float = 2.0  # a junction-free body (tube) gets no segment shorter than this × its diameter
    root_push: float = 0.5  # a chain's root moves this share of its medial radius outwards, towards the end
    limb_exit: float = 1.5  # a limb gets a joint where its medial radius is down to this × its own (its hip)...
    limb_gap: float = 0.3  # ...unless a joint is within this × spacing of it already
    leg_segments: int = 4  # a leg standing on the floor gets a joint at least every this share of its length...
    leg_upright: float = 0.75  # ...when it runs at least this steeply along the up axis (|cos|)...
    floor_gap: float = 0.05  # ...and its tip reaches down to within this of the mesh's lowest point
    leg_tip_pull: float = 0.3  # a leg's foot joint moves only this share towards its parent (0 / 0.3 / 0.5 alike)
    section_limit: float = SECTION_LIMIT  # voxels a chain joint may move towards its limb's cross-section centre
    loop_gap: float = 0.5  # a junction-free body whose vertices lie on rings this × its thickness apart: low-poly tube
    head_widen: float = 1.3  # a mid-plane limb widening again to this × its thinnest is a head on a neck...
    neck_tol: float = 1.1  # ...pivoting where the neck is within this × its thinnest, nearest the head


@dataclass(frozen=True)
class _Ground:
    """What tells a leg: the up axis (unit), the mesh's lowest point along it, its mirror plane (None: none)."""

    up: np.ndarray
    floor: float
    plane: MirrorPlane | None


@dataclass
class _JointGraph:
    positions: list[np.ndarray]
    edges: list[tuple[int, int]]
    body: list[int]
    leg_tips: set[int] = field(default_factory=set)


def _body_joints(forest: MedialForest, nodes: np.ndarray, params: GeometricParams, scale: float, spacing: float,
                 ground: _Ground, graph: _JointGraph, body: int) -> int:
    """Add one body's joints and edges to `graph`; returns how many joints it added."""
    adjacency, pos, rad = forest.adjacency, forest.positions, forest.radius
    keys, brs = branches(adjacency, nodes)
    rep, merged, brs = merge_junctions(keys, brs, adjacency, pos, rad, params.merge_ratio)
    split = HubSplit(rep, merged, brs, [])
    if len(brs) >= 4:  # a hub has at least four branches
        split = split_hubs(rep, merged, brs, pos, rad, mirror_plane(pos[nodes]), len(pos))
    rep, merged, brs = split.rep, split.merged, split.branches
    if len(brs) == 1:  # a tube (no junction): like a sheet, it bends only where segments are longer than it is thick
        spacing = max(spacing, params.tube_ratio * 2.0 * float(np.max(rad[brs[0].nodes])))
    base = len(graph.positions)
    slot: dict[int, int] = {}
    used = {rep[k] for b in brs for k in (b.start, b.end)} | {k for link in split.links for k in link}
    for r in sorted(set(rep.values())):
        if brs and r not in used:  # a hub that was split into junctions along the spine
            continue
        slot[r] = len(graph.positions)
        graph.positions.append(merged[r])
        graph.body.append(body)
    for b in brs:
        leg = _leg_tip(b.nodes, adjacency, pos, rad, ground, params, scale, spacing) if len(brs) > 1 else None
        step = spacing if leg is None else min(spacing, path_length(pos, b.nodes) / params.leg_segments)
        interior = branch_joints(pos[b.nodes], rad[b.nodes], params.turn_ratio, params.turn_min * scale, step)
        if len(brs) > 1:
            interior = _with_limb_root(b.nodes, interior, adjacency, pos, rad, params, spacing)
            interior = _head_at_neck(b.nodes, interior, adjacency, pos, rad, ground, params, spacing)
        chain = [slot[rep[b.start]]]
        for i in interior:
            chain.append(len(graph.positions))
            graph.positions.append(pos[b.nodes[i]])
            graph.body.append(body)
        chain.append(slot[rep[b.end]])
        graph.edges += list(zip(chain[:-1], chain[1:]))
        if leg is not None:
            graph.leg_tips.add(chain[0] if leg == 0 else chain[-1])
    graph.edges += [(slot[a], slot[b]) for a, b in split.links]
    return len(graph.positions) - base


def _leaf_end(nodes: list[int], adjacency: list[list[int]]) -> int | None:
    """0 or len(nodes) - 1: the end of the branch `nodes` that is a leaf, when exactly one is (a limb); else None.
    Keys at or past len(adjacency) are junctions made by split_hubs, never leaves."""
    leaves = [i for i in (0, len(nodes) - 1) if nodes[i] < len(adjacency) and len(adjacency[nodes[i]]) == 1]
    return leaves[0] if len(leaves) == 1 else None


def _from_junction(nodes: list[int], end: int, pos: np.ndarray) -> tuple[np.ndarray, Callable[[int], int], np.ndarray]:
    """A limb branch `nodes` whose leaf is at index `end` (0 or last), read from its junction to its tip: (the node
    ids junction → tip, the map between an index into `nodes` and one into that path (its own inverse), the arc
    length at each node of the path, metres)."""
    last = len(nodes) - 1
    path = np.asarray(nodes if end == last else nodes[::-1])
    arc = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(pos[path], axis=0), axis=1))])
    return path, (lambda i: i) if end == last else (lambda i: last - i), arc


def _leg_tip(nodes: list[int], adjacency: list[list[int]], pos: np.ndarray, rad: np.ndarray, ground: _Ground,
             params: GeometricParams, scale: float, spacing: float) -> int | None:
    """0 or len(nodes) - 1: which end of the branch `nodes` is the foot when the branch is a leg; else None.

    A leg is a limb (junction to tip) at least `spacing` long that runs steeply along the up axis, whose tip
    reaches down to the floor and, on a symmetric body, lies off the mirror plane (one of a pair, not a tail or a
    hanging body). Artists give it a hip or shoulder, a knee or elbow, an ankle or wrist and a foot: it gets a
    joint at least every 1 / `leg_segments` of its length, where an even split by `spacing` gives two or three,
    and its foot joint stays nearer the floor (`leg_tip_pull`). Measured on the dev rigs (auto), four segments
    against none: the fox 0.0438 → 0.0397, quadruped_a 0.0532 → 0.0462, lizard 0.0308 → 0.0276, others unchanged;
    3 and 5 segments also better (geometric assets 0.0382 → 0.0376, 0.0372 against 0.0370); steepness 0.75-0.8
    the same, 0.5-0.7 also take the fish's slanting pectoral fins (0.0384 → 0.0396), 0.85 loses one of
    quadruped_a's legs. The foot pulled 0.3 instead of 0.7 of the way in (measured with symmetry.TWIN_BARE still
    at 0.03): fox 0.0381, quadruped_a 0.0452, lizard 0.0263 (geometric assets 0.0370 → 0.0367; 0 and 0.5 give
    0.0367 and 0.0368), and no 1 cm last bone on the lizard.
    """
    end = _leaf_end(nodes, adjacency)
    if end is None:
        return None
    tip, start = nodes[end], nodes[len(nodes) - 1 - end]
    chord = pos[tip] - pos[start]
    upright = abs(float(chord @ ground.up)) >= params.leg_upright * float(np.linalg.norm(chord))
    on_floor = float(pos[tip] @ ground.up) - rad[tip] <= ground.floor + params.floor_gap * scale
    plane = ground.plane  # off it by more than the limb is thick: one of a pair
    paired = plane is None or abs(pos[tip, plane.axis] - plane.offset) > float(np.median(rad[nodes]))
    long_enough = path_length(pos, nodes) >= spacing
    return end if upright and on_floor and paired and long_enough else None


def _head_at_neck(nodes: list[int], interior: list[int], adjacency: list[list[int]], pos: np.ndarray,
                  rad: np.ndarray, ground: _Ground, params: GeometricParams, spacing: float) -> list[int]:
    """`interior` (indices into the branch `nodes`) with a head's joints replaced by one at its neck.

    A head is the end of a limb whose tip lies on the mirror plane and which widens again, beyond its thinnest
    point, to at least `head_widen` × that thickness (a skull beyond a neck). A skull does not bend, so joints
    inside it only let it buckle: it gets one joint, its pivot, where the neck is thinnest next to it (the last
    point within `neck_tol` of the thinnest, as a long neck is thin all along), and joints of the neck closer than
    `limb_gap` × spacing to that point go. Its tip then ends the chain as a midline end (`_midline_ends`).
    The first and last tenth of the limb are not read: the junction's ball and the tip's cap.
    Measured on the dev rigs (auto): quadruped_a 0.0406 → 0.0355 (B2B 0.0271 → 0.0206), the only one it fires on;
    `head_widen` 1.2-1.6 the same, `neck_tol` 1.0 / 1.2 give 0.0356 / 0.0352.
    """
    end, plane = _leaf_end(nodes, adjacency), ground.plane
    if end is None or plane is None or abs(pos[nodes[end], plane.axis] - plane.offset) > rad[nodes[end]]:
        return interior
    path, flip, arc = _from_junction(nodes, end, pos)
    r = ndimage.uniform_filter1d(rad[path].astype(np.float64), RADIUS_SMOOTH, mode="nearest")
    lo, hi = max(2, len(path) // 10), len(path) - max(2, len(path) // 10)
    if hi - lo < 3:
        return interior
    widest = lo + int(np.argmax(r[lo:hi]))
    if widest == lo or r[widest] < params.head_widen * float(r[lo:widest].min()):
        return interior
    neck = lo + int(np.flatnonzero(r[lo:widest] <= params.neck_tol * float(r[lo:widest].min()))[-1])
    keep = [i for i in interior if arc[flip(i)] < arc[neck] - params.limb_gap * spacing]
    return sorted(keep + [flip(neck)])


def _with_limb_root(nodes: list[int], interior: list[int], adjacency: list[list[int]], pos: np.ndarray,
                    rad: np.ndarray, params: GeometricParams, spacing: float) -> list[int]:
    """`interior` (indices into the branch `nodes`) plus a joint where a limb leaves the body, when it has none.

    A limb is a branch from a junction to a leaf. Its first joint belongs where it leaves the body (the hip or
    shoulder it swings about, as artists and the humanoid fit place it), not at the medial junction deep inside the
    body; it is added only when the limb goes on for at least `spacing` past that point, so short end parts do not
    get a second joint, nor when the junction or a joint is within `limb_gap` × spacing of it (no stub bones).
    Measured on the dev rigs (auto): J2J 0.0348 → 0.0344 (lizard, penguin, quadruped_a and dragon better, none
    worse), B2B 0.0176 either way.
    """
    end = _leaf_end(nodes, adjacency)
    if end is None or len(nodes) < 3:
        return interior
    path, flip, arc = _from_junction(nodes, end, pos)
    exit_at = limb_exit(rad[path], params.limb_exit)
    taken = [0.0] + [float(arc[flip(i)]) for i in interior]  # the junction and the joints already there
    near = min(abs(a - arc[exit_at]) for a in taken) <= params.limb_gap * spacing
    if not 0 < exit_at < len(path) - 1 or arc[-1] - arc[exit_at] <= spacing or near:
        return interior
    return sorted(interior + [flip(exit_at)])


def _connect_bodies(graph: _JointGraph, order: list[int]) -> int:
    """Join body trees (largest first in `order`) by their closest joint pairs; returns edges added."""
    pos = np.asarray(graph.positions)
    body = np.asarray(graph.body)
    connected = body == order[0]
    added = 0
    pending = list(order[1:])
    while pending:
        best = None
        for b in pending:
            inside = np.flatnonzero(body == b)
            outside = np.flatnonzero(connected)
            d = np.linalg.norm(pos[inside][:, None] - pos[outside][None], axis=2)
            i, j = np.unravel_index(int(np.argmin(d)), d.shape)
            if best is None or d[i, j] < best[0]:
                best = (float(d[i, j]), b, int(outside[j]), int(inside[i]))
        _, b, a, c = best
        graph.edges.append((a, c))
        connected |= body == b
        pending.remove(b)
        added += 1
    return added


def _choose_root(pos: np.ndarray, edges: np.ndarray, main: np.ndarray, centre: np.ndarray) -> int:
    """RigGS root: the junction with the longest tree path to its nearest endpoint (main body only); ties go to
    the joint nearest the centre of mass. A junction-free body (tube, rope, strip) is rooted at an end, as
    animators rig chains, not at its middle."""
    n = len(pos)
    if n == 1:
        return 0
    length = np.linalg.norm(pos[edges[:, 0]] - pos[edges[:, 1]], axis=1) + 1e-9
    adj = sp.coo_matrix((length, (edges[:, 0], edges[:, 1])), shape=(n, n)).tocsr()
    adj = adj + adj.T
    degree = np.diff(adj.indptr)
    leaves = np.flatnonzero(degree == 1)
    to_leaf = dijkstra(adj, directed=False, indices=leaves, min_only=True)
    to_centre = np.linalg.norm(pos - centre, axis=1)
    junctions = np.flatnonzero((degree >= 3) & main)
    if len(junctions) == 0:  # a chain: rooted at an end, as animators rig chains
        ends = np.flatnonzero((degree <= 1) & main) if (degree[main] <= 1).any() else np.flatnonzero(main)
        return int(ends[_chain_start(pos[ends], float(np.ptp(pos[main], axis=0).max()))])
    # Longest-to-nearest-endpoint first; a 5 % band counts as a tie broken by distance to the centre of mass.
    best = to_leaf[junctions].max()
    near = junctions[to_leaf[junctions] >= 0.95 * best]
    return int(near[np.argmin(to_centre[near])])


def _chain_start(ends: np.ndarray, span: float) -> int:
    """Index into `ends` (N, 3), a chain's end joints, of the one it is rooted at: the lowest (+Y up), or the back
    (-Z) one among those within a tenth of `span` (the chain's length) of the lowest, when it lies level."""
    low = np.flatnonzero(ends[:, 1] < ends[:, 1].min() + 0.1 * (span or 1.0))
    return int(low[np.argmin(ends[low, 2])])


def _from_start(chain: np.ndarray) -> np.ndarray:
    """The joints `chain` (J, 3) of a chain, in order from the end it is rooted at (`_chain_start`)."""
    span = float(np.ptp(chain, axis=0).max())
    return chain if _chain_start(chain[[0, -1]], span) == 0 else chain[::-1]


def _rooted_order(n: int, edges: np.ndarray, root: int, pos: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """DFS preorder from `root` (children visited by ascending position tuple); returns (order, parents in order)."""
    nbrs: list[list[int]] = [[] for _ in range(n)]
    for a, b in edges.tolist():
        nbrs[a].append(b)
        nbrs[b].append(a)
    order, parent_of = [], {root: -1}
    stack = [root]
    while stack:
        j = stack.pop()
        order.append(j)
        kids = sorted((c for c in nbrs[j] if c not in parent_of), key=lambda c: tuple(pos[c]), reverse=True)
        for c in kids:
            parent_of[c] = j
        stack += kids
    index = {j: k for k, j in enumerate(order)}
    parents = np.array([index[parent_of[j]] if parent_of[j] >= 0 else -1 for j in order], dtype=np.int64)
    return np.asarray(order), parents


def _pull_tips(pos: np.ndarray, parents: np.ndarray, share: float | np.ndarray) -> np.ndarray:
    """Move every leaf joint `share` (a number, or (J,) one per joint) of the way to its parent.
    pos: (J, 3), parents: (J,) → new (J, 3).

    Thinning ends a radius short of a limb's tip, and artists' last weighted joint sits where the end part
    (hand, fin, tail tip) starts, not at its far end. Measured on the dev rigs (auto): 0.7 against 0.35 lowers
    J2J on 9 of 19 and raises it on 4 (fox, lizard, recursive_skeletons, robot_expressive); mean 0.0383 → 0.0348,
    0.0352 → 0.0342 without the three toy rigs.
    """
    out = pos.copy()
    has_child = np.zeros(len(pos), bool)
    has_child[parents[parents >= 0]] = True
    leaves = np.flatnonzero(~has_child & (parents >= 0))
    shares = np.broadcast_to(share, len(pos))[leaves, None]
    out[leaves] += shares * (pos[parents[leaves]] - pos[leaves])
    return out


def _midline_ends(skeleton: Skeleton, twins: MirrorTwins) -> np.ndarray:
    """(J,) bool: the leaves on the mirror plane (the ends of a head, a tail, a snout) of a skeleton that has a
    junction; none for a lone chain (a rope keeps its end) or when fewer than two joints would remain. A leaf
    hanging straight from the body (a joint with limbs off the plane) keeps its joint: it is the part's only bone
    (the bat's head: without it the head could not turn), 0.0311 → 0.0291 on the bat. A fork on the plane (the
    fish's two tail lobes) is one part's end: its leaves go (kept, the fish measured 0.0388 against 0.0379).

    Artists end a head or tail chain at its last pivot; the joint at its tip (Mixamo's HeadTop_End) carries no
    weight, so it is not part of their rig. Measured on the dev rigs (auto), every non-toy geometric asset closer
    or the same: fox 0.0372 → 0.0365, fish 0.0384 → 0.0379, dragon 0.0534 → 0.0503, quadruped_a 0.0452 → 0.0406,
    bat 0.0323 → 0.0311, bird, penguin, lizard 0.0261 → 0.0237; robot the same. Over those nine, 0.0361 → 0.0346;
    pulling the ends further in instead (0.8 / 0.9 of the way) gave 0.0358 / 0.0356 and a stub last bone.
    """
    parents, own = skeleton.parents, np.arange(skeleton.num_joints)
    degree = np.bincount(parents[parents >= 0], minlength=skeleton.num_joints) + (parents >= 0)
    on_plane = twins.twin == own
    hub = np.zeros(skeleton.num_joints, bool)  # a joint with a child off the mirror plane: the body, not a fork
    hub[parents[(parents >= 0) & ~on_plane]] = True
    parent = np.maximum(parents, 0)  # the root stands in for its own parent (masked out by parents >= 0)
    chain_end = (parents >= 0) & (((degree[parent] == 2) & (parents[parent] >= 0)) | ~hub[parent])
    ends = (degree == 1) & chain_end & on_plane
    if not (degree >= 3).any() or np.count_nonzero(~ends) < 2:
        return np.zeros(skeleton.num_joints, bool)
    return ends


def _stub_joints(pos: np.ndarray, parents: np.ndarray, shortest: float) -> np.ndarray:
    """(J,) bool: the joints closer than `shortest` to their parent (a zero-length bone has no direction to
    rotate about). Averaging mirror twins makes them: the bird's foot had a twinless joint on one side and its
    child, paired with the other side's joint, landed on it."""
    stub = np.zeros(len(pos), bool)
    stub[1:] = np.linalg.norm(pos[1:] - pos[parents[1:]], axis=1) < shortest
    return stub


def _free_skeleton(positions: np.ndarray, parents: np.ndarray) -> Skeleton:
    """A validated Skeleton of FREE joints named `root`, `joint001`, … in order."""
    names = ["root"] + [f"joint{k:03d}" for k in range(1, len(positions))]
    return Skeleton(positions, parents, names, [JointKind.FREE] * len(positions)).validate()


def _extend_end(end: np.ndarray, inner: np.ndarray, distance: float) -> np.ndarray:
    """(3,) `end` moved `distance` further along the direction from `inner` to `end`."""
    step = end - inner
    return end + distance * step / max(float(np.linalg.norm(step)), 1e-12)


def sheet_chain(parts: list[SurfacePart], ratio: float, spacing: float, max_joints: int) -> np.ndarray | None:
    """(J, 3) joints of a chain along the principal axis when the mesh is a flat sheet, else None.

    parts: the mesh's connected parts (surface_parts). A sheet (thickness < `ratio` × length) has no solid to
    thin; artists rig a strip, flag or card as one chain of even segments, max(`spacing`, sheet width) long, with
    a joint where each segment starts (the segment's pivot) and none on the far edge, which would bend nothing
    (the glTF specification's SimpleSkin strip: two joints, at its base and its middle; the tip pulled 0.7 back
    from the far edge instead left a last bone 0.15 × the length long). Each part holding SHEET_PART_AREA of the
    area must be flat itself (two solids far apart are flat as a whole, and a chain through the empty space
    between them is no skeleton); the chain follows those parts, smaller ones (a button) take their weights from
    it.
    """
    total = sum(p.area for p in parts)
    deciding = [p.points for p in parts if p.area >= SHEET_PART_AREA * total] or [parts[0].points]
    if any(flat_normal(points, ratio) is None for points in deciding):
        return None
    pts = np.unique(np.concatenate(deciding), axis=0)
    centre, axes, local = principal_frame(pts)
    extent = np.ptp(local, axis=0)
    if extent[0] <= 0 or extent[2] >= ratio * extent[0]:
        return None
    segments = int(np.clip(np.floor(extent[0] / max(spacing, extent[1]) + 0.5), 2, max(max_joints, 2)))
    mid = 0.5 * (local.min(axis=0) + local.max(axis=0))
    t = local[:, 0].min() + extent[0] * np.arange(segments + 1) / segments
    chain = centre + (mid[None, :] * [0, 1, 1] + t[:, None] * [1, 0, 0]) @ axes
    return _from_start(chain)[:-1]


def rank_bodies(grid: VoxelGrid, forest: MedialForest) -> tuple[list[int], dict[int, int], np.ndarray]:
    """Medial-forest components by the solid volume (voxels) of the bodies they thin, largest first.

    Returns (component labels ranked, label → voxel count, (X, Y, Z) int body label of every voxel).
    """
    body_labels, _ = ndimage.label(grid.occupancy, structure=np.ones((3, 3, 3), bool))
    volume = np.bincount(body_labels.ravel())
    medial_body = body_labels[tuple(grid.index_of(forest.positions).T)]
    comp_volume = {int(c): int(volume[np.unique(medial_body[forest.component == c])].sum())
                   for c in np.unique(forest.component)}
    ranked = sorted(comp_volume, key=lambda c: (-comp_volume[c], c))
    return ranked, comp_volume, body_labels


def _closed_solid(v: np.ndarray, faces: np.ndarray, params: GeometricParams) -> tuple[VoxelGrid, MedialForest, int]:
    """Voxelise with the smallest closing, then retry with a stronger one; keep the stronger closing only when it
    shortens the medial axis by more than `close_drop` (a gap-sized hole made thinning trace round a cavity) and
    its medial axis stays inside the lightly closed solid (the closing filled a hole in a body, not the space
    between separate parts, e.g. BrainStem's rigid pieces, whose joints would then float outside the mesh).

    Returns (grid, medial forest, close radius used). Unsupervised: no ground truth, one criterion for all meshes.
    """
    grid = solid_voxels(v, faces, resolution=params.resolution, close_radius=params.close_radius)
    forest = medial_forest(grid, restore_limbs=True)
    if params.close_retry <= params.close_radius:
        return grid, forest, params.close_radius
    closed = solid_voxels(v, faces, resolution=params.resolution, close_radius=params.close_retry)
    closed_forest = medial_forest(closed, restore_limbs=True)
    shorter = _medial_length(closed_forest) < (1.0 - params.close_drop) * _medial_length(forest)
    if shorter and grid.inside(closed_forest.positions).mean() >= params.close_inside:
        return closed, closed_forest, params.close_retry
    return grid, forest, params.close_radius


def _medial_length(forest: MedialForest) -> float:
    """Total edge length of the medial forest, metres."""
    a = np.repeat(np.arange(len(forest.adjacency)), [len(n) for n in forest.adjacency])
    b = np.fromiter((m for n in forest.adjacency for m in n), dtype=np.int64, count=len(a))
    return 0.5 * float(np.linalg.norm(forest.positions[a] - forest.positions[b], axis=1).sum())


def geometric_skeleton(vertices: np.ndarray, faces: np.ndarray, *, max_joints: int = 64,
                       params: GeometricParams = GeometricParams(),
                       parts: list[SurfacePart] | None = None, up: np.ndarray = GLTF_UP) -> tuple[Skeleton, dict]:
    """Skeleton of a triangle soup by medial thinning.

    vertices: (V, 3) float64 metres (any frame; the result is in the same frame), faces: (F, 3) int64;
    parts: surface_parts(vertices, faces) when the caller has them already; up: the up axis (unit), which only
    tells legs standing on the floor (glTF's +Y unless the caller knows better).
    Returns (Skeleton with JointKind.FREE joints named `root`, `joint001`…, report dict). Deterministic.
    """
    v = np.asarray(vertices, dtype=np.float64)
    scale = float(np.ptp(v, axis=0).max()) or 1.0
    chain = sheet_chain(parts if parts is not None else surface_parts(v, faces), params.sheet_ratio, params.spacing * scale, max_joints)
    if chain is not None:
        parents = np.arange(-1, len(chain) - 1, dtype=np.int64)
        skeleton = _free_skeleton(chain, parents)
        return skeleton, {"sheet": True, "joints": skeleton.num_joints, "bodies": 1}
    grid, base, closing = _closed_solid(v, faces, params)
    ranked, comp_volume, body_labels = rank_bodies(grid, base)
    total = sum(comp_volume.values())
    kept = [c for c in ranked if comp_volume[c] >= params.min_part * total] or ranked[:1]

    spacing, spur_min = params.spacing * scale, params.spur_min * scale
    plane = body_mirror(v)  # None: not symmetric (then no twins anywhere)
    ground = _Ground(up, float((v @ up).min()), plane)
    for _ in range(60):  # widen spacing, then prune longer spurs, then drop small bodies until the budget holds
        forest = MedialForest(base.positions, base.radius, [list(a) for a in base.adjacency], base.component)
        slender = params.twin_slender if spur_min <= params.spur_min * scale else np.inf  # the budget comes first
        removed = prune_spurs(forest.adjacency, forest.positions, forest.radius, params.spur_ratio, spur_min,
                              plane, slender)
        alive = np.ones(len(forest.positions), bool)
        alive[removed] = False
        graph = _JointGraph([], [], [])
        for b, c in enumerate(kept):
            _body_joints(forest, np.flatnonzero((forest.component == c) & alive), params, scale, spacing, ground,
                         graph, b)
        if len(graph.positions) <= max_joints:
            break
        if spacing < 2 * scale:
            spacing *= 1.25
        elif spur_min < scale:
            spur_min *= 1.5
        elif len(kept) > 1:
            kept = kept[:-1]
    degree = np.bincount(np.asarray(graph.edges, dtype=np.int64).ravel(), minlength=len(graph.positions))
    loops = edge_loops(v, params.loop_gap) if len(kept) == 1 and degree.max(initial=0) <= 2 else None
    if loops is not None and len(loops) - 1 <= max_joints:  # a low-poly tube: a joint at each ring but the far one
        skeleton = _free_skeleton(snap_inside(grid, _from_start(loops)[:-1]), np.arange(-1, len(loops) - 2))
        return skeleton, {"edge_loops": len(loops), "joints": skeleton.num_joints, "bodies": 1,
                          "resolution": params.resolution, "voxel_pitch": grid.pitch}
    joined = _connect_bodies(graph, list(range(len(kept)))) if len(kept) > 1 else 0

    pos = np.asarray(graph.positions, dtype=np.float64).reshape(-1, 3)
    edges = np.asarray(graph.edges, dtype=np.int64).reshape(-1, 2)
    main = np.asarray(graph.body) == 0
    main_labels = np.unique(body_labels[tuple(grid.index_of(base.positions[base.component == kept[0]]).T)])
    occupied = grid.centers(np.argwhere(np.isin(body_labels, main_labels)))
    root = _choose_root(pos, edges, main, occupied.mean(axis=0))
    order, parents = _rooted_order(len(pos), edges, root, pos)
    feet = np.isin(order, list(graph.leg_tips))
    pos = _pull_tips(pos[order], parents, np.where(feet, params.leg_tip_pull, params.tip_pull))
    if np.count_nonzero(parents == 0) == 1:  # a chain's root is its end: thinning stopped a radius short of it
        depth = base.radius[int(np.argmin(np.linalg.norm(base.positions - pos[0], axis=1)))]
        pos[0] = _extend_end(pos[0], pos[np.flatnonzero(parents == 0)[0]], params.root_push * depth)
    pos = centre_in_section(pos, parents, grid, params.section_limit)
    twins = None if plane is None else mirror_twins(pos, parents, grid, plane)
    if twins is not None:
        pos = symmetrize(pos, twins)
    pos = snap_inside(grid, pos)  # a tip pulled across a bend, a joint averaged with its mirror twin
    skeleton, mirror = _free_skeleton(pos, parents), mirror_report(None)
    stubs = _stub_joints(pos, parents, STUB_VOXELS * grid.pitch)
    whole, drop = skeleton, stubs
    if twins is not None:
        lopsided = lopsided_branches(skeleton, twins, grid)
        ends = _midline_ends(skeleton, twins)
        whole, drop, added = complete_twins(skeleton, twins, grid, lopsided | ends | stubs, max_joints)
        mirror = mirror_report(twins, int(np.count_nonzero(lopsided[1:] & ~lopsided[parents[1:]])), added,
                               int(np.count_nonzero(ends)))
    if drop.any() or whole is not skeleton:
        rest = whole.without(drop)[0]
        skeleton = _free_skeleton(rest.positions, rest.parents)
    report = {
        "resolution": params.resolution,
        "close_radius": closing,
        "voxel_pitch": grid.pitch,
        "medial_voxels": int(len(forest.positions)),
        "limbs_restored": base.restored,
        "spur_voxels_pruned": int(len(removed)),
        "bodies": len(kept),
        "bodies_ignored": len(ranked) - len(kept),
        "bodies_joined": joined,
        "joints": skeleton.num_joints,
        "spacing": spacing,
        "stub_joints_dropped": int(np.count_nonzero(stubs)),
        "mirror": mirror,
    }
    return skeleton, report

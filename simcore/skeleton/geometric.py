"""Geometric skeleton for any mesh: solid voxels → medial forest → joint graph → rooted tree.

Works on real game meshes (holes, several components, self-intersections) because everything downstream of
`solid_voxels` sees only a closed voxel solid. Joints are medial voxel centres, refined within their voxel towards
the centre of their limb's cross-section (`section_centre`). Several disconnected bodies each get their own tree
and are then hung under the largest body's tree at their closest joint pair, so the result is one Skeleton; the
report says how many bodies were joined. The rules for one limb are in `limb_rules`; chains and flat sheets in
`chains`; low-poly tubes in `edge_loops`.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp
from scipy import ndimage
from scipy.sparse.csgraph import dijkstra

from simcore.geometry.parts import SurfacePart, surface_parts
from simcore.geometry.voxelize import VoxelGrid, solid_voxels
from simcore.skeleton.axes import GLTF_UP
from simcore.skeleton.chains import chain_start, segment_starts, sheet_chain
from simcore.skeleton.edge_loops import edge_loops
from simcore.skeleton.graph_simplify import branch_joints, branches, merge_junctions, path_length, prune_spurs
from simcore.skeleton.inside import snap_inside
from simcore.skeleton.limb_rules import Ground, head_at_neck, leg_tip, with_limb_root
from simcore.skeleton.medial import MedialForest, medial_forest
from simcore.skeleton.section_centre import SECTION_LIMIT, centre_in_section
from simcore.skeleton.symmetry import MirrorTwins, body_mirror, complete_twins, lopsided_branches, mirror_report, mirror_twins, symmetrize
from simcore.skeleton.types import JointKind, Skeleton

STUB_VOXELS = 0.5  # a bone shorter than this many voxels is no bone: its child joint goes


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
    # Special-case rules, each switchable (simcore.skeleton.geometric_rules, `rigforge eval skeleton --ablate`).
    twin_spurs: bool = True  # mirror-twin spurs of one junction are kept or pruned together
    legs: bool = True  # legs standing on the floor: denser joints and a foot joint pulled in less
    limb_roots: bool = True  # a limb gets a joint where it leaves the trunk (its hip or shoulder)
    neck_pivot: bool = True  # a head on a neck gets its pivot where the neck is thinnest
    restore_limbs: bool = True  # limbs that thinning erased get their medial line back (lost_limbs)
    mirror: bool = True  # on a mirror-symmetric mesh, twin joints are averaged into mirror images
    lopsided: bool = True  # ...a twinless branch whose mirror image is bare solid is dropped...
    midline_ends: bool = True  # ...and the tip joints of head and tail chains on the mirror plane are dropped


@dataclass
class _JointGraph:
    positions: list[np.ndarray]
    edges: list[tuple[int, int]]
    body: list[int]
    leg_tips: set[int] = field(default_factory=set)


def _body_joints(forest: MedialForest, nodes: np.ndarray, params: GeometricParams, scale: float, spacing: float,
                 ground: Ground, graph: _JointGraph, body: int) -> int:
    """Add one body's joints and edges to `graph`; returns how many joints it added."""
    adjacency, pos, rad = forest.adjacency, forest.positions, forest.radius
    keys, brs = branches(adjacency, nodes)
    rep, merged, brs = merge_junctions(keys, brs, adjacency, pos, rad, params.merge_ratio)
    base = len(graph.positions)
    slot: dict[int, int] = {}
    for r in sorted(set(rep.values())):
        slot[r] = len(graph.positions)
        graph.positions.append(merged[r])
        graph.body.append(body)
    for b in brs:
        leg = leg_tip(b.nodes, adjacency, pos, rad, ground, params, scale, spacing) if len(brs) > 1 and params.legs else None
        step = spacing if leg is None else min(spacing, path_length(pos, b.nodes) / params.leg_segments)
        interior = branch_joints(pos[b.nodes], rad[b.nodes], params.turn_ratio, params.turn_min * scale, step)
        if len(brs) > 1 and params.limb_roots:
            interior = with_limb_root(b.nodes, interior, adjacency, pos, rad, params, spacing)
        if len(brs) > 1 and params.neck_pivot:
            interior = head_at_neck(b.nodes, interior, adjacency, pos, rad, ground, params, spacing)
        chain = [slot[rep[b.start]]]
        for i in interior:
            chain.append(len(graph.positions))
            graph.positions.append(pos[b.nodes[i]])
            graph.body.append(body)
        chain.append(slot[rep[b.end]])
        graph.edges += list(zip(chain[:-1], chain[1:]))
        if leg is not None:
            graph.leg_tips.add(chain[0] if leg == 0 else chain[-1])
    return len(graph.positions) - base


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
        assert best is not None  # pending is not empty
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
        return int(ends[chain_start(pos[ends], float(np.ptp(pos[main], axis=0).max()))])
    # Longest-to-nearest-endpoint first; a 5 % band counts as a tie broken by distance to the centre of mass.
    best = to_leaf[junctions].max()
    near = junctions[to_leaf[junctions] >= 0.95 * best]
    return int(near[np.argmin(to_centre[near])])


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
    (hand, fin, tail tip) starts, not at its far end. Pulling the leaf most of the way back towards its parent
    puts it at that pivot rather than out in the end part, which would only carry rigid weight.
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
    (a head set straight on the body: without it the head could not turn). A fork on the plane (a fish's two
    tail lobes) is one part's end: its leaves go, as the lobes move with the tail rather than on their own.

    Artists end a head or tail chain at its last pivot; the joint at its tip (Mixamo's HeadTop_End) carries no
    weight, so it is not part of their rig; dropping it leaves the chain ending at the pivot that moves the part.
    Pulling such an end further in instead would leave a stub last bone with little length to rotate.
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
    rotate about). Averaging mirror twins makes them: a twinless joint on one side whose child is paired with
    the other side's joint can have that child land on it."""
    stub = np.zeros(len(pos), bool)
    stub[1:] = np.linalg.norm(pos[1:] - pos[parents[1:]], axis=1) < shortest
    return stub


def _free_skeleton(positions: np.ndarray, parents: np.ndarray) -> Skeleton:
    """A validated Skeleton of FREE joints named `root`, `joint001`, … in order."""
    names = ["root"] + [f"joint{k:03d}" for k in range(1, len(positions))]
    return Skeleton(positions, parents, names, [JointKind.FREE] * len(positions)).validate()


def _chain_skeleton(positions: np.ndarray) -> Skeleton:
    """`_free_skeleton` of a chain: each of `positions` (J, 3) the parent of the next."""
    return _free_skeleton(positions, np.arange(-1, len(positions) - 1, dtype=np.int64))


def _extend_end(end: np.ndarray, inner: np.ndarray, distance: float) -> np.ndarray:
    """(3,) `end` moved `distance` further along the direction from `inner` to `end`."""
    step = end - inner
    return end + distance * step / max(float(np.linalg.norm(step)), 1e-12)


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
    between separate rigid parts, whose joints would then float outside the mesh).

    Returns (grid, medial forest, close radius used). Unsupervised: no ground truth, one criterion for all meshes.
    """
    grid = solid_voxels(v, faces, resolution=params.resolution, close_radius=params.close_radius)
    forest = medial_forest(grid, restore_limbs=params.restore_limbs)
    if params.close_retry <= params.close_radius:
        return grid, forest, params.close_radius
    closed = solid_voxels(v, faces, resolution=params.resolution, close_radius=params.close_retry)
    closed_forest = medial_forest(closed, restore_limbs=params.restore_limbs)
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
    parts = parts if parts is not None else surface_parts(v, faces)
    chain = sheet_chain(parts, params.sheet_ratio, params.spacing * scale, max_joints)
    if chain is not None:
        skeleton = _chain_skeleton(chain)
        return skeleton, {"sheet": True, "joints": skeleton.num_joints, "bodies": 1}
    grid, base, closing = _closed_solid(v, faces, params)
    ranked, comp_volume, body_labels = rank_bodies(grid, base)
    total = sum(comp_volume.values())
    kept = [c for c in ranked if comp_volume[c] >= params.min_part * total] or ranked[:1]

    spacing, spur_min = params.spacing * scale, params.spur_min * scale
    plane = body_mirror(v)  # None: not symmetric (then no twins anywhere)
    ground = Ground(up, float((v @ up).min()), plane)
    for _ in range(60):  # widen spacing, then prune longer spurs, then drop small bodies until the budget holds
        forest = MedialForest(base.positions, base.radius, [list(a) for a in base.adjacency], base.component)
        slender = params.twin_slender if spur_min <= params.spur_min * scale else np.inf  # the budget comes first
        removed = prune_spurs(forest.adjacency, forest.positions, forest.radius, params.spur_ratio, spur_min,
                              plane if params.twin_spurs else None, slender)
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
        skeleton = _chain_skeleton(snap_inside(grid, segment_starts(loops)))
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
    twins = None if plane is None or not params.mirror else mirror_twins(pos, parents, grid, plane)
    if twins is not None:
        pos = symmetrize(pos, twins)
    pos = snap_inside(grid, pos)  # a tip pulled across a bend, a joint averaged with its mirror twin
    skeleton, mirror = _free_skeleton(pos, parents), mirror_report(None)
    stubs = _stub_joints(pos, parents, STUB_VOXELS * grid.pitch)
    whole, drop = skeleton, stubs
    if twins is not None:
        none = np.zeros(skeleton.num_joints, bool)
        lopsided = lopsided_branches(skeleton, twins, grid) if params.lopsided else none
        ends = _midline_ends(skeleton, twins) if params.midline_ends else none
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

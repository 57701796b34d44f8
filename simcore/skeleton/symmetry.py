"""Mirror-symmetric skeletons for mirror-symmetric meshes.

Artists' rigs of symmetric characters are symmetric (so poses and animations can be mirrored); voxel thinning
and template fitting are not quite: a knee lands a voxel lower on one side, a spine joint beside the mid-plane,
a spur is pruned on one side and kept on the other. When the mesh is its own mirror image across an axis-aligned
plane, joints are paired with their mirror twins: matched globally (one-to-one, least total cost), the cost of a
pair being how far each joint's mirror image is from the other plus the same for their parents, so a knee pairs
with the other knee, not with a foot tip pulled close to it. Each twin is averaged with its twin's mirror image
and a joint that is its own twin goes onto the plane; a branch of two or more joints with no twins, where the
body has the same part on the other side but no bones, is dropped (the other side's was pruned as a spur there),
while a lone twinless joint (a foot tip or a turning point found on one side only) gets its mirror image on the
other side.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import linear_sum_assignment
from scipy.spatial import cKDTree

from simcore.geometry.voxelize import VoxelGrid
from simcore.skeleton.mirror import MirrorPlane, best_mirror
from simcore.skeleton.types import Skeleton

SYMMETRIC_MESH = 0.01  # mean distance from a mirrored vertex to the nearest vertex, × size: a symmetric mesh
PAIR_DISTANCE = 0.08  # × size: joints are twins when their mirror images and their parents' are within this
LOPSIDED_JOINTS = 2  # a twinless branch this long (joints) is dropped when its mirror image lies in the solid...
LOPSIDED_INSIDE = 0.8  # ...for at least this share of its joints...
LOPSIDED_BARE = 0.03  # ...and no joint lies within this × size of that image (no bones there on the other side)
# A lone twinless joint's mirror image is added when no joint lies within this × size of it (two voxels of the
# geometric method's 96): close enough that a mirror-side joint a voxel or so off counts as the twin, and far
# enough below the spacing of a limb's joints that a missing twin (a foot pulled in less) is still restored.
TWIN_BARE = 0.02


@dataclass(frozen=True)
class MirrorTwins:
    """A skeleton's mirror plane, each joint's twin across it (`twin[j]` = j on the plane, -1 = none) and the size
    (longest side of the solid, metres) the distance tests are relative to."""

    plane: MirrorPlane
    twin: np.ndarray
    size: float


def mirror_report(twins: MirrorTwins | None, dropped: int = 0, added: int = 0, ends: int = 0) -> dict:
    """report.json's `mirror`: {"axis", "pairs", "on_plane", "lopsided_dropped", "twins_added",
    "midline_ends_dropped"}, or {"axis": None} when the mesh is not symmetric (a posed character, a prop held out
    to one side) and nothing was moved."""
    if twins is None:
        return {"axis": None}
    own = np.arange(len(twins.twin))
    pairs = int(np.count_nonzero((twins.twin >= 0) & (twins.twin != own))) // 2
    return {"axis": "xyz"[twins.plane.axis], "pairs": pairs, "on_plane": int(np.count_nonzero(twins.twin == own)),
            "lopsided_dropped": dropped, "twins_added": added, "midline_ends_dropped": ends}


def body_mirror(vertices: np.ndarray) -> MirrorPlane | None:
    """The mesh's mirror plane when it is mirror-symmetric (its mirrored vertices lie within SYMMETRIC_MESH × size
    of its vertices, on average), else None. A pose breaks it: a character mid-stride is clearly asymmetric,
    while a rest or bind pose mirrors almost exactly."""
    v = np.asarray(vertices, dtype=np.float64)
    plane, spread = best_mirror(v)
    return plane if spread <= SYMMETRIC_MESH * float(np.ptp(v, axis=0).max()) else None


def mirror_twins(positions: np.ndarray, parents: np.ndarray, grid: VoxelGrid, plane: MirrorPlane,
                 names: list[str] | None = None) -> MirrorTwins:
    """Twins across `plane` (see `body_mirror`) of the joints `positions` (J, 3) (parent indices `parents`,
    root -1) in the solid `grid`. With `names`, `Left…`/`Right…` pairs (a template's: LeftHandIndex1 and
    RightHandIndex1) are matched first, as neighbouring fingers' mirror images nearly coincide; they must still
    pass the distance test."""
    return twins_at_scale(positions, parents, _solid_size(grid), plane, names)


def twins_at_scale(positions: np.ndarray, parents: np.ndarray, scale: float, plane: MirrorPlane,
                   names: list[str] | None = None) -> MirrorTwins:
    """`mirror_twins` with the body's size (metres) given instead of read off a solid."""
    pos = np.asarray(positions, dtype=np.float64)
    own = np.arange(len(pos))
    up = np.where(np.asarray(parents) >= 0, parents, own)  # the root stands in for its own parent
    apart = np.linalg.norm(plane.reflect(pos)[:, None] - pos[None], axis=2)
    cost = apart + apart[up][:, up]
    choice = cost.copy()
    for i, j in _named_pairs(names or []):
        choice[i, j] = 0.0
    _, twin = linear_sum_assignment(choice)  # rows in order: twin[j] is j's best twin
    paired = (cost[own, twin] <= 2.0 * PAIR_DISTANCE * scale) & (twin[twin] == own)
    return MirrorTwins(plane, np.where(paired, twin, -1), scale)


def _named_pairs(names: list[str]) -> list[tuple[int, int]]:
    """(i, j) index pairs of `Left…`/`Right…` names that differ only in the side."""
    index = {name: i for i, name in enumerate(names)}
    sides = (("Left", "Right"), ("Right", "Left"))
    return [(i, index[name.replace(side, other)]) for name, i in index.items() for side, other in sides
            if side in name and name.replace(side, other) in index]


def _solid_size(grid: VoxelGrid) -> float:
    """The longest side of `grid`'s solid, metres."""
    return float(np.ptp(np.argwhere(grid.occupancy), axis=0).max() + 1) * grid.pitch


def symmetrize(positions: np.ndarray, twins: MirrorTwins) -> np.ndarray:
    """(J, 3) copy of `positions` with every twin averaged with its twin's mirror image (self-twins: the plane)."""
    pos = np.array(positions, dtype=np.float64, copy=True)
    paired = twins.twin >= 0
    pos[paired] = 0.5 * (pos[paired] + twins.plane.reflect(pos[twins.twin[paired]]))
    return pos


def lopsided_branches(skeleton: Skeleton, twins: MirrorTwins, grid: VoxelGrid) -> np.ndarray:
    """(J,) bool: the joints of twinless branches (LOPSIDED_JOINTS or more) whose mirror image lies in the solid,
    away from every joint.

    A branch is a joint whose whole subtree is twinless, hanging from a joint with a twin (or on the plane).
    """
    children, parents, pos = skeleton.children(), skeleton.parents, skeleton.positions
    tree, scale = cKDTree(pos), twins.size
    twinless = twins.twin < 0
    for j in range(skeleton.num_joints - 1, -1, -1):  # parents come before children: children are settled first
        twinless[j] = twinless[j] and all(twinless[c] for c in children[j])
    drop = np.zeros(skeleton.num_joints, bool)
    for top in np.flatnonzero(twinless[1:] & ~twinless[parents[1:]]) + 1:
        branch = [int(top)]
        for k in branch:  # grows while it is read: the whole subtree
            branch += children[k]
        mirrored = twins.plane.reflect(pos[branch])
        bare = tree.query(mirrored)[0].min() > LOPSIDED_BARE * scale  # no bones there on the other side
        if len(branch) >= LOPSIDED_JOINTS and grid.inside(mirrored).mean() >= LOPSIDED_INSIDE and bare:
            drop[branch] = True
    return drop


def complete_twins(skeleton: Skeleton, twins: MirrorTwins, grid: VoxelGrid, dropped: np.ndarray,
                   max_joints: int | None = None) -> tuple[Skeleton, np.ndarray, int]:
    """`skeleton` with the mirror images of its lone twinless joints added on the other side: (the new tree, the
    `dropped` (J,) bool mask carried over to it (new joints False), how many joints were added).

    A twinless joint j, not dropped, whose parent has a twin p' (the parent itself when on the plane) qualifies when
    its mirror image lies in the solid with no joint (nor image added before it) within TWIN_BARE × size, and it is
    - a leaf: the image hangs from p' (thinning ended a foot one voxel sooner on the other side);
    - a joint with one child whose twin hangs from p': the image goes between the two (a chain one joint longer
      on one side: a turning point found on one side only).
    No image is added that would take the joints not dropped past `max_joints`.
    """
    pos, parents, twin = skeleton.positions, skeleton.parents.copy(), twins.twin
    children, scale = skeleton.children(), twins.size
    key = list(np.arange(skeleton.num_joints, dtype=np.float64))  # children are visited by key: images slot in
    added: list[np.ndarray] = []
    new_parents: list[int] = []
    room = np.inf if max_joints is None else max_joints - int(np.count_nonzero(~dropped))
    for j in range(1, skeleton.num_joints):
        p = parents[j]
        if len(added) >= room:
            break
        if twin[j] >= 0 or dropped[j] or twin[p] < 0 or dropped[twin[p]] or len(children[j]) > 1:
            continue
        image = twins.plane.reflect(pos[j:j + 1])
        nearest = float(np.linalg.norm(np.vstack([pos, *added]) - image, axis=1).min())  # images added so far too
        if not grid.inside(image)[0] or nearest <= TWIN_BARE * scale:
            continue
        new = skeleton.num_joints + len(added)
        if children[j]:
            below = twin[children[j][0]]
            if below < 0 or parents[below] != twin[p]:
                continue
            parents[below], k = new, key[below] - 0.5
        else:
            k = float(new)
        added.append(image[0])
        new_parents.append(int(twin[p]))
        key.append(k)
    if not added:
        return skeleton, dropped, 0
    all_parents = np.concatenate([parents, new_parents])
    kids: list[list[int]] = [[] for _ in all_parents]
    for c in sorted(range(1, len(all_parents)), key=lambda c: key[c]):
        kids[all_parents[c]].append(c)
    order = [0]
    for j in order:  # grows while it is read: parents before children, each joint's children in key order
        order += kids[j]
    whole = Skeleton(np.vstack([pos, added]), all_parents, [f"j{k}" for k in range(len(all_parents))])
    carried = np.concatenate([dropped, np.zeros(len(added), bool)])
    return whole.reordered(np.asarray(order)), carried[order], len(added)

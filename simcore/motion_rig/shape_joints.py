"""Joints the motion cannot reveal, placed from the mesh's shape.

A part that never bends in a sequence (a spine a clip keeps straight, legs that stand still) is one rigid bone to
the motion: no joint can be read off it. The mesh's shape still shows where it would bend. The shape skeleton's
joints (simcore.skeleton.predict, `auto`) that lie farther from every motion joint than `reach` × the solid's
thickness there are added, each as a child of the motion bone that carries the vertices around it (or of an added
joint of that bone above it in the shape tree). They move rigidly with that bone, so the rig replays the sequence
exactly as before; the bone's weight on each vertex is shared among it and its added joints by geodesic weights.
A separately modelled piece that the motion carries as one (at least PIECE_SHARE of its weight on one bone: a staff,
a hat, a rigid plate) gets none: it is bound whole to that bone, as artists bind such pieces.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import ndimage
from scipy.spatial import cKDTree

from simcore.geometry.parts import part_labels
from simcore.geometry.voxelize import VoxelGrid
from simcore.skeleton.predict import predict_skeleton
from simcore.skeleton.types import Skeleton
from simcore.skinning.geodesic import geodesic_weights

NEIGHBOURS = 8  # vertices around a shape joint whose weights name the bone that carries it
PIECE_SHARE = 0.9  # a separate piece with this share of its weight on one bone moves as one: no joints in it


@dataclass
class ShapeJoints:
    """The rig with shape joints added (after the motion's): skeleton, (V, J) weights, (T, J, 4, 4) transforms,
    and `owner` (A,) the motion joint each added joint moves with."""

    skeleton: Skeleton
    weights: np.ndarray
    transforms: np.ndarray
    owner: np.ndarray


def _thickness(grid: VoxelGrid, points: np.ndarray) -> np.ndarray:
    """(N,) distance from each point to the outside of the solid (at least one voxel), metres."""
    depth = ndimage.distance_transform_edt(grid.occupancy) * grid.pitch
    ijk = np.clip(grid.index_of(points), 0, np.asarray(depth.shape) - 1)
    return np.maximum(depth[tuple(ijk.T)], grid.pitch)


def _carried_pieces(rest: np.ndarray, faces: np.ndarray, weights: np.ndarray) -> np.ndarray:
    """(V,) bool the vertices of separate pieces (every connected part but the largest) that put at least
    PIECE_SHARE of their weight on one bone."""
    labels = part_labels(rest, faces)
    count = int(labels.max()) + 1
    if count < 2:
        return np.zeros(len(rest), bool)
    mass = np.zeros((count, weights.shape[1]))
    np.add.at(mass, labels, weights)
    rigid = mass.max(axis=1) >= PIECE_SHARE * mass.sum(axis=1)
    rigid[np.argmax(np.bincount(labels, minlength=count))] = False  # the body itself
    return rigid[labels]


def _split_weights(weights: np.ndarray, shares: np.ndarray, group: np.ndarray, max_influences: int) -> np.ndarray:
    """(V, J) weights with each motion bone's weight shared among its group by `shares` (V, J), at most
    `max_influences` per vertex. group: (J,) the motion joint each joint moves with (itself for motion joints).
    Within a group the joints move alike, so moving weight among them leaves the skinned sequence unchanged; a
    vertex keeps each of its bones' best member and fills the slots left with the next best members."""
    count = weights.shape[1]
    members = np.zeros((count, len(group)))
    members[group, np.arange(len(group))] = 1.0
    spread = np.zeros((len(weights), len(group)))
    spread[:, : count] = weights
    own = shares * (weights @ members > 0)  # shares within the groups the vertex is weighted to
    split = np.flatnonzero(np.count_nonzero(own[:, count:], axis=1))
    for v in split.tolist():
        row = own[v].copy()
        empty = np.flatnonzero((row @ members.T == 0) & (weights[v] > 0))
        row[empty] = 1.0  # a bone none of whose group reaches the vertex keeps it
        row /= np.maximum(row @ members.T @ members, 1e-12)  # share of its group
        bones = np.flatnonzero(weights[v])
        slots = max_influences - len(bones)
        keep = [int(np.flatnonzero(group == b)[np.argmax(row[group == b])]) for b in bones.tolist()]
        mass = row * weights[v][group]  # the weight each member would carry
        extra = [j for j in np.argsort(-mass).tolist() if mass[j] > 0 and j not in keep][: max(slots, 0)]
        kept = np.asarray(keep + extra)
        out = np.zeros(len(group))
        out[kept] = row[kept]
        total = out @ members.T  # (count,) the kept share of each group
        out = out * (weights[v] / np.maximum(total, 1e-12))[group]
        spread[v] = out
    return spread


def add_shape_joints(rest: np.ndarray, faces: np.ndarray, skeleton: Skeleton, weights: np.ndarray,
                     transforms: np.ndarray, grid: VoxelGrid, *, reach: float, max_joints: int,
                     max_influences: int) -> ShapeJoints:
    """The rig with the shape skeleton's joints that no motion joint is near (at most `max_joints` joints in all;
    the farthest first).

    rest: (V, 3); faces: (F, 3); skeleton: the motion's, parents first; weights: (V, J) rows summing to 1;
    transforms: (T, J, 4, 4) rest → frame t; grid: the rest mesh's solid (for its thickness).
    """
    shape = predict_skeleton(rest, faces, method="auto", max_joints=max_joints).skeleton
    gap = cKDTree(skeleton.positions).query(shape.positions)[0] / _thickness(grid, shape.positions)
    near = cKDTree(rest).query(shape.positions, k=min(NEIGHBOURS, len(rest)))[1].reshape(len(shape.positions), -1)
    in_piece = _carried_pieces(rest, faces, weights)[near].mean(axis=1) > 0.5
    room = max_joints - skeleton.num_joints
    wanted = np.flatnonzero((gap > reach) & ~in_piece)
    wanted = np.sort(wanted[np.argsort(-gap[wanted], kind="stable")][: max(room, 0)])  # parents first
    if not len(wanted):
        return ShapeJoints(skeleton, weights, transforms, np.zeros(0, np.int64))
    carrier = weights[near[wanted]].sum(axis=1).argmax(axis=1)  # (A,) the motion bone around each added joint
    index = {int(s): skeleton.num_joints + i for i, s in enumerate(wanted.tolist())}
    parents = list(skeleton.parents.tolist())
    for i, s in enumerate(wanted.tolist()):
        up = int(shape.parents[s])
        same = up in index and carrier[index[up] - skeleton.num_joints] == carrier[i]
        parents.append(index[up] if same else int(carrier[i]))
    count = skeleton.num_joints
    names = list(skeleton.names) + [f"shape_{i:02d}" for i in range(len(wanted))]
    grown = Skeleton(np.concatenate([skeleton.positions, shape.positions[wanted]]), np.asarray(parents), names).validate()
    group = np.concatenate([np.arange(count), carrier])
    shares = geodesic_weights(rest, faces, grown)
    split = _split_weights(weights, shares, group, max_influences)
    return ShapeJoints(grown, split, transforms[:, group], carrier)

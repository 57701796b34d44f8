"""Rules that read one limb of the medial graph (a branch from a junction to a leaf) and place its joints as
artists do: a hip where it leaves the body, a leg's joints down to the floor, a head's single pivot at its neck."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from scipy import ndimage

from simcore.skeleton.graph_simplify import limb_exit, path_length
from simcore.skeleton.mirror import MirrorPlane

if TYPE_CHECKING:
    from simcore.skeleton.geometric import GeometricParams

RADIUS_SMOOTH = 5  # medial voxels averaged when a limb's thickness profile is read


@dataclass(frozen=True)
class Ground:
    """What tells a leg: the up axis (unit), the mesh's lowest point along it, its mirror plane (None: none)."""

    up: np.ndarray
    floor: float
    plane: MirrorPlane | None


def leaf_end(nodes: list[int], adjacency: list[list[int]]) -> int | None:
    """0 or len(nodes) - 1: the end of the branch `nodes` that is a leaf, when exactly one is (a limb); else None."""
    leaves = [i for i in (0, len(nodes) - 1) if len(adjacency[nodes[i]]) == 1]
    return leaves[0] if len(leaves) == 1 else None


def from_junction(nodes: list[int], end: int, pos: np.ndarray) -> tuple[np.ndarray, Callable[[int], int], np.ndarray]:
    """A limb branch `nodes` whose leaf is at index `end` (0 or last), read from its junction to its tip: (the node
    ids junction → tip, the map between an index into `nodes` and one into that path (its own inverse), the arc
    length at each node of the path, metres)."""
    last = len(nodes) - 1
    path = np.asarray(nodes if end == last else nodes[::-1])
    arc = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(pos[path], axis=0), axis=1))])
    return path, (lambda i: i) if end == last else (lambda i: last - i), arc


def leg_tip(nodes: list[int], adjacency: list[list[int]], pos: np.ndarray, rad: np.ndarray, ground: Ground,
             params: GeometricParams, scale: float, spacing: float) -> int | None:
    """0 or len(nodes) - 1: which end of the branch `nodes` is the foot when the branch is a leg; else None.

    A leg is a limb (junction to tip) at least `spacing` long that runs steeply along the up axis, whose tip
    reaches down to the floor and, on a symmetric body, lies off the mirror plane (one of a pair, not a tail or a
    hanging body). Artists give it a hip or shoulder, a knee or elbow, an ankle or wrist and a foot: it gets a
    joint at least every 1 / `leg_segments` of its length, where an even split by `spacing` gives two or three,
    and its foot joint stays nearer the floor (`leg_tip_pull`), since the foot's pivot is close to the ground
    and pulling it far in would leave a stub last bone. The steepness test (`leg_upright`) keeps slanting fins and
    other limbs that do not carry the body off this rule while still taking legs that splay a little.
    """
    end = leaf_end(nodes, adjacency)
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


def head_at_neck(nodes: list[int], interior: list[int], adjacency: list[list[int]], pos: np.ndarray,
                  rad: np.ndarray, ground: Ground, params: GeometricParams, spacing: float) -> list[int]:
    """`interior` (indices into the branch `nodes`) with a head's joints replaced by one at its neck.

    A head is the end of a limb whose tip lies on the mirror plane and which widens again, beyond its thinnest
    point, to at least `head_widen` × that thickness (a skull beyond a neck). A skull does not bend, so joints
    inside it only let it buckle: it gets one joint, its pivot, where the neck is thinnest next to it (the last
    point within `neck_tol` of the thinnest, as a long neck is thin all along), and joints of the neck closer than
    `limb_gap` × spacing to that point go. Its tip then ends the chain as a midline end (`_midline_ends`).
    The first and last tenth of the limb are not read: the junction's ball and the tip's cap.
    Only limbs with a clear skull beyond a neck are changed; tails, snouts and plain limbs do not widen again.
    """
    end, plane = leaf_end(nodes, adjacency), ground.plane
    if end is None or plane is None or abs(pos[nodes[end], plane.axis] - plane.offset) > rad[nodes[end]]:
        return interior
    path, flip, arc = from_junction(nodes, end, pos)
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


def with_limb_root(nodes: list[int], interior: list[int], adjacency: list[list[int]], pos: np.ndarray,
                    rad: np.ndarray, params: GeometricParams, spacing: float) -> list[int]:
    """`interior` (indices into the branch `nodes`) plus a joint where a limb leaves the body, when it has none.

    A limb is a branch from a junction to a leaf. Its first joint belongs where it leaves the body (the hip or
    shoulder it swings about, as artists and the humanoid fit place it), not at the medial junction deep inside the
    body; it is added only when the limb goes on for at least `spacing` past that point, so short end parts do not
    get a second joint, nor when the junction or a joint is within `limb_gap` × spacing of it (no stub bones).
    The joint then sits at the limb's real pivot, so the limb rotates about its socket rather than about a point
    inside the trunk.
    """
    end = leaf_end(nodes, adjacency)
    if end is None or len(nodes) < 3:
        return interior
    path, flip, arc = from_junction(nodes, end, pos)
    exit_at = limb_exit(rad[path], params.limb_exit)
    taken = [0.0] + [float(arc[flip(i)]) for i in interior]  # the junction and the joints already there
    near = min(abs(a - arc[exit_at]) for a in taken) <= params.limb_gap * spacing
    if not 0 < exit_at < len(path) - 1 or arc[-1] - arc[exit_at] <= spacing or near:
        return interior
    return sorted(interior + [flip(exit_at)])

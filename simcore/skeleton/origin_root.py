"""A root joint at the model's own origin, above a predicted skeleton (`options.root_joint: "origin"`).

The origin of an uploaded file is the pivot its author gave the character: the point on the floor under it, or
the point a flying character hovers above. Game rigs hang the body from a root joint there (the bone that carries
root motion in Unreal, Godot and Unity's generic rigs): in corpus `train` a joint of the artist's rig lies within
6 % of the model's size of the origin in 71 of the 82 rigs, within 1 % in 45 (`rigforge eval skeleton`'s ground
truth). A predicted skeleton gets that joint as a helper (JointKind.HELPER: it owns no bone and no weight, so it
stays where it is while the body moves) when the origin lies within REACH model sizes of the mesh's bounding box
(a file whose origin is far off was not authored around the character), when no joint of the skeleton is already
within NEAR of it and when `max_joints` leaves room.
"""

from __future__ import annotations

import numpy as np

from simcore.skeleton.types import JointKind, Skeleton

REACH = 1.0  # model sizes beyond the bounding box within which the origin is the character's pivot
NEAR = 0.01  # model sizes: a joint this close to the origin already is the root there
NAMES = ("root", "origin_root")
ADDED = "added at the file's origin"


def origin_root(skeleton: Skeleton, vertices: np.ndarray, max_joints: int) -> tuple[Skeleton, str]:
    """`skeleton` (in the vertices' frame, whose origin is the file's) under a helper root at the origin, and why
    it was or was not added."""
    v = np.asarray(vertices, dtype=np.float64)
    lo, hi = v.min(axis=0), v.max(axis=0)
    size = float((hi - lo).max())
    if not (np.all(lo - REACH * size <= 0.0) and np.all(hi + REACH * size >= 0.0)):
        return skeleton, "the file's origin lies far from the model"
    if float(np.linalg.norm(skeleton.positions, axis=1).min()) <= NEAR * size:
        return skeleton, "a joint lies at the file's origin already"
    if skeleton.num_joints >= max_joints:
        return skeleton, "max_joints leaves no room"
    name = next((n for n in NAMES if n not in skeleton.names), f"root_{skeleton.num_joints}")
    return skeleton.under_root(np.zeros(3), name, JointKind.HELPER), ADDED


def body_tree(skeleton: Skeleton) -> tuple[Skeleton, int]:
    """The skeleton below a helper root that holds it by one child (`origin_root`'s, also when it comes back in an
    edited skeleton.json), and 1; else the skeleton and 0. Skinning and retargeting work on the body tree, so the
    body is skinned and animated exactly as without the root."""
    if skeleton.kinds[0] != JointKind.HELPER or not skeleton.root_has_one_child():
        return skeleton, 0
    return skeleton.below_root(), 1

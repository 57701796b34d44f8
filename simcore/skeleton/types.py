"""The skeleton tree: rest-pose joints, parents, names and joint kinds."""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from enum import Enum

import numpy as np

from simcore.errors import InvalidInput

SHORT_BONE = 0.01  # × the skeleton's size: a bone shorter than this repeats its joint (RigNet's duplicates)


def ancestors(parents: np.ndarray, j: int) -> list[int]:
    """[j, parent(j), ..., its root]."""
    out = [int(j)]
    while parents[out[-1]] >= 0:
        out.append(int(parents[out[-1]]))
    return out


def is_at_or_below(parents: np.ndarray, a: int, b: int) -> bool:
    """Joint a is joint b or one of b's descendants in the tree `parents` ((J,) int, -1 for a root)."""
    while a >= 0:
        if a == b:
            return True
        a = int(parents[a])
    return False


def parents_first_order(parents: np.ndarray) -> np.ndarray:
    """(J,) int64 permutation listing every joint after its parent; the identity when that already holds (each
    pass takes, in index order, the joints whose parent is placed). Raises InvalidInput on a cycle or a parent
    index out of range.

    parents: (J,) int, -1 for a root; any order, any number of roots.
    """
    parents = np.asarray(parents, dtype=np.int64).reshape(-1)
    j = len(parents)
    if np.any(parents >= j) or np.any(parents < -1):
        raise InvalidInput("skeleton parent index out of range", field="skeleton")
    order: list[int] = []
    placed = np.zeros(j, bool)
    while len(order) < j:
        before = len(order)
        for k in np.flatnonzero(~placed).tolist():
            if parents[k] < 0 or placed[parents[k]]:
                order.append(k)
                placed[k] = True
        if len(order) == before:
            raise InvalidInput("skeleton parents form a cycle", field="skeleton")
    return np.asarray(order, dtype=np.int64)


def tree_depths(parents: np.ndarray) -> np.ndarray:
    """(J,) int64 number of ancestors of each joint. parents: (J,) int, -1 for a root, in any order; raises
    InvalidInput as `parents_first_order` does."""
    parents = np.asarray(parents, dtype=np.int64).reshape(-1)
    depth = np.zeros(len(parents), np.int64)
    for j in parents_first_order(parents).tolist():
        if parents[j] >= 0:
            depth[j] = depth[parents[j]] + 1
    return depth


class JointKind(str, Enum):
    """What a joint belongs to; drives tokenisation (template parts, spring chains)."""

    BODY = "body"  # Mixamo body template joint
    HAND = "hand"  # Mixamo finger joint
    SPRING = "spring"  # secondary chain (hair, tail, skirt)
    FREE = "free"  # anything else
    HELPER = "helper"  # deforms nothing (a kept rig's pole target, bone-end marker, socket): owns no bone to skin to


@dataclass
class Skeleton:
    """A joint tree in rest pose.

    positions: (J, 3) float64 world-space joint heads, metres, +Y up.
    parents:   (J,) int64, root = -1, every parent index smaller than its child's.
    names:     J unique joint names.
    kinds:     J JointKind values.
    orientations: optional (J, 4) float64 world rotation of each joint frame at bind, quaternion xyzw;
               None means every joint frame is world-axis-aligned (our predicted skeletons). Kept for
               studio rigs re-skinned in "keep" mode so their bind pose survives export.
    file_order:   optional (J,) int64 position of each joint in the uploaded skin's `joints` list.
    file_parents: optional (J,) int64 each joint's parent in the upload (an index here, -1 for a root there):
               it differs from `parents` only at the upload's extra roots, which this tree hangs from its root.
               Both None for predicted skeletons; kept for studio rigs in "keep" mode so the exported skin
               lists the joints in the upload's order under the upload's hierarchy.
    """

    positions: np.ndarray
    parents: np.ndarray
    names: list[str]
    kinds: list[JointKind] = field(default_factory=list)
    orientations: np.ndarray | None = None
    file_order: np.ndarray | None = None
    file_parents: np.ndarray | None = None

    def __post_init__(self) -> None:
        self.positions = np.asarray(self.positions, dtype=np.float64).reshape(-1, 3)
        self.parents = np.asarray(self.parents, dtype=np.int64).reshape(-1)
        self.names = [str(n) for n in self.names]
        if not self.kinds:
            self.kinds = [JointKind.FREE] * len(self.names)
        self.kinds = [JointKind(k) for k in self.kinds]
        if self.orientations is not None:
            self.orientations = np.asarray(self.orientations, dtype=np.float64).reshape(-1, 4)
        if self.file_order is not None:
            self.file_order = np.asarray(self.file_order, dtype=np.int64).reshape(-1)
        if self.file_parents is not None:
            self.file_parents = np.asarray(self.file_parents, dtype=np.int64).reshape(-1)

    @property
    def num_joints(self) -> int:
        return int(self.positions.shape[0])

    def validate(self) -> Skeleton:
        """Raise InvalidInput unless this is one finite, acyclic, rooted tree with unique names."""
        j = self.num_joints
        if j == 0:
            raise InvalidInput("skeleton has no joints", field="skeleton")
        if self.parents.shape != (j,) or len(self.names) != j or len(self.kinds) != j:
            raise InvalidInput("skeleton arrays disagree in length", field="skeleton")
        if not np.all(np.isfinite(self.positions)):
            raise InvalidInput("skeleton has non-finite joint positions", field="skeleton")
        roots = np.flatnonzero(self.parents < 0)
        if len(roots) != 1 or roots[0] != 0:
            raise InvalidInput(f"skeleton must have exactly one root at index 0, found {roots.tolist()}", field="skeleton")
        if np.any(self.parents[1:] >= np.arange(1, j)) or np.any(self.parents[1:] < 0):
            raise InvalidInput("skeleton parents must come before their children (acyclic, ordered)", field="skeleton")
        if len(set(self.names)) != j:
            raise InvalidInput("skeleton joint names are not unique", field="skeleton")
        if (self.file_order is None) != (self.file_parents is None):
            raise InvalidInput("skeleton file_order and file_parents come together", field="skeleton")
        if self.file_order is not None and self.file_parents is not None:  # both or neither, checked above
            if sorted(self.file_order.tolist()) != list(range(j)) or self.file_parents.shape != (j,):
                raise InvalidInput("skeleton file_order is not a permutation of its joints", field="skeleton")
            parents_first_order(self.file_parents)  # in range and acyclic
        return self

    def children(self) -> list[list[int]]:
        """Child indices of every joint, in index order."""
        out: list[list[int]] = [[] for _ in range(self.num_joints)]
        for c, p in enumerate(self.parents):
            if p >= 0:
                out[int(p)].append(c)
        return out

    def bones(self) -> np.ndarray:
        """(B, 2) int64 (parent, child) index pairs, one per non-root joint."""
        child = np.flatnonzero(self.parents >= 0)
        return np.stack([self.parents[child], child], axis=1)

    def reordered(self, order: np.ndarray) -> Skeleton:
        """The same tree with joints in `order` (a permutation where parents precede children)."""
        order = np.asarray(order, dtype=np.int64)
        inverse = np.empty_like(order)
        inverse[order] = np.arange(len(order))
        parents = np.where(self.parents[order] >= 0, inverse[np.maximum(self.parents[order], 0)], -1)
        orient = None if self.orientations is None else self.orientations[order]
        file_order = file_parents = None
        if self.file_order is not None and self.file_parents is not None:
            file_order = self.file_order[order]
            file_parents = np.where(self.file_parents[order] >= 0, inverse[np.maximum(self.file_parents[order], 0)], -1)
        return Skeleton(self.positions[order], parents, [self.names[i] for i in order], [self.kinds[i] for i in order],
                        orient, file_order, file_parents)

    def with_helpers(self, helpers: np.ndarray) -> Skeleton:
        """The same tree with the joints where (J,) bool `helpers` is set marked JointKind.HELPER (no bone to skin to)."""
        return replace(self, kinds=[JointKind.HELPER if h else kind for kind, h in zip(self.kinds, helpers, strict=True)])

    def without(self, drop: np.ndarray) -> tuple[Skeleton, np.ndarray]:
        """(the tree of the joints not in `drop`, their indices here). drop: (J,) bool, never the root. Each kept
        joint hangs from its nearest kept ancestor, so the bones it makes with its kept children remain."""
        drop = np.asarray(drop, bool)
        if drop[0]:
            raise InvalidInput(f"the root joint {self.names[0]!r} cannot be left out", field="skeleton")
        kept = np.flatnonzero(~drop)
        index = np.full(self.num_joints, -1, dtype=np.int64)
        index[kept] = np.arange(len(kept))
        parents = []
        for j in kept:
            p = int(self.parents[j])
            while p >= 0 and drop[p]:
                p = int(self.parents[p])
            parents.append(index[p] if p >= 0 else -1)
        orient = None if self.orientations is None else self.orientations[kept]
        sub = Skeleton(self.positions[kept], np.asarray(parents), [self.names[i] for i in kept], [self.kinds[i] for i in kept], orient)
        return sub, kept

    def under_root(self, position: np.ndarray, name: str, kind: JointKind) -> Skeleton:
        """The tree hung from one more joint at `position`, the new root (index 0; its frame world-aligned). The
        upload's file layout (file_order, file_parents) does not carry over: for predicted trees and weight solves."""
        orient = None if self.orientations is None else np.vstack([[0.0, 0.0, 0.0, 1.0], self.orientations])
        return Skeleton(np.vstack([np.asarray(position, np.float64).reshape(1, 3), self.positions]),
                        np.r_[-1, np.maximum(self.parents + 1, 0)], [name, *self.names], [kind, *self.kinds], orient)

    def root_has_one_child(self) -> bool:
        """Whether the tree has one root and the root holds it by one child, joint 1 (what `below_root` needs)."""
        return self.num_joints > 1 and self.children()[0] == [1] and np.count_nonzero(self.parents < 0) == 1

    def below_root(self) -> Skeleton:
        """The tree without its root, whose one child becomes the root (the inverse of `under_root`)."""
        if not self.root_has_one_child():
            raise InvalidInput(f"the root joint {self.names[0]!r} does not hold the tree by one child", field="skeleton")
        orient = None if self.orientations is None else self.orientations[1:]
        return Skeleton(self.positions[1:], np.maximum(self.parents[1:] - 1, -1), self.names[1:], self.kinds[1:], orient)

    def to_dict(self) -> dict:
        """JSON-ready form (positions as lists)."""
        return {
            "names": list(self.names),
            "parents": self.parents.tolist(),
            "positions": self.positions.round(6).tolist(),
            "kinds": [k.value for k in self.kinds],
            "orientations": None if self.orientations is None else self.orientations.round(8).tolist(),
            "file_order": None if self.file_order is None else self.file_order.tolist(),
            "file_parents": None if self.file_parents is None else self.file_parents.tolist(),
        }

    @classmethod
    def from_dict(cls, data: dict) -> Skeleton:
        """Inverse of to_dict; validates."""
        orient, file_order, file_parents = (data.get(k) for k in ("orientations", "file_order", "file_parents"))
        return cls(
            np.asarray(data["positions"]), np.asarray(data["parents"]), data["names"], data.get("kinds") or [],
            None if orient is None else np.asarray(orient),
            None if file_order is None else np.asarray(file_order),
            None if file_parents is None else np.asarray(file_parents),
        ).validate()

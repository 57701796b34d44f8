"""A skeleton's body plan read from its tree and rest positions: spine, neck, head, tails and paired limbs.

The mid-plane is the vertical plane that mirrors the joints best (across x or z, through the root or the joints'
median). The spine runs from the root to the head: the mid-plane leaf whose path carries the most side branches
(arms, front legs, wings), the highest on a tie. Joints on that path up to the last side branch are the spine, the rest
the neck and head. Every other branch is a limb, named by what it does: a `leg` reaches the floor, a `wing`
is long (≥ 0.45 of the skeleton's size), else an `arm` (or a `fin` on a body with no legs); on the mid-plane
it is a `tail` (an `jaw` off the head); off the head it is an `ear`. Pairs are told apart by side (L/R: the
character's left is up × forward, forward being from the root towards the head, glTF's +Z when the head is
right above the root) and along the spine (`front`/`back`, or 1, 2, 3 from the front). A limb's joints are
numbered along its longest path; branches off it are `digit1`, `digit2`...
Positions: (J, 3) metres, +Y up, as in simcore.skeleton.types.Skeleton.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from simcore.skeleton.types import Skeleton

CENTRAL_FRACTION = 0.03  # a branch whose joints average within this share of the size from the mid-plane is central
FLOOR_FRACTION = 0.15  # a leg's lowest joint is within this share of the height from the lowest joint
WING_FRACTION = 0.45  # a side limb at least this long (share of the skeleton's size) is a wing


@dataclass
class Limb:
    """One branch off the spine, head or another limb.

    kind: leg | arm | wing | fin | ear | tail | jaw | digit. side: "L", "R" or None (on the mid-plane).
    path: its longest path of joints, root-ward first. attach: the joint it hangs from. prefix: its name stem.
    """

    kind: str
    side: str | None
    path: list[int]
    attach: int
    prefix: str = ""


@dataclass
class BodyPlan:
    """names: a descriptive name per joint. spine: root-ward first, root excluded. neck: between spine and head."""

    names: list[str]
    spine: list[int]
    neck: list[int]
    head: int | None
    limbs: list[Limb] = field(default_factory=list)


def _children(parents: np.ndarray) -> list[list[int]]:
    out: list[list[int]] = [[] for _ in parents]
    for j, p in enumerate(parents):
        if p >= 0:
            out[int(p)].append(j)
    return out


def _subtrees(children: list[list[int]]) -> list[list[int]]:
    """Every joint's subtree (itself first); parents precede children in Skeleton order."""
    out = [[j] for j in range(len(children))]
    for j in reversed(range(len(children))):
        for c in children[j]:
            out[j] += out[c]
    return out


def _mid_plane(positions: np.ndarray) -> tuple[int, float]:
    """(axis, offset): the vertical plane across which the joints mirror best, relative to their spread along its
    normal (a flat rig mirrors across its thickness trivially). The normal is x (0) or z (2); the plane passes
    through the root or through the joints' median, whichever mirrors them better (a rig read off motion puts
    its root where bones turn, which may be off the body's mid-plane)."""
    best: tuple[float, int, float] | None = None
    for axis in (0, 2):
        for centre in (float(positions[0, axis]), float(np.median(positions[:, axis]))):
            mirrored = positions.copy()
            mirrored[:, axis] = 2 * centre - positions[:, axis]
            d = np.linalg.norm(positions[:, None] - mirrored[None], axis=-1)
            score = d.min(axis=1).mean() / (np.ptp(positions[:, axis]) + 1e-9)
            if best is None or score < best[0] - 1e-9:
                best = (score, axis, centre)
    assert best is not None
    return best[1], best[2]


def _longest_path(start: int, children: list[list[int]], subtrees: list[list[int]]) -> list[int]:
    path = [start]
    while children[path[-1]]:
        path.append(max(children[path[-1]], key=lambda c: len(subtrees[c])))
    return path


class _Reader:
    """Reads one skeleton's plan (see the module docstring)."""

    def __init__(self, skeleton: Skeleton):
        self.pos, self.parents = skeleton.positions, skeleton.parents
        self.children = _children(self.parents)
        self.subtrees = _subtrees(self.children)
        self.size = max(float(np.ptp(self.pos, axis=0).max()), 1e-9)
        self.height = max(float(np.ptp(self.pos[:, 1])), 1e-9)
        self.axis, centre = _mid_plane(self.pos)
        self.offset = self.pos[:, self.axis] - centre

    def lean(self, j: int) -> float:
        """Mean signed distance of j's subtree from the mid-plane."""
        return float(self.offset[self.subtrees[j]].mean())

    def is_side(self, j: int) -> bool:
        return abs(self.lean(j)) >= CENTRAL_FRACTION * self.size

    def side_branches(self, j: int, path: set[int]) -> int:
        return sum(1 for c in self.children[j] if c not in path and self.is_side(c))

    def spine_path(self) -> list[int]:
        leaves = [j for j in range(len(self.parents)) if not self.children[j] and not self.is_side(j)] or [0]
        best, key = [0], None
        for leaf in leaves:
            path = [leaf]
            while self.parents[path[-1]] >= 0:
                path.append(int(self.parents[path[-1]]))
            path.reverse()
            members = set(path)
            score = (sum(self.side_branches(j, members) > 0 for j in path[1:]), float(self.pos[leaf, 1]), len(path))
            if key is None or score > key:
                best, key = path, score
        return best

    def reaches_floor(self, j: int) -> bool:
        lowest = float(self.pos[self.subtrees[j], 1].min())
        floor = float(self.pos[:, 1].min())
        return lowest <= floor + FLOOR_FRACTION * self.height and lowest < self.pos[self.parents[j], 1] - 0.1 * self.height

    def length(self, path: list[int]) -> float:
        pts = self.pos[[int(self.parents[path[0]])] + path]
        return float(np.linalg.norm(np.diff(pts, axis=0), axis=1).sum())


def _group_words(attach_rank: dict[int, int]) -> dict[int, str]:
    """Path index of each attachment → '' (one group), 'front'/'back' (two) or '1', '2'... (front first)."""
    ranks = sorted(set(attach_rank.values()), reverse=True)
    if len(ranks) == 1:
        return {ranks[0]: ""}
    if len(ranks) == 2:
        return {ranks[0]: "front", ranks[1]: "back"}
    return {r: str(k + 1) for k, r in enumerate(ranks)}


def _forward_sign(r: _Reader, head: int, limbs: list[Limb]) -> float:
    """+1 or -1: which way along the forward axis the body faces (head ahead of the root, else the feet's
    toes, else glTF's +Z / +X)."""
    forward_axis = 2 if r.axis == 0 else 0
    d = r.pos[head, forward_axis] - r.pos[0, forward_axis]
    if abs(d) > 0.1 * r.size:
        return float(np.sign(d))
    toes = [r.pos[limb.path[-1], forward_axis] - r.pos[limb.path[-2], forward_axis]
            for limb in limbs if limb.kind == "leg" and len(limb.path) >= 3]
    if toes and abs(np.mean(toes)) > 0.02 * r.size:
        return float(np.sign(np.mean(toes)))
    return 1.0


def _classify(r: _Reader, limbs: list[Limb], head_chain: set[int]) -> None:
    legs = {id(limb) for limb in limbs if limb.side and limb.attach not in head_chain and r.reaches_floor(limb.path[0])}
    for limb in limbs:
        if limb.attach in head_chain:
            limb.kind = "ear" if limb.side else "jaw"
        elif not limb.side:
            limb.kind = "tail"
        elif id(limb) in legs:
            limb.kind = "leg"
        elif r.length(limb.path) >= WING_FRACTION * r.size:
            limb.kind = "wing"
        else:
            limb.kind = "arm" if legs else "fin"


def _prefixes(limbs: list[Limb], rank: dict[int, int]) -> None:
    for kind in {limb.kind for limb in limbs}:
        same = [limb for limb in limbs if limb.kind == kind]
        words = _group_words({id(limb): rank[limb.attach] for limb in same})
        for limb in same:
            limb.prefix = "_".join(w for w in (kind, words[rank[limb.attach]], limb.side) if w)
    count: dict[str, int] = {}
    for limb in limbs:  # two tails off one joint: tail, tail_2
        count[limb.prefix] = count.get(limb.prefix, 0) + 1
        if count[limb.prefix] > 1:
            limb.prefix = f"{limb.prefix}_{count[limb.prefix]}"


def _plan(skeleton: Skeleton) -> BodyPlan:
    """The plan with names that may repeat (see body_plan)."""
    r = _Reader(skeleton)
    path = r.spine_path()
    members = set(path)
    sides = [k for k in range(1, len(path)) if r.side_branches(path[k], members)]
    last = sides[-1] if sides else (len(path) - 2 if len(path) > 2 else 0)
    spine, rest = path[1:last + 1], path[last + 1:]
    head = rest[-1] if rest else None
    neck = rest[:-1]
    limbs = [Limb("", "side" if r.is_side(c) else None, _longest_path(c, r.children, r.subtrees), j)
             for j in path for c in r.children[j] if c not in members]
    _classify(r, limbs, set(rest))
    left = _forward_sign(r, head if head is not None else path[-1], limbs) * (1.0 if r.axis == 0 else -1.0)
    for limb in limbs:  # the character's left is up x forward: +Z forward → +X, +X forward → -Z
        if limb.side:
            limb.side = "L" if r.lean(limb.path[0]) * left > 0 else "R"
    _prefixes(limbs, {j: k for k, j in enumerate(path)})

    names = [""] * len(r.parents)
    names[0] = "hips" if any(limb.kind == "leg" and limb.attach == 0 for limb in limbs) else "root"
    for k, j in enumerate(spine):
        names[j] = f"spine_{k + 1:02d}"
    for k, j in enumerate(neck):
        names[j] = "neck" if len(neck) == 1 else f"neck_{k + 1:02d}"
    if head is not None:
        names[head] = "head"
    queue = list(limbs)
    while queue:
        limb = queue.pop(0)
        for k, j in enumerate(limb.path):
            names[j] = f"{limb.prefix}_{k + 1:02d}"
        on_path, digit = set(limb.path), 0
        for j in limb.path:
            for c in r.children[j]:
                if c not in on_path:
                    digit += 1
                    path = _longest_path(c, r.children, r.subtrees)
                    sub = Limb("digit", limb.side, path, j, f"{limb.prefix}_digit{digit}")
                    limbs.append(sub)
                    queue.append(sub)
    return BodyPlan(names, spine, neck, head, limbs)


def body_plan(skeleton: Skeleton) -> BodyPlan:
    """Read the body plan of `skeleton` and give every joint a descriptive, unique name."""
    plan = _plan(skeleton)
    plan.names = unique_names(plan.names)
    return plan


def unique_names(names: list[str]) -> list[str]:
    """`names` with repeats suffixed `_2`, `_3`... (the first keeps its name)."""
    seen: set[str] = set()
    out = []
    for name in names:
        candidate, k = name, 2
        while candidate in seen:
            candidate, k = f"{name}_{k}", k + 1
        seen.add(candidate)
        out.append(candidate)
    return out

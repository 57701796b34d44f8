"""Skeletons for tokenizer and grammar tests: seeded random trees (with template blocks and spring chains)
and the used-joint skeletons of the rigged dev assets."""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path

import numpy as np

from simcore.errors import InvalidInput
from simcore.io.gltf_document import GltfDocument
from simcore.io.gltf_rig import read_rigged_asset, used_joints
from simcore.skeleton.mixamo import BODY_JOINTS, BODY_PARENTS, HAND_JOINTS, HAND_PARENTS, full_name
from simcore.skeleton.types import JointKind, Skeleton, is_at_or_below
from simcore.skeleton.vocab import quantize


def distinct_bin_positions(rng: np.random.Generator, count: int) -> np.ndarray:
    """(count, 3) points in [-0.98, 0.98]^3 whose coordinate bins are pairwise distinct (no decoding ties)."""
    out: list[np.ndarray] = []
    seen: set[tuple[int, ...]] = set()
    while len(out) < count:
        p = rng.uniform(-0.98, 0.98, 3)
        key = tuple(quantize(p).tolist())
        if key not in seen:
            seen.add(key)
            out.append(p)
    return np.asarray(out).reshape(-1, 3)


def random_tree(rng: np.random.Generator, joints: int, *, template: str = "none", spring_roots: int = 0) -> Skeleton:
    """A random tree in the unit cube (normalisation = identity).

    template: "none" | "body" | "hand" (body + fingers) first, then `joints` free joints attached anywhere;
    spring_roots: that many free non-root joints become SPRING together with their descendants.
    """
    names: list[str] = []
    parents: list[int] = []
    kinds: list[JointKind] = []
    templates: dict[str, list[tuple[tuple[str, ...], Mapping[str, str | None], JointKind]]] = {
        "none": [], "body": [(BODY_JOINTS, BODY_PARENTS, JointKind.BODY)],
        "hand": [(BODY_JOINTS, BODY_PARENTS, JointKind.BODY), (HAND_JOINTS, HAND_PARENTS, JointKind.HAND)]}
    blocks = templates[template]
    for block, block_parents, kind in blocks:
        for name in block:
            parent = block_parents[name]
            parents.append(-1 if parent is None else names.index(full_name(parent)))
            names.append(full_name(name))
            kinds.append(kind)
    for _ in range(joints):
        n = len(names)
        parents.append(-1 if n == 0 else int(rng.integers(0, n)))
        names.append(f"free_{n}")
        kinds.append(JointKind.FREE)
    parents_arr = np.asarray(parents)
    first_free = len(names) - joints
    candidates = np.arange(max(first_free, 1), len(names))
    roots: np.ndarray | list[int] = rng.choice(candidates, size=min(spring_roots, len(candidates)), replace=False) if len(candidates) else []
    for root in roots:
        for j in range(int(root), len(names)):
            if is_at_or_below(parents_arr, j, int(root)):
                kinds[j] = JointKind.SPRING
    positions = distinct_bin_positions(rng, len(names))
    return Skeleton(positions, parents_arr, names, kinds).validate()


MAX_TOKENIZED_JOINTS = 256  # the learned models' bone limit; larger rigs get a clear too-many-tokens error


def dev_skeletons(dev_assets: Path, max_joints: int | None = None) -> list[tuple[str, Skeleton, np.ndarray]]:
    """(name, used-joint skeleton, mesh vertices) of every rigged dev asset our reader accepts, leaving out
    skeletons with more than `max_joints` used joints (a file of hundreds of characters) when it is given."""
    out = []
    for path in sorted(dev_assets.glob("*.gl*")):
        try:
            asset = read_rigged_asset(GltfDocument.from_bytes(path.read_bytes()))
        except InvalidInput:
            continue  # meshseq_* carry no skin
        keep = np.flatnonzero(used_joints(asset.skeleton, asset.weights))
        if max_joints is not None and len(keep) > max_joints:
            continue
        remap = -np.ones(asset.skeleton.num_joints, np.int64)
        remap[keep] = np.arange(len(keep))
        sk = asset.skeleton
        parents = np.where(sk.parents[keep] >= 0, remap[np.maximum(sk.parents[keep], 0)], -1)
        out.append((path.stem, Skeleton(sk.positions[keep], parents, [sk.names[i] for i in keep]).validate(), asset.vertices))
    return out

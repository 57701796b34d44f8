"""Skeleton tree tokenizer over UniRig's released 267-token vocabulary (paper §5.1, Algorithm 1).

Axis convention: the token frame is z-up like UniRig's (Blender's). Our data is glTF +Y up, so at this
boundary model (x, y, z) = ours (x, -z, y), a +90° rotation about X (Blender's glTF import); our +Z
(glTF front) becomes model -Y. Coordinates are written in model (x, y, z) order.

Normalisation: skeleton positions are mapped into [-1, 1]^3 by a `Normalization` (centre, scale),
normally the mesh's bounding-box centre and longest half-side (`Normalization.from_points`).

Sequence (see `simcore.skeleton.grammar` for the full language):
  <bos> <cls> [<part:body> 22 joints [<part:hand> 30 joints]] free joints (<spring> spring joints)* <eos>
- Template blocks are used when the skeleton contains the Mixamo body (and finger) joints by name with
  the template's parents and Hips as the root; their coordinates follow the template order, no parents.
- Every other joint is written in DFS pre-order, children sorted by their own model-frame position in
  (z, x, y) order, ascending, compared by bin then by exact value then by index (UniRig's release sorted
  by the parent's head by accident; this is the intent). A joint whose parent is the joint written just
  before costs 3 tokens, otherwise `<branch> px py pz x y z`.
- Spring chains: each maximal subtree of SPRING-kind joints (with all its descendants) forms one section.
  A SPRING root joint is written as a free joint (a chain needs an earlier joint to hang off).
De-tokenisation: a branch's parent is the earlier joint nearest to the decoded parent position; exact
ties (two joints in one bin) go to the ancestors of the last written joint, then to the earliest, which
is the true parent whenever the DFS branches back up its current path. Joints are never merged (UniRig
merges close joints; duplicated joints in real rigs would lose topology). Names: template names for
template joints, `joint_N` (N = decoded index) otherwise.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from simcore.errors import InvalidInput
from simcore.skeleton.grammar import SkeletonGrammar
from simcore.skeleton.mixamo import BODY_JOINTS, BODY_PARENTS, HAND_JOINTS, HAND_PARENTS, bare_name, full_name
from simcore.skeleton.types import JointKind, Skeleton
from simcore.skeleton.vocab import (
    BOS,
    BRANCH,
    CLASS_TOKENS,
    EOS,
    PAD,
    PART_BODY,
    PART_HAND,
    SPRING,
    VOCAB_SIZE,
    dequantize,
    quantize,
)

_TO_MODEL = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]])  # model = _TO_MODEL @ ours


@dataclass(frozen=True)
class Normalization:
    """Affine map of world points into the token cube: unit = (world - center) / scale.

    center: (3,) float64 metres; scale: metres per unit (> 0).
    """

    center: np.ndarray
    scale: float

    @classmethod
    def from_points(cls, points: np.ndarray) -> Normalization:
        """Bounding-box centre and longest half-side of `points` (V, 3) (mesh vertices, optionally joints)."""
        p = np.asarray(points, dtype=np.float64).reshape(-1, 3)
        if len(p) == 0 or not np.all(np.isfinite(p)):
            raise InvalidInput("normalisation needs finite points", code="invalid_mesh", field="mesh")
        lo, hi = p.min(axis=0), p.max(axis=0)
        return cls((lo + hi) / 2.0, max(float((hi - lo).max()) / 2.0, 1e-9))

    def to_unit(self, world: np.ndarray) -> np.ndarray:
        """(N, 3) world metres → (N, 3) normalised, same axes."""
        return (np.asarray(world, dtype=np.float64) - self.center) / self.scale

    def to_world(self, unit: np.ndarray) -> np.ndarray:
        """(N, 3) normalised → (N, 3) world metres."""
        return np.asarray(unit, dtype=np.float64) * self.scale + self.center


@dataclass(frozen=True)
class TokenPlan:
    """How a skeleton is written: the joint order and the per-joint markers (all arrays aligned with `order`).

    order:   (J,) int64 original joint indices in token order (parents before children).
    branch:  (J,) bool joint is written with `<branch>` + parent coordinates.
    marker:  (J,) int64 token written before the joint (PART_BODY, PART_HAND, SPRING) or -1.
    kinds:   J JointKind the sequence gives each joint (template, spring section or free).
    """

    order: np.ndarray
    branch: np.ndarray
    marker: np.ndarray
    kinds: list[JointKind]

    @property
    def num_markers(self) -> int:
        return int((self.marker >= 0).sum())

    @property
    def num_branches(self) -> int:
        return int(self.branch.sum())


def _template_matches(skeleton: Skeleton, names: tuple[str, ...], parents: dict, index: dict[str, int]) -> bool:
    for name in names:
        if name not in index:
            return False
        parent = parents[name]
        actual = skeleton.parents[index[name]]
        if (parent is None and actual != -1) or (parent is not None and actual != index.get(parent, -2)):
            return False
    return True


class SkeletonTokenizer:
    """Encode a Skeleton to UniRig token ids and back. Stateless; see the module docstring for the format."""

    vocab_size = VOCAB_SIZE

    def __init__(self, max_length: int | None = None) -> None:
        self.grammar = SkeletonGrammar() if max_length is None else SkeletonGrammar(max_length=max_length)

    # ----- the plan -------------------------------------------------------------------------------
    @staticmethod
    def model_frame(points: np.ndarray) -> np.ndarray:
        """(N, 3) ours (+Y up) → (N, 3) model frame (+Z up): (x, -z, y)."""
        return np.asarray(points, dtype=np.float64) @ _TO_MODEL.T

    @staticmethod
    def from_model_frame(points: np.ndarray) -> np.ndarray:
        """(N, 3) model frame → (N, 3) ours: (x, z, -y)."""
        return np.asarray(points, dtype=np.float64) @ _TO_MODEL

    def templates(self, skeleton: Skeleton) -> tuple[list[int], list[int]]:
        """Joint indices of the matched body and hand templates in template order ([] when absent)."""
        index = {bare_name(n): k for k, n in enumerate(skeleton.names)}
        if skeleton.num_joints == 0 or not _template_matches(skeleton, BODY_JOINTS, BODY_PARENTS, index):
            return [], []
        body = [index[n] for n in BODY_JOINTS]
        hand = [index[n] for n in HAND_JOINTS] if _template_matches(skeleton, HAND_JOINTS, HAND_PARENTS, index) else []
        return body, hand

    def plan(self, skeleton: Skeleton, norm: Normalization) -> TokenPlan:
        """The canonical joint order and markers for `skeleton` normalised by `norm`."""
        skeleton.validate()
        j = skeleton.num_joints
        unit = self.model_frame(norm.to_unit(skeleton.positions))
        bins = quantize(unit)
        # Sort key (z, x, y): by bins first so the order can be recomputed from decoded tokens.
        key = {i: (bins[i, 2], bins[i, 0], bins[i, 1], unit[i, 2], unit[i, 0], unit[i, 1], i) for i in range(j)}
        children = skeleton.children()
        body, hand = self.templates(skeleton)
        in_template = np.zeros(j, bool)
        in_template[body + hand] = True
        spring = np.zeros(j, bool)
        for c in range(1, j):  # parents precede children, so one pass closes spring sets under descent
            p = skeleton.parents[c]
            spring[c] = not in_template[c] and (skeleton.kinds[c] == JointKind.SPRING or spring[p])
        order: list[int] = []
        marker: list[int] = []

        def dfs(root: int, first_marker: int) -> None:
            stack = [root]
            while stack:
                node = stack.pop()
                order.append(node)
                marker.append(first_marker if node == root else -1)
                kids = [c for c in children[node] if not in_template[c] and spring[c] == spring[root]]
                stack.extend(sorted(kids, key=key.__getitem__, reverse=True))

        for block, token in ((body, PART_BODY), (hand, PART_HAND)):
            for k, node in enumerate(block):
                order.append(node)
                marker.append(token if k == 0 else -1)
        if not body:
            dfs(0, -1)
        else:
            free_roots = [c for c in range(j) if not in_template[c] and not spring[c] and in_template[skeleton.parents[c]]]
            for r in sorted(free_roots, key=key.__getitem__):
                dfs(r, -1)
        spring_roots = [c for c in range(j) if spring[c] and not spring[skeleton.parents[c]]]
        for r in sorted(spring_roots, key=key.__getitem__):
            dfs(r, SPRING)
        order_arr = np.asarray(order, dtype=np.int64)
        branch = np.zeros(j, bool)
        template_count = len(body) + len(hand)
        for k in range(template_count, j):
            branch[k] = k == 0 or skeleton.parents[order_arr[k]] != order_arr[k - 1]
        branch[0] = False  # the root has no parent to name
        kinds = [JointKind.SPRING if spring[n] else JointKind.FREE for n in order_arr]
        kinds[:len(body)] = [JointKind.BODY] * len(body)
        kinds[len(body):template_count] = [JointKind.HAND] * len(hand)
        return TokenPlan(order_arr, branch, np.asarray(marker, dtype=np.int64), kinds)

    # ----- encode / decode ------------------------------------------------------------------------
    def encode(self, skeleton: Skeleton, norm: Normalization, cls: str | None = None) -> np.ndarray:
        """(L,) int64 token ids for `skeleton`.

        cls: "none" | "vroid" | "mixamo" | "articulation"; None picks "mixamo" when the body template
             matches, else "none".
        Coordinates outside [-1, 1] after normalisation clip to the edge bins (normalise by mesh and joints
        together, `Normalization.from_points`, when joints may lie outside the mesh's box).
        """
        plan = self.plan(skeleton, norm)
        if cls is None:
            cls = "mixamo" if (plan.marker == PART_BODY).any() else "none"
        if cls not in CLASS_TOKENS:
            raise InvalidInput(f"unknown skeleton class {cls!r}; use one of {sorted(CLASS_TOKENS)}", code="invalid_option", field="cls")
        bins = quantize(self.model_frame(norm.to_unit(skeleton.positions)))
        tokens = [BOS, CLASS_TOKENS[cls]]
        for k, node in enumerate(plan.order):
            if plan.marker[k] >= 0:
                tokens.append(int(plan.marker[k]))
            if plan.branch[k]:
                tokens.append(BRANCH)
                tokens.extend(bins[skeleton.parents[node]].tolist())
            tokens.extend(bins[node].tolist())
        tokens.append(EOS)
        out = np.asarray(tokens, dtype=np.int64)
        if len(out) > self.grammar.max_length:
            raise InvalidInput(f"skeleton needs {len(out)} tokens, over the {self.grammar.max_length} limit",
                               code="too_many_tokens", field="skeleton")
        return out

    def decode(self, tokens: np.ndarray, norm: Normalization) -> Skeleton:
        """Rebuild a Skeleton (world positions at bin centres) from a complete token sequence.

        Raises InvalidInput(code="invalid_tokens") for a sequence the grammar does not accept.
        """
        tokens = np.asarray(tokens, dtype=np.int64).reshape(-1)
        state = self.grammar.run(tokens)
        if not state.complete:
            raise InvalidInput("token sequence ends before <eos>", code="invalid_tokens", field="tokens")
        positions: list[np.ndarray] = []
        parents: list[int] = []
        names: list[str] = []
        kinds: list[JointKind] = []
        section, template_slot = JointKind.FREE, 0
        i = 2  # after <bos> <cls>
        while tokens[i] != EOS:
            t = int(tokens[i])
            if t in (PART_BODY, PART_HAND, SPRING):
                section = {PART_BODY: JointKind.BODY, PART_HAND: JointKind.HAND, SPRING: JointKind.SPRING}[t]
                template_slot = 0
                i += 1
                continue
            if t == BRANCH:
                parent = self._nearest_earlier(positions, parents, dequantize(tokens[i + 1:i + 4]))
                i += 4
            else:
                parent = len(positions) - 1
            pos = dequantize(tokens[i:i + 3])
            i += 3
            if section in (JointKind.BODY, JointKind.HAND):
                template = BODY_JOINTS if section == JointKind.BODY else HAND_JOINTS
                tparents = BODY_PARENTS if section == JointKind.BODY else HAND_PARENTS
                name = template[template_slot]
                template_parent = tparents[name]
                parent = -1 if template_parent is None else names.index(full_name(template_parent))
                names.append(full_name(name))
                kinds.append(section)
                template_slot += 1
                if template_slot == len(template):
                    section = JointKind.FREE  # joints after a block without a marker are free
            else:
                names.append(f"joint_{len(positions)}")
                kinds.append(section)
            positions.append(pos)
            parents.append(parent)
        unit = self.from_model_frame(np.asarray(positions))
        return Skeleton(norm.to_world(unit), np.asarray(parents), names, kinds).validate()

    @staticmethod
    def _nearest_earlier(positions: list[np.ndarray], parents: list[int], target: np.ndarray) -> int:
        dist = np.linalg.norm(np.asarray(positions) - target, axis=1)
        best = np.flatnonzero(dist <= dist.min() + 1e-12)
        if len(best) > 1:
            path, node = set(), len(positions) - 1
            while node >= 0:
                path.add(node)
                node = parents[node]
            on_path = [b for b in best if b in path]
            best = np.asarray(on_path or best)
        return int(best[0])

    @staticmethod
    def read_class(tokens: np.ndarray) -> str:
        """The class name carried by a sequence's second token."""
        by_token = {v: k for k, v in CLASS_TOKENS.items()}
        if len(tokens) < 2 or int(tokens[1]) not in by_token:
            raise InvalidInput("sequence has no class token after <bos>", code="invalid_tokens", field="tokens")
        return by_token[int(tokens[1])]

    # ----- lengths --------------------------------------------------------------------------------
    @staticmethod
    def optimized_length(plan: TokenPlan) -> int:
        """Tokens of the optimised sequence without <bos>/<eos>: 3T + M + 4S + 1 (T joints, M markers,
        S branches, 1 class token)."""
        return 3 * len(plan.order) + plan.num_markers + 4 * plan.num_branches + 1

    @staticmethod
    def naive_length(plan: TokenPlan) -> int:
        """Tokens of UniRig's naive sequence without <bos>/<eos>: 6T - 3 + K (every joint with its parent's
        coordinates, the root with none; K = the class token plus the same part/spring markers)."""
        return 6 * len(plan.order) - 3 + 1 + plan.num_markers


def strip_padding(tokens: np.ndarray) -> np.ndarray:
    """Drop trailing <pad> tokens (batched sequences)."""
    tokens = np.asarray(tokens, dtype=np.int64).reshape(-1)
    end = len(tokens)
    while end and tokens[end - 1] == PAD:
        end -= 1
    return tokens[:end]


__all__ = ["Normalization", "SkeletonTokenizer", "TokenPlan", "strip_padding"]

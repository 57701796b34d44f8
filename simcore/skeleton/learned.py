"""The `learned` skeleton method: the trained skeleton-token model, decoded best-of-N (weights in the repo).

The model reads `points` surface samples of the mesh (in the token frame, glTF +Y up), then writes candidate
token sequences under the grammar (never an invalid tree): one greedy sequence per class token it was trained on
(articulation, Mixamo, the game-engine humanoid, and `none` for procedural creatures when the training data had
them) and the rest sampled. Each is placed in the solid (`refined`) and scored
without ground truth (`simcore.skeleton.candidate_score`, plus the model's log-probability); the best is kept.
`auto` takes all of them as candidates. The weights file is read once per process; a missing or corrupt file
raises ModelUnavailable with the path and the reason.
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np
import torch

from simcore.model_weights import cached_per_file, load_weights, read_metadata
from simcore.skeleton.candidate_score import LOG_PROB_WEIGHT, ShapeContext, score_candidate, shape_context
from simcore.skeleton.candidates import Candidate
from simcore.skeleton.grammar import SkeletonGrammar
from simcore.skeleton.inside import snap_inside
from simcore.skeleton.learned_model import SkeletonModelConfig, SkeletonTokenModel
from simcore.skeleton.section_centre import centre_in_section
from simcore.skeleton.shape_points import shape_points
from simcore.skeleton.symmetry import mirror_twins, symmetrize
from simcore.skeleton.token_decoding import decode_tokens
from simcore.skeleton.tokenizer import SkeletonTokenizer
from simcore.skeleton.types import Skeleton

WEIGHTS = Path(__file__).parent / "weights" / "skeleton_tokens.safetensors"
GREEDY_CLASSES = ("articulation", "mixamo", "vroid", "none")  # those the model was trained on are decoded
FIRST_CLASSES = GREEDY_CLASSES[:3]  # a file whose summary lists no classes was trained on these
TEMPERATURE = 0.8
CANDIDATES = 16  # decoded sequences per mesh: one greedy per class, the rest sampled
SECTION_LIMIT = 6.0  # voxels of the quality score's solid: decoded joints are a few coordinate bins off


@cached_per_file(maxsize=4)
def load_skeleton_model(path: Path = WEIGHTS) -> SkeletonTokenModel:
    """The model stored at `path`, in eval mode (read once per process, again if the file changes)."""
    return load_weights(path, "skeleton", "skeleton", lambda sizes: SkeletonTokenModel(SkeletonModelConfig(**sizes)))


def without_stacked(skeleton: Skeleton, shortest: float) -> Skeleton:
    """The skeleton without joints closer than `shortest` (metres) to their parent, their children hung from that
    parent: two joints in one coordinate bin make a bone with no direction to rotate about."""
    pos, j = skeleton.positions, skeleton.num_joints
    into = np.arange(j)  # the joint each joint is merged into (itself when kept)
    parents = skeleton.parents.copy()
    for k in range(1, j):  # parents come before their children
        parents[k] = into[parents[k]]
        if np.linalg.norm(pos[k] - pos[parents[k]]) < shortest:
            into[k] = parents[k]
    keep = np.flatnonzero(into == np.arange(j))
    index = np.full(j, -1)
    index[keep] = np.arange(len(keep))
    kept_parents = np.where(parents[keep] >= 0, index[np.maximum(parents[keep], 0)], -1)
    return Skeleton(pos[keep], kept_parents, [skeleton.names[k] for k in keep], [skeleton.kinds[k] for k in keep])


def refined(skeleton: Skeleton, shape: ShapeContext) -> tuple[Skeleton, dict[str, int]]:
    """The decoded skeleton placed in the solid as the geometric method places its joints: chain joints towards
    their limb's cross-section centre (by at most SECTION_LIMIT voxels: decoded joints are a few bins off), mirror
    twins averaged on a symmetric mesh, joints still outside moved to the nearest inside voxel, joints within half
    a voxel of their parent merged into it. Returns it and how many joints the last two steps moved and merged."""
    pos = centre_in_section(skeleton.positions, skeleton.parents, shape.grid, SECTION_LIMIT)
    if shape.mirror is not None:
        pos = symmetrize(pos, mirror_twins(pos, skeleton.parents, shape.grid, shape.mirror, skeleton.names))
    inside = snap_inside(shape.grid, pos)
    placed = Skeleton(inside, skeleton.parents, skeleton.names, skeleton.kinds)
    merged = without_stacked(placed, 0.5 * shape.grid.pitch)
    counts = {"moved_inside": int(np.count_nonzero(np.any(inside != pos, axis=1))),
              "stacked_merged": placed.num_joints - merged.num_joints}
    return merged, counts


def learned_candidates(vertices: np.ndarray, faces: np.ndarray, shape: ShapeContext, *, max_joints: int = 64,
                       candidates: int = CANDIDATES, seed: int = 0, model_path: Path | None = None) -> list[Candidate]:
    """`candidates` decoded skeletons for a mesh (vertices (V, 3) metres, +Y up; faces (F, 3)), each placed in the
    solid (`refined`), in the mesh's frame, with its class, joints moved and merged, and the model's log-probability.
    model_path: the weights file (None = the shipped WEIGHTS)."""
    started = time.perf_counter()
    model_path = WEIGHTS if model_path is None else model_path
    model = load_skeleton_model(model_path)
    summary = read_metadata(model_path, "skeleton", "skeleton")["summary"]
    points = int(summary["config"]["points"])
    trained = summary.get("classes", FIRST_CLASSES)
    greedy = [c for c in GREEDY_CLASSES if c in trained]
    cloud, norm = shape_points(vertices, faces, points, np.random.default_rng(seed))
    grammar = SkeletonGrammar(max_length=model.config.max_tokens, max_joints=max_joints)
    classes = greedy[:candidates]
    sampled = [greedy[k % len(greedy)] for k in range(max(0, candidates - len(classes)))]
    generator = torch.Generator().manual_seed(seed)
    tensor = torch.from_numpy(cloud)
    decoded = decode_tokens(model, tensor, classes, grammar)
    if sampled:
        decoded += decode_tokens(model, tensor, sampled, grammar, temperature=TEMPERATURE, generator=generator)
    tokenizer = SkeletonTokenizer(max_length=model.config.max_tokens)
    out = []
    for k, (cls, (tokens, log_prob)) in enumerate(zip(classes + sampled, decoded)):
        skeleton, counts = refined(tokenizer.decode(tokens, norm), shape)
        out.append(Candidate(skeleton, "learned", {"sample": k, "class": cls, "greedy": k < len(classes), **counts},
                             log_prob=log_prob))
    seconds = (time.perf_counter() - started) / max(len(out), 1)
    for c in out:
        c.seconds = seconds
    return out


def learned_skeleton(vertices: np.ndarray, faces: np.ndarray, *, max_joints: int = 64, candidates: int = CANDIDATES,
                     seed: int = 0, model_path: Path | None = None) -> tuple[Skeleton, dict]:
    """The best of `candidates` decoded skeletons (`learned_candidates`) by the quality score plus the model's own
    log-probability, and a report: each candidate's class and scores, the chosen one."""
    shape = shape_context(vertices, faces)
    pool = learned_candidates(vertices, faces, shape, max_joints=max_joints, candidates=candidates, seed=seed,
                              model_path=model_path)
    scores = [score_candidate(c.skeleton, shape) for c in pool]
    best = int(np.argmax([s.total + LOG_PROB_WEIGHT * (c.log_prob or 0.0) for c, s in zip(pool, scores)]))
    chosen = pool[best]
    report = {
        "chosen": best, "joints": chosen.skeleton.num_joints, "symmetric": shape.mirror is not None,
        "candidates": [{**c.report, "joints": c.skeleton.num_joints, "log_prob": round(c.log_prob or 0.0, 4),
                        **s.to_dict()} for c, s in zip(pool, scores)],
    }
    return chosen.skeleton, report

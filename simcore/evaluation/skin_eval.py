"""Skinning evaluation over a directory of rigged assets (`rigforge eval skin DIR`).

Skin-only: every rigged .glb/.gltf is re-skinned on its own ground-truth skeleton (bind pose, joint order
and names kept) and compared with the artist's weights: avg L1, support precision/recall, and the
deformation protocol of `simcore.metrics.skinning` (8 seeded random poses, unit-cube units). A second
deformation column poses the mesh with the asset's own animation clips where it has them (every clip,
sampled at CLIP_FPS, at most CLIP_FRAMES frames each). Peer weights (e.g. Blender's, written by
bench/peers/blender_weights.py as PEERS/<peer>/<asset>.npz) are scored the same way, row by row; a peer row
carries its solve status (`ok`, `partial`: some vertices left unweighted, `failed`: no solution; `error`: not
run), and `peer_means` sets each peer beside our methods on the same assets, with and without failed solves.

Full-pipeline rows (`pipeline=True`, method "pipeline"): our predicted skeleton + our weights. Each of our
joints is matched to the weight-bearing artist joint whose bones lie nearest to its own bone midpoints and
follows that joint's motion under the same poses; by linearity of LBS that equals scoring our weights summed
onto the matched artist joints (W_ours · C, C one-hot J_ours × J_gt), so every metric applies unchanged.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Collection, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import scipy.sparse as sp

from simcore.errors import SimcoreError
from simcore.evaluation.assets import rigged_assets
from simcore.evaluation.methods import listed_methods
from simcore.io.gltf_document import GltfDocument
from simcore.io.gltf_rig import RiggedAsset, root_holds_weight, weightless_joints
from simcore.metrics.skinning import deformation_error, support_precision_recall, unit_cube_frame, weight_l1
from simcore.skeleton.types import Skeleton
from simcore.skinning.bones import closest_on_segments, joint_segments
from simcore.skinning.learned import SHIPPED, LearnedSkinning
from simcore.skinning.predict import compute_weights

OUR_METHODS = ("auto", "learned", "geodesic", "heat")
CLIP_FPS = 10.0
CLIP_FRAMES = 60
PEER_STATUSES = ("ok", "partial", "failed")
UNWEIGHTED = 1e-6  # a vertex whose peer weights sum to no more than this has none
ROW_KEYS = ("l1", "precision", "recall", "deform_mean", "deform_p95", "clip_deform_mean", "clip_deform_p95", "seconds")


@dataclass
class SkinRow:
    """One asset skinned by one method; metrics None when the method failed (`error` says why)."""

    name: str
    category: str
    method: str
    metrics: dict[str, float | None] = field(default_factory=dict)
    chosen: str | None = None  # the method `auto` picked
    error: str | None = None
    note: str | None = None
    status: str | None = None  # a peer's solve: ok, partial, failed (PEER_STATUSES)
    unweighted_share: float | None = None  # a peer's vertices left without weight

    def to_dict(self) -> dict:
        out: dict = {"name": self.name, "category": self.category, "method": self.method}
        out.update({k: (None if v is None else round(float(v), 6)) for k, v in self.metrics.items()})
        if self.chosen:
            out["chosen"] = self.chosen
        if self.error:
            out["error"] = self.error
        if self.note:
            out["note"] = self.note
        if self.status:
            out["status"] = self.status
            out["unweighted_share"] = None if self.unweighted_share is None else round(self.unweighted_share, 4)
        return out


@dataclass
class SkinEvaluation:
    rows: list[SkinRow] = field(default_factory=list)
    skipped: dict[str, str] = field(default_factory=dict)

    def methods(self) -> list[str]:
        return list(dict.fromkeys(r.method for r in self.rows))

    def mean(self, method: str, names: set[str] | None = None) -> dict:
        """Mean of every metric over `method`'s successful rows (optionally only assets in `names`)."""
        rows = [r for r in self.rows if r.method == method and r.error is None and (names is None or r.name in names)]
        out: dict = {"assets": len(rows)}
        for key in ROW_KEYS:
            vals = [value for r in rows if (value := r.metrics.get(key)) is not None]
            out[key] = round(float(np.mean(vals)), 6) if vals else None
        return out

    def peer_means(self) -> dict[str, dict]:
        """Per peer: its solve counts and every method's mean over the assets the peer scored ("scored", failed
        and partial solves included) and over those it solved cleanly ("solved"), ours beside it on the same assets."""
        out = {}
        for peer in dict.fromkeys(r.method for r in self.rows if r.status is not None):
            rows = [r for r in self.rows if r.method == peer]
            counts = {s: sum(r.status == s for r in rows) for s in PEER_STATUSES + ("error",)}
            scored = {r.name for r in rows if r.error is None}
            solved = {r.name for r in rows if r.error is None and r.status == "ok"}
            out[peer] = {**counts, "scored": {m: self.mean(m, scored) for m in self.methods()},
                         "solved": {m: self.mean(m, solved) for m in self.methods()}}
        return out

    def to_dict(self) -> dict:
        """{"assets": [row...], "mean": {method: {...}}, "peer_means": {...}, "skipped": {...}} (the issue's JSON format)."""
        return {
            "assets": [r.to_dict() for r in self.rows],
            "mean": {m: self.mean(m) for m in self.methods()},
            "peer_means": self.peer_means(),
            "skipped": self.skipped,
        }


def clip_skin_matrices(doc: GltfDocument, asset: RiggedAsset) -> np.ndarray | None:
    """(T, J, 4, 4) skinning matrices of every clip's frames in the asset's unit-cube frame; None without clips.

    Joint matrix (glTF): world(joint, t) · inverseBindMatrix, taken back into bind space by the inverse of
    where the rest pose places the bind pose, then conjugated into the unit cube of the bind vertices.
    """
    from simcore.io.bind_pose import bind_placement
    from simcore.motion.gltf_clips import clip_time_range, sample_node_worlds

    anims = doc.items("animations")
    if not anims:
        return None
    placement_inv = np.linalg.inv(bind_placement(doc, asset))
    ibm = np.linalg.inv(asset.bind_matrices)
    centre, side = unit_cube_frame(asset.vertices)
    to_cube = np.diag([1.0 / side] * 3 + [1.0])
    to_cube[:3, 3] = -centre / side
    frames = []
    for index in range(len(anims)):
        try:  # a clip with broken keys (no keys, NaN or infinite times or values) is left out
            t0, t1, _ = clip_time_range(doc, index)
            times = np.arange(t0, t1 + 1e-9, 1.0 / CLIP_FPS)[:CLIP_FRAMES]
            world = sample_node_worlds(doc, index, times, asset.joint_nodes)  # (T, J, 4, 4)
        except SimcoreError:
            continue
        frames.append(to_cube @ placement_inv @ world @ ibm @ np.linalg.inv(to_cube))
    return np.concatenate(frames) if frames else None


def score_weights(asset: RiggedAsset, weights: sp.spmatrix | np.ndarray, clips: np.ndarray | None) -> dict[str, float | None]:
    """Every metric of predicted (V, J) weights against the asset's own."""
    precision, recall = support_precision_recall(weights, asset.weights)
    out: dict[str, float | None] = {"l1": weight_l1(weights, asset.weights), "precision": precision, "recall": recall}
    out.update(deformation_error(asset.vertices, asset.skeleton, weights, asset.weights))
    if clips is not None:
        clip = deformation_error(asset.vertices, asset.skeleton, weights, asset.weights, skin_matrices=clips)
        out["clip_deform_mean"], out["clip_deform_p95"] = clip["deform_mean"], clip["deform_p95"]
    else:
        out["clip_deform_mean"] = out["clip_deform_p95"] = None
    return out


def joint_correspondence(ours: Skeleton, gt: Skeleton, gt_weights: sp.spmatrix) -> np.ndarray:
    """(J_ours,) int64: the weight-bearing ground-truth joint whose bone segments are nearest our joint's bones."""
    mine, theirs = joint_segments(ours), joint_segments(gt)
    bearing = np.asarray(abs(gt_weights).sum(axis=0)).ravel() > 0
    keep = bearing[theirs.owner]
    if not keep.any():
        keep[:] = True
    mid = 0.5 * (mine.heads + mine.tails)
    dist = closest_on_segments(mid, theirs.heads[keep], theirs.tails[keep])[0]  # (S_ours, S_gt kept)
    owner = theirs.owner[keep]
    out = np.zeros(ours.num_joints, np.int64)
    for j in range(ours.num_joints):
        rows = dist[mine.owner == j]
        out[j] = owner[int(np.argmin(rows.min(axis=0)))]
    return out


def pipeline_weights(asset: RiggedAsset) -> tuple[sp.csr_matrix, str]:
    """Our skeleton + our weights for the bind mesh, carried onto the artist's joints: ((V, J_gt), note)."""
    from simcore.skeleton.predict import predict_skeleton

    prediction = predict_skeleton(asset.vertices, asset.faces, method="auto")
    ours = compute_weights(asset.vertices, asset.faces, prediction.skeleton, root_deforms=True)
    corr = joint_correspondence(prediction.skeleton, asset.skeleton, asset.weights)
    onto = sp.csr_matrix((np.ones(len(corr)), (np.arange(len(corr)), corr)), shape=(len(corr), asset.skeleton.num_joints))
    note = f"{prediction.skeleton.num_joints} joints ({prediction.method}), weights {ours.method}"
    return (ours.weights @ onto).tocsr(), note


@dataclass
class PeerWeights:
    """A peer's (V, J) weights for one asset and how its solve went (status: PEER_STATUSES or "error")."""

    weights: np.ndarray
    seconds: float
    status: str
    unweighted_share: float
    message: str = ""


def _peer_weights(peers: Path, name: str, shape: tuple[int, int]) -> dict[str, PeerWeights]:
    """peer name → its weights from PEERS/<peer>/<name>.npz files that match the asset's shape.

    The status is the file's own (`status`, `unweighted_share`, `messages`); a file without one (written before
    statuses were kept) is judged from its weights, so an all-zero matrix is a failed solve, never a result."""
    out = {}
    for folder in sorted(p for p in peers.iterdir() if p.is_dir()):
        path = folder / f"{name}.npz"
        if path.is_file():
            data = np.load(path, allow_pickle=False)
            if data["weights"].shape != shape:
                continue
            weights = data["weights"].astype(np.float64)
            unweighted = float(np.mean(weights.sum(axis=1) <= UNWEIGHTED)) if len(weights) else 1.0
            if "status" in data:
                status = str(data["status"])
                unweighted = float(data["unweighted_share"]) if "unweighted_share" in data else unweighted
            else:
                status = "failed" if unweighted >= 1.0 else "partial" if unweighted > 0 else "ok"
            message = str(data["messages"]) if "messages" in data else ""
            out[folder.name] = PeerWeights(weights, float(data["seconds"]), status, unweighted, message)
    return out


def _peer_row(name: str, category: str, peer: str, found: PeerWeights, asset: RiggedAsset, clips: np.ndarray | None) -> SkinRow:
    """A peer's row: scored whatever its status (failed and partial solves are what a user gets), marked with it."""
    if found.status not in PEER_STATUSES:
        return SkinRow(name, category, peer, error=f"{found.status}: {found.message or 'no weights'}"[:200], status=found.status)
    metrics = score_weights(asset, found.weights, clips)
    metrics["seconds"] = found.seconds
    what = {"ok": None, "partial": "partial", "failed": "failed (no solution)"}[found.status]
    note = what and f"{what}: {found.unweighted_share:.1%} of vertices unweighted"
    return SkinRow(name, category, peer, metrics, note=note, status=found.status, unweighted_share=found.unweighted_share)


def evaluate_skinning(
    directory: Path,
    methods: Sequence[str],
    *,
    peers: Path | None = None,
    pipeline: bool = False,
    split: str | None = None,
    names: Collection[str] | None = None,
    learned: LearnedSkinning = SHIPPED,
    on_asset: Callable[[str], None] | None = None,
) -> SkinEvaluation:
    """Skin every rigged asset in `directory` with each of our `methods` (in order, each once; "all" alone: every
    method but auto, which runs one of them); score peers found under `peers`;
    with `pipeline`, add full-pipeline rows (our skeleton and weights vs the artist's rig); with `split`, only the
    files `directory`/MANIFEST.tsv lists for that split (the corpus layout); with `names`, only those assets;
    `learned`: the learned method's (and `auto`'s) model file and prior share in place of the shipped ones."""
    methods = listed_methods(methods, OUR_METHODS, [m for m in OUR_METHODS if m != "auto"], "skinning method")
    report = SkinEvaluation()
    for name, category, doc, asset in rigged_assets(directory, report.skipped, split=split, names=names):
        if on_asset is not None:
            on_asset(name)
        try:
            clips = clip_skin_matrices(doc, asset)
        except SimcoreError:
            clips = None
        root_deforms, helpers = root_holds_weight(asset.weights), weightless_joints(asset.weights)  # as a job keeping the rig
        for method in methods:
            started = time.perf_counter()
            try:
                result = compute_weights(asset.vertices, asset.faces, asset.skeleton, method=method,  # type: ignore[arg-type]
                                         root_deforms=root_deforms, exclude=helpers,
                                         learned=learned)
                seconds = time.perf_counter() - started
                metrics = score_weights(asset, result.weights, clips)
                metrics["seconds"] = seconds
                report.rows.append(SkinRow(name, category, method, metrics, chosen=result.method if method == "auto" else None))
            except Exception as exc:  # one failing asset must not hide the others; the error is reported
                kind = exc.code if isinstance(exc, SimcoreError) else type(exc).__name__
                report.rows.append(SkinRow(name, category, method, error=f"{kind}: {exc}"[:200]))
        if pipeline:
            started = time.perf_counter()
            try:
                weights, note = pipeline_weights(asset)
                metrics = score_weights(asset, weights, clips)
                metrics["seconds"] = time.perf_counter() - started
                report.rows.append(SkinRow(name, category, "pipeline", metrics, note=note))
            except Exception as exc:  # reported per row, like the methods above
                kind = exc.code if isinstance(exc, SimcoreError) else type(exc).__name__
                report.rows.append(SkinRow(name, category, "pipeline", error=f"{kind}: {exc}"[:200]))
        if peers is not None and peers.is_dir():
            for peer, found in _peer_weights(peers, name, asset.weights.shape).items():
                report.rows.append(_peer_row(name, category, peer, found, asset, clips))
    return report

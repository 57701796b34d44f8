"""Motion evaluation: retarget each dev character's own clip onto OUR skeleton and compare the skinned result.

For every rigged .glb/.gltf in DIR that carries animation clips (loader stress tests excluded):
- reference: the artist's animation, i.e. LBS of the world-space bind mesh with the artist's weights under
  the clip sampled on the artist's skeleton (bit-exact with a glTF viewer's skinning);
- ours: the same clip retargeted from the artist's skeleton onto the predicted skeleton
  (`predict_skeleton` + `compute_weights` on the bind mesh alone), skinned with our weights;
- error: mean vertex distance per frame, in unit-cube units (divided by the rest mesh's largest extent),
  averaged over up to 60 evenly spaced frames; "artist" rows retarget onto the artist skeleton itself
  (a self-check that must be ~0).
Humanoids also get `mocap_cmu_01_01.bvh` retargeted at 30 fps and their soles' sliding speed while in
contact, for our rig and (as a reference measured in the same run) the artist's rig.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import scipy.sparse as sp

from simcore.errors import SimcoreError
from simcore.evaluation.assets import rigged_assets
from simcore.io.bvh import parse_bvh
from simcore.io.gltf_document import GltfDocument
from simcore.io.gltf_rig import RiggedAsset
from simcore.motion.clip_frame import transform_clip
from simcore.motion.gltf_clips import bind_placement, read_gltf_clip
from simcore.motion.quality import foot_sliding, skin_matrices
from simcore.motion.retarget import retarget
from simcore.motion.types import MotionClip
from simcore.options import MotionOptions
from simcore.skeleton.types import Skeleton
from simcore.skinning.lbs import linear_blend

EXCLUDED = {"recursive_skeletons"}  # a loader stress test of 84 skins, not a character
MOCAP = "mocap_cmu_01_01.bvh"
MAX_FRAMES = 60


@dataclass
class MotionRow:
    """One character × target rig."""

    name: str
    category: str
    target: str  # "ours" or "artist"
    clip: str = ""
    frames: int = 0
    joints: int = 0
    mapped: int = 0
    method: str = ""
    vertex_error: float | None = None  # mean over frames, unit-cube units
    vertex_error_p95: float | None = None  # 95th percentile over vertices and frames
    mocap_sliding: float | None = None  # heights per second
    mocap_contact: float | None = None
    seconds: float = 0.0
    error: str | None = None


@dataclass
class MotionEvaluation:
    rows: list[MotionRow] = field(default_factory=list)
    skipped: dict[str, str] = field(default_factory=dict)
    predictor: str = "predicted"

    def mean(self, target: str, key: str) -> float | None:
        vals = [getattr(r, key) for r in self.rows if r.target == target and getattr(r, key) is not None]
        return float(np.mean(vals)) if vals else None

    def to_dict(self) -> dict[str, Any]:
        return {
            "rows": [asdict(r) for r in self.rows], "skipped": self.skipped, "predictor": self.predictor,
            "mean": {t: {k: self.mean(t, k) for k in ("vertex_error", "vertex_error_p95", "mocap_sliding")} for t in ("ours", "artist")},
        }


def _load_predictors() -> tuple[Callable, Callable] | None:
    """(predict_skeleton, compute_weights) when those modules are importable, else None."""
    try:
        from simcore.skeleton.predict import predict_skeleton
        from simcore.skinning.predict import compute_weights
    except ImportError:
        return None
    return predict_skeleton, compute_weights


def world_bind(doc: GltfDocument, asset: RiggedAsset, clip: MotionClip) -> tuple[np.ndarray, MotionClip]:
    """The bind mesh where viewers show it (+Y up), in metres (cm-sized files scaled by 0.01), and the clip
    in the same frame. Returns (V, 3) float64 vertices and the scaled clip."""
    g = bind_placement(doc, asset)
    v = asset.vertices @ g[:3, :3].T + g[:3, 3]
    scale = 0.01 if np.ptp(v, axis=0).max() > 20.0 else 1.0
    if scale != 1.0:
        clip = transform_clip(clip, scale, np.eye(3), np.zeros(3))
    return v * scale, clip


def _frames(n: int) -> np.ndarray:
    return np.unique(np.linspace(0, n - 1, min(n, MAX_FRAMES)).astype(np.int64))


def _clip_error(clip: MotionClip, vertices: np.ndarray, artist_w: sp.csr_matrix, target: Skeleton,
                weights: sp.csr_matrix) -> tuple[float, float, Any]:
    """(mean, p95) per-vertex distance in unit-cube units, and the retarget result."""
    result = retarget(clip, target)
    keep = _frames(clip.animation.num_frames)
    reference = linear_blend(vertices, artist_w, skin_matrices(clip.skeleton, clip.animation)[keep])
    ours = linear_blend(vertices, weights, skin_matrices(target, result.animation)[keep])
    dist = np.linalg.norm(ours - reference, axis=2) / np.ptp(vertices, axis=0).max()
    return float(dist.mean()), float(np.percentile(dist, 95)), result


def _mocap_sliding(mocap: MotionClip | None, vertices: np.ndarray, target: Skeleton, weights: sp.csr_matrix) -> tuple[float | None, float | None]:
    if mocap is None:
        return None, None
    anim = retarget(mocap, target, MotionOptions(fps=30)).animation
    score = foot_sliding(vertices, weights, skin_matrices(target, anim), anim.fps)
    return score["sliding_heights_per_s"], score["contact_fraction"]


def evaluate_character(name: str, category: str, doc: GltfDocument, asset: RiggedAsset,
                       predictors: tuple[Callable, Callable] | None, mocap: MotionClip | None) -> list[MotionRow]:
    """Rows for the artist rig (self-check) and for our predicted rig (when predictors exist)."""
    clip = read_gltf_clip(doc, None, asset=asset)
    vertices, clip = world_bind(doc, asset, clip)
    artist_w = asset.weights
    humanoid = category == "humanoid"
    targets: list[tuple[str, Callable[[], tuple[Skeleton, sp.csr_matrix]]]] = [
        ("artist", lambda: (clip.skeleton, artist_w)),
    ]
    if predictors is not None:
        predict_skeleton, compute_weights = predictors

        def ours() -> tuple[Skeleton, sp.csr_matrix]:
            skel = predict_skeleton(vertices, asset.faces).skeleton
            return skel, compute_weights(vertices, asset.faces, skel).weights

        targets.append(("ours", ours))
    rows = []
    for label, build in targets:
        started = time.perf_counter()
        row = MotionRow(name, category, label, clip.animation.name, clip.animation.num_frames)
        try:
            skel, weights = build()
            row.vertex_error, row.vertex_error_p95, result = _clip_error(clip, vertices, artist_w, skel, weights)
            row.joints, row.mapped, row.method = skel.num_joints, len(result.mapping), result.method
            if humanoid:
                row.mocap_sliding, row.mocap_contact = _mocap_sliding(mocap, vertices, skel, weights)
        except SimcoreError as exc:
            row.error = f"{exc.code}: {exc}"
        row.seconds = round(time.perf_counter() - started, 2)
        rows.append(row)
    return rows


def evaluate_motion(directory: Path, *, use_predicted: bool = True, only: set[str] | None = None,
                    on_asset: Callable[[str], None] = lambda name: None) -> MotionEvaluation:
    """Evaluate every animated rig in `directory` (see the module docstring)."""
    directory = Path(directory)
    report = MotionEvaluation()
    predictors = _load_predictors() if use_predicted else None
    if use_predicted and predictors is None:
        report.predictor = "unavailable (simcore.skeleton.predict / simcore.skinning.predict not importable)"
    mocap_path = directory / MOCAP
    mocap = parse_bvh(mocap_path.read_bytes(), name=mocap_path.stem) if mocap_path.is_file() else None
    for name, category, doc, asset in rigged_assets(directory, report.skipped):
        if name in EXCLUDED or (only and name not in only):
            continue
        if not doc.items("animations"):
            report.skipped[name] = "no animation clips"
            continue
        on_asset(name)
        report.rows.extend(evaluate_character(name, category, doc, asset, predictors, mocap))
    return report

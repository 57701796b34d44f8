"""Motion evaluation: retarget each dev character's own clip onto OUR skeleton and compare the skinned result.

For every rigged .glb/.gltf in DIR that carries animation clips (loader stress tests excluded):
- reference: the artist's animation, i.e. LBS of the world-space bind mesh with the artist's weights under
  the clip sampled on the artist's skeleton (bit-exact with a glTF viewer's skinning);
- ours: exactly what a job does with the file and `options.motion.clip` naming the clip (`job_rig`, `job_clip`):
  the job's ingest, skeleton and skin stages with default options (or the options given, e.g. `skeleton: keep`
  to separate what the weights do from what the skeleton does), then its motion stage and the quality
  gate's motion figures, on the ingested mesh (the gate in "warn" mode; its warnings are listed per row);
- error: mean vertex distance per frame, in unit-cube units (divided by the rest mesh's largest extent),
  averaged over up to 60 evenly spaced frames; "artist" rows retarget onto the artist skeleton itself
  (a self-check that must be ~0). For our rig the job's mesh is compared with the artist's animation when the
  ingested mesh is the bind mesh moved by one similarity (same vertices; residual under BIND_MATCH of its size);
  when ingest re-posed or re-indexed it, the error is left out (the stretch figures need no correspondence).
- stretch: over every frame of the clip, the lowest 1st and highest 99th percentile of edge length / bind
  length (as the quality gate measures a job), for our rig and for the artist's rig playing the same clip;
  `stretch_ratio` is our deviation from 1 over the artist's, the worse tail, and issue 25 bounds it by
  STRETCH_BOUND on every character × clip. Every clip of a character is evaluated. The artist's deviation is
  floored (`deviation_floor`) at what a median-length edge of the mesh shows when its length changes by one
  pixel of a view that frames the whole character 1000 pixels high (PIXEL × the model size), and at least
  MIN_DEVIATION: an artist rig of rigid parts stretches nothing, and a ratio to zero would make any smooth
  skinning fail however invisible its stretch. Volume: lowest and highest enclosed volume / bind volume.
The motion stage relaxes the weights under the clip it plays (`motion/relax_weights.py`); `held_out` relaxes them
under the character's next clip instead and plays this one on them, so the figures show what the relaxation does to
a motion it never saw.
Humanoids also get `mocap_cmu_01_01.bvh` retargeted at 30 fps and their soles' sliding speed while in
contact, for our rig and (as a reference measured in the same run) the artist's rig.
"""

from __future__ import annotations

import json
import tempfile
import time
from collections.abc import Callable
from dataclasses import asdict, dataclass, field, replace
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import scipy.sparse as sp

from simcore.errors import SimcoreError
from simcore.evaluation.assets import asset_files, rigged_assets
from simcore.gate.measures import deformation_series, lbs_blocks, model_size
from simcore.geometry.laplacian import edges
from simcore.io.bind_pose import bind_placement
from simcore.io.bvh import parse_bvh
from simcore.io.gltf_document import GltfDocument
from simcore.io.gltf_rig import RiggedAsset
from simcore.motion.clip_frame import transform_clip
from simcore.motion.gltf_clips import read_gltf_clip
from simcore.motion.quality import foot_sliding, skin_matrices
from simcore.motion.retarget import retarget
from simcore.motion.types import MotionClip
from simcore.options import JobOptions, MotionOptions
from simcore.skeleton.types import Skeleton
from simcore.skinning.lbs import linear_blend

if TYPE_CHECKING:
    from simcore.pipeline import PipelineState

EXCLUDED = {"recursive_skeletons"}  # a loader stress test of 84 skins, not a character
MOCAP = "mocap_cmu_01_01.bvh"
MAX_FRAMES = 60
STRETCH_BOUND = 1.15  # our stretch deviation / the artist rig's on the same clip, at most (issue 25)
MIN_DEVIATION = 0.01  # an artist rig that stretches less than 1 % is compared with 1 %: no ratio of two near-zeros
PIXEL = 1e-3  # × the model size: one pixel of a view framing the whole character 1000 pixels high
BIND_MATCH = 1e-4  # × the model size: an ingested mesh this close to the bind mesh after a similarity is the same pose


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
    stretch_low: float | None = None  # lowest per-frame 1st percentile of edge length / bind length
    stretch_high: float | None = None  # highest per-frame 99th percentile
    artist_stretch_low: float | None = None  # the same for the artist's rig playing the same clip
    artist_stretch_high: float | None = None
    volume_low: float | None = None  # lowest per-frame enclosed volume / bind volume (None: the mesh encloses none)
    volume_high: float | None = None
    artist_volume_low: float | None = None
    artist_volume_high: float | None = None
    deviation_floor: float = MIN_DEVIATION  # the least artist deviation a ratio divides by (see the module docstring)
    warnings: list[str] = field(default_factory=list)  # the job's quality-gate warning codes for this clip (ours)
    seconds: float = 0.0
    error: str | None = None

    @property
    def stretch_ratio(self) -> float | None:
        """Our deviation from rest length over the artist rig's on the same clip, the worse of the two tails."""
        if self.stretch_low is None or self.stretch_high is None or self.artist_stretch_low is None or self.artist_stretch_high is None:
            return None
        floor = max(self.deviation_floor, MIN_DEVIATION)
        low = (1.0 - self.stretch_low) / max(1.0 - self.artist_stretch_low, floor)
        high = (self.stretch_high - 1.0) / max(self.artist_stretch_high - 1.0, floor)
        return float(max(low, high))

    @property
    def within_bound(self) -> bool | None:
        ratio = self.stretch_ratio
        return None if ratio is None else ratio <= STRETCH_BOUND


@dataclass
class MotionEvaluation:
    rows: list[MotionRow] = field(default_factory=list)
    skipped: dict[str, str] = field(default_factory=dict)
    predictor: str = "the job's stages (default options)"

    def mean(self, target: str, key: str) -> float | None:
        vals = [getattr(r, key) for r in self.rows if r.target == target and getattr(r, key) is not None]
        return float(np.mean(vals)) if vals else None

    def stretch_geomean(self) -> float | None:
        """Geometric mean of our rows' stretch ratios (each floored at 1e-6): one figure for a whole set."""
        ratios = [r.stretch_ratio for r in self.rows if r.target == "ours" and r.stretch_ratio is not None]
        return float(np.exp(np.mean(np.log(np.maximum(ratios, 1e-6))))) if ratios else None

    def bound_counts(self) -> tuple[int, int]:
        """(our character × clip rows within STRETCH_BOUND, rows measured)."""
        judged = [r.within_bound for r in self.rows if r.target == "ours" and r.within_bound is not None]
        return sum(judged), len(judged)

    def to_dict(self) -> dict[str, Any]:
        return {
            "rows": [{**asdict(r), "stretch_ratio": r.stretch_ratio, "within_bound": r.within_bound} for r in self.rows],
            "stretch_bound": STRETCH_BOUND, "within_bound": dict(zip(("within", "measured"), self.bound_counts(), strict=True)),
            "stretch_ratio_geomean": self.stretch_geomean(),
            "skipped": self.skipped, "predictor": self.predictor,
            "mean": {t: {k: self.mean(t, k) for k in ("vertex_error", "vertex_error_p95", "mocap_sliding")} for t in ("ours", "artist")},
        }


def world_bind(doc: GltfDocument, asset: RiggedAsset, clip: MotionClip) -> tuple[np.ndarray, MotionClip]:
    """The bind mesh where viewers show it (+Y up), in metres (cm-sized files scaled by 0.01), and the clip
    in the same frame. Returns (V, 3) float64 vertices and the scaled clip."""
    g = bind_placement(doc, asset)
    v = asset.vertices @ g[:3, :3].T + g[:3, 3]
    scale = 0.01 if np.ptp(v, axis=0).max() > 20.0 else 1.0
    if scale != 1.0:
        clip = transform_clip(clip, scale, np.eye(3), np.zeros(3))
    return v * scale, replace(clip, shares_bind_pose=True)  # as a job playing the mesh upload's own clip


def _frames(n: int) -> np.ndarray:
    return np.unique(np.linspace(0, n - 1, min(n, MAX_FRAMES)).astype(np.int64))


def deviation_floor(vertices: np.ndarray, faces: np.ndarray) -> float:
    """The least artist stretch deviation a ratio divides by: a median-length edge of the (V, 3), (F, 3) mesh
    changing its length by PIXEL × the model size, and at least MIN_DEVIATION."""
    e = edges(faces)
    length = np.linalg.norm(vertices[e[:, 0]] - vertices[e[:, 1]], axis=1)
    length = length[length > 0]
    if not len(length):
        return MIN_DEVIATION
    return float(max(MIN_DEVIATION, PIXEL * model_size(vertices) / np.median(length)))


Deformation = tuple[float, float, float | None, float | None]


def _deformation(vertices: np.ndarray, faces: np.ndarray, weights: sp.csr_matrix, mats: np.ndarray) -> Deformation:
    """(lowest 1st, highest 99th per-frame percentile of edge stretch, lowest, highest volume ratio) of LBS under
    mats (T, J, 4, 4); the volumes are None when the bind mesh encloses none."""
    series = deformation_series(vertices, faces, lbs_blocks(vertices, weights, mats))
    vol = series.volume_ratio
    low, high = (None, None) if vol is None or not len(vol) else (float(vol.min()), float(vol.max()))
    return float(series.stretch_low.min()), float(series.stretch_high.max()), low, high


def _vertex_error(ours: np.ndarray, reference: np.ndarray, size: float, row: MotionRow) -> None:
    """Fill the row's mean and p95 per-vertex distance (unit-cube units) of (T, V, 3) frames."""
    dist = np.linalg.norm(ours - reference, axis=2) / size
    row.vertex_error, row.vertex_error_p95 = float(dist.mean()), float(np.percentile(dist, 95))


ARTIST_FIELDS = ("artist_stretch_low", "artist_stretch_high", "artist_volume_low", "artist_volume_high", "deviation_floor")


def _self_check(clip: MotionClip, vertices: np.ndarray, faces: np.ndarray, artist_w: sp.csr_matrix, row: MotionRow) -> Any:
    """The artist's clip retargeted onto its own skeleton and skinned with its own weights: every figure of the
    row (a self-check of the retargeter), the artist rig's own stretch and volume among them; returns the
    retarget result."""
    artist_mats = skin_matrices(clip.skeleton, clip.animation)  # first: our rig's row needs these if retargeting fails
    row.artist_stretch_low, row.artist_stretch_high, row.artist_volume_low, row.artist_volume_high = _deformation(
        vertices, faces, artist_w, artist_mats)
    result = retarget(clip, clip.skeleton)
    keep = _frames(clip.animation.num_frames)
    our_mats = skin_matrices(clip.skeleton, result.animation)
    _vertex_error(linear_blend(vertices, artist_w, our_mats[keep]), linear_blend(vertices, artist_w, artist_mats[keep]),
                  float(np.ptp(vertices, axis=0).max()), row)
    row.stretch_low, row.stretch_high, row.volume_low, row.volume_high = _deformation(vertices, faces, artist_w, our_mats)
    return result


def _mocap_sliding(mocap: MotionClip | None, vertices: np.ndarray, target: Skeleton, weights: sp.csr_matrix) -> tuple[float | None, float | None]:
    if mocap is None:
        return None, None
    anim = retarget(mocap, target, MotionOptions(fps=30)).animation
    score = foot_sliding(vertices, weights, skin_matrices(target, anim), anim.fps)
    return score["sliding_heights_per_s"], score["contact_fraction"]


def job_rig(path: Path, workdir: Path, options: JobOptions | None = None) -> PipelineState:
    """The job's ingest, skeleton and skin stages on `path` with `options` (default: the defaults), the quality
    gate in warn mode."""
    from simcore.pipeline import PipelineInputs, run_pipeline

    options = (options or JobOptions()).model_copy(update={"stages": ["skeleton", "skin"], "quality_gate": "warn"})
    return run_pipeline(PipelineInputs(path, path.suffix.lstrip(".").lower()), options, workdir)


def job_clip(state: PipelineState, clip: int, relax: bool = True) -> tuple[dict[str, Any], list[str]]:
    """The job's motion stage for the upload's own clip `clip` (weights relaxed under it unless not `relax`) and
    the gate's motion check on its result: (report["quality"]["motion"], the codes of the warnings it added)."""
    from simcore.gate.checks import check_stage
    from simcore.motion import stage as motion_stage
    from simcore.pipeline import StageProgress

    options = state.options
    motion = options.motion.model_copy(update={"clip": clip, "relax_weights": relax and options.motion.relax_weights})
    state.options = options.model_copy(update={"motion": motion,
                                               "stages": [*(options.stages or []), "motion"]})
    before = len(state.report.get("warnings", []))
    try:
        motion_stage.run(state, StageProgress("motion", 0.0, 1.0, lambda stage, fraction: None, lambda: None))
        check_stage("motion", state)
    finally:
        state.options = options
    return state.report["quality"]["motion"], [w["code"] for w in state.report.get("warnings", [])[before:]]


def _bind_frame(state: PipelineState, vertices: np.ndarray) -> tuple[float, np.ndarray, np.ndarray] | None:
    """(s, R, t) taking the job's mesh onto the bind mesh `vertices` when it is that mesh moved by one similarity."""
    from simcore.geometry.similarity import similarity_fit

    assert state.mesh is not None, "job_rig ingests"
    mesh = state.mesh.vertices
    if mesh.shape != vertices.shape:
        return None
    s, r, t = similarity_fit(mesh, vertices)
    residual = np.linalg.norm(s * mesh @ r.T + t - vertices, axis=1).max()
    return (s, r, t) if residual <= BIND_MATCH * model_size(vertices) else None


def _job_rows(path: Path, clips: list[tuple[np.ndarray, MotionClip]], artist_w: sp.csr_matrix, artist_rows: list[MotionRow],
              mocap: MotionClip | None, workdir: Path, options: JobOptions | None = None,
              held_out: bool = False) -> list[MotionRow]:
    """Our rig's rows: the job's rig playing each clip (see the module docstring), beside the artist rig's figures
    that `artist_rows` (one per clip) already hold. held_out: the weights are relaxed under the character's next
    clip and then play this one unchanged (how the relaxation carries to a motion it never saw)."""
    name, category = artist_rows[0].name, artist_rows[0].category
    started = time.perf_counter()
    try:
        state = job_rig(path, workdir, options)
    except SimcoreError as exc:
        return [MotionRow(name, category, "ours", error=f"{exc.code}: {exc}")]
    assert state.mesh is not None and state.skeleton is not None and state.weights is not None, "the stages ran"
    vertices = clips[0][0]
    frame = _bind_frame(state, vertices)
    skin_weights = state.weights  # each clip is its own job: its motion stage starts from the skin stage's weights
    rows = []
    for k, (_, clip) in enumerate(clips):
        state.weights = skin_weights
        row = MotionRow(name, category, "ours", clip.animation.name, clip.animation.num_frames, state.skeleton.num_joints,
                        **{f: getattr(artist_rows[k], f) for f in ARTIST_FIELDS})
        try:
            if held_out and len(clips) < 2:
                raise SimcoreError("one clip: none other to relax the weights under", code="held_out")
            if held_out:
                job_clip(state, (k + 1) % len(clips))
            figures, row.warnings = job_clip(state, k, relax=not held_out)
            assert state.animation is not None, "the motion stage ran"
            row.mapped, row.method = len(state.report["motion"]["joint_map"]), state.report["motion"]["mapping_method"]
            row.stretch_low, row.stretch_high = figures["stretch_low"], figures["stretch_high"]
            row.volume_low, row.volume_high = figures.get("volume_low"), figures.get("volume_high")
            if frame is not None:
                s, r, t = frame
                keep = _frames(min(clip.animation.num_frames, state.animation.num_frames))
                ours = linear_blend(state.mesh.vertices, state.weights, skin_matrices(state.skeleton, state.animation)[keep])
                reference = linear_blend(vertices, artist_w, skin_matrices(clip.skeleton, clip.animation)[keep])
                _vertex_error(s * ours @ r.T + t, reference, float(np.ptp(vertices, axis=0).max()), row)
            if category == "humanoid" and k == 0:
                row.mocap_sliding, row.mocap_contact = _mocap_sliding(mocap, state.mesh.vertices, state.skeleton, skin_weights)
        except SimcoreError as exc:
            row.error = f"{exc.code}: {exc}"
        row.seconds = round(time.perf_counter() - started, 2)
        started = time.perf_counter()
        rows.append(row)
    return rows


def evaluate_character(name: str, category: str, path: Path, doc: GltfDocument, asset: RiggedAsset, use_predicted: bool,
                       mocap: MotionClip | None, workdir: Path, options: JobOptions | None = None,
                       held_out: bool = False) -> list[MotionRow]:
    """Rows for the artist rig (self-check) and, with `use_predicted`, for the job's rig (made with `options`),
    per clip."""
    clips = [world_bind(doc, asset, read_gltf_clip(doc, k, asset=asset)) for k in range(len(doc.items("animations")))]
    vertices = clips[0][0]
    floor = deviation_floor(vertices, asset.faces)
    rows = []
    started = time.perf_counter()
    for k, (_, clip) in enumerate(clips):
        row = MotionRow(name, category, "artist", clip.animation.name, clip.animation.num_frames, deviation_floor=floor)
        try:
            result = _self_check(clip, vertices, asset.faces, asset.weights, row)
            row.joints, row.mapped, row.method = clip.skeleton.num_joints, len(result.mapping), result.method
            if category == "humanoid" and k == 0:
                row.mocap_sliding, row.mocap_contact = _mocap_sliding(mocap, vertices, clip.skeleton, asset.weights)
        except SimcoreError as exc:
            row.error = f"{exc.code}: {exc}"
        row.seconds = round(time.perf_counter() - started, 2)
        started = time.perf_counter()
        rows.append(row)
    if use_predicted:
        rows.extend(_job_rows(path, clips, asset.weights, rows, mocap, workdir, options, held_out))
    return rows


def evaluate_motion(directory: Path, *, use_predicted: bool = True, only: set[str] | None = None, split: str | None = None,
                    on_asset: Callable[[str], None] = lambda name: None, options: JobOptions | None = None,
                    held_out: bool = False) -> MotionEvaluation:
    """Evaluate every animated rig in `directory` (see the module docstring); with `split`, only the files
    DIR/MANIFEST.tsv lists for that split (the training corpus layout); `options`: the job options our rig is
    made with (stages and gate mode are the eval's); `held_out`: see `_job_rows`."""
    directory = Path(directory)
    report = MotionEvaluation()
    changed = options.model_dump(mode="json", exclude_defaults=True) if options else {}
    if changed:
        report.predictor = f"the job's stages (options {json.dumps(changed, sort_keys=True)})"
    if held_out:
        report.predictor += "; weights relaxed under the character's next clip, not the one played"
    mocap_path = directory / MOCAP
    mocap = parse_bvh(mocap_path.read_bytes(), name=mocap_path.stem) if mocap_path.is_file() else None
    paths = {p.stem: p for p in asset_files(directory, split)}
    with tempfile.TemporaryDirectory(prefix="rigforge-motion-eval-") as work:
        for name, category, doc, asset in rigged_assets(directory, report.skipped, split):
            if name in EXCLUDED or (only and name not in only):
                continue
            if not doc.items("animations"):
                report.skipped[name] = "no animation clips"
                continue
            on_asset(name)
            report.rows.extend(evaluate_character(name, category, paths[name], doc, asset, use_predicted, mocap,
                                                  Path(work) / name, options, held_out))
    return report

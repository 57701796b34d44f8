"""`rigforge eval motion-rig DIR`: rigs recovered from mesh sequences, against free Dem Bones and the artist.

Sequences: DIR's mesh-sequence files (glTF morph animations, read and ingested exactly as a job reads them; no
ground-truth skeleton), and each rigged asset posed with the artist's weights by its own clip and by a seeded
random motion (simcore.evaluation.motion_sequences), whose skeleton is the ground truth. Every sequence is rigged
by `rig_from_motion` with the job's default parameters. Figures: reconstruction RMSE of the rig and of free-bone
Dem Bones at the same bone count (first frame's bounding-box diagonal), and J2J / B2B (unit-cube units,
simcore.metrics.skeleton) of the recovered skeleton, of its joints read off the motion alone (before the shape
joints of simcore.motion_rig.shape_joints), and, as a baseline, of the free bones' centres.
"""

from __future__ import annotations

import time
import zlib
from collections.abc import Callable, Iterator
from dataclasses import asdict, dataclass, field
from functools import partial
from pathlib import Path
from typing import Any

import numpy as np

from simcore.errors import SimcoreError
from simcore.evaluation.assets import asset_files, problem, rigged_assets
from simcore.evaluation.motion_sequences import PosedSequence, clip_sequence, random_sequence
from simcore.metrics.skeleton import graph_scores, skeleton_scores
from simcore.motion_rig.solve import MotionRig, MotionRigParams, rig_from_motion
from simcore.motion_rig.upload import SequenceUpload

MOTIONS = ("sequence", "clip", "random")


@dataclass
class MotionRigRow:
    """One sequence rigged from its motion. Distances as the module docstring says; None where not measured."""

    name: str
    motion: str
    frames: int = 0
    vertices: int = 0
    bones: int = 0
    shape_joints: int = 0
    sliding: int = 0
    outside: int = 0
    rmse: float | None = None
    free_rmse: float | None = None
    j2j: float | None = None
    b2b: float | None = None
    free_j2j: float | None = None
    motion_j2j: float | None = None  # the joints read off the motion alone (before shape joints are added)
    joints_truth: int | None = None
    seconds: float = 0.0
    error: str | None = None

    @property
    def ratio(self) -> float | None:
        """rig RMSE / free-bone RMSE."""
        return None if self.rmse is None or not self.free_rmse else self.rmse / self.free_rmse


@dataclass
class MotionRigEvaluation:
    rows: list[MotionRigRow] = field(default_factory=list)
    skipped: dict[str, str] = field(default_factory=dict)

    def mean(self, key: str, motion: str | None = None) -> float | None:
        values = [getattr(r, key) for r in self.rows if (motion is None or r.motion.startswith(motion))
                  and getattr(r, key) is not None]
        return float(np.mean(values)) if values else None

    def worst(self, key: str) -> float | None:
        values = [getattr(r, key) for r in self.rows if getattr(r, key) is not None]
        return float(np.max(values)) if values else None

    def to_dict(self) -> dict[str, Any]:
        rows = [{**asdict(r), "ratio": r.ratio} for r in self.rows]
        summary = {f"{key}_{kind}": self.mean(key, kind) for key in ("rmse", "free_rmse", "j2j", "b2b", "free_j2j",
                                                                        "motion_j2j")
                   for kind in MOTIONS}
        summary.update(worst_ratio=self.worst("ratio"), worst_rmse=self.worst("rmse"), worst_j2j=self.worst("j2j"))
        return {"rows": rows, "summary": summary, "skipped": self.skipped}


def _sequence_files(directory: Path) -> Iterator[tuple[str, Callable[[], tuple[np.ndarray, np.ndarray, np.ndarray, float]]]]:
    """(name, loader) of each mesh-sequence file of `directory`: the loader ingests it as a job does."""
    from simcore.motion_rig.upload import read_sequence_upload

    for path in asset_files(directory):
        data = path.read_bytes()
        fmt = "glb" if data[:4] == b"glTF" else "gltf"
        try:
            upload = read_sequence_upload(data, fmt)
        except SimcoreError:
            continue
        if upload is None:
            continue

        yield path.stem, partial(_ingested, upload)


def _ingested(upload: SequenceUpload) -> tuple[np.ndarray, np.ndarray, np.ndarray, float]:
    """The bind mesh and frames of a sequence upload, ingested as a job ingests them."""
    from simcore.ingest import ingest
    from simcore.motion_rig.upload import sequence_in_mesh_frame

    mesh = ingest(upload.mesh_data, upload.mesh_format)
    seq = sequence_in_mesh_frame(upload.sequence, mesh)
    return mesh.vertices, mesh.faces, seq.frames, seq.fps


def _free_centres(rig: MotionRig) -> np.ndarray:
    """(B, 3) weighted centres of the free bones' vertices: the skeleton-less baseline's joints."""
    return np.asarray(rig.report["free_bone_centres"])


def _score(row: MotionRigRow, rig: MotionRig, seq: PosedSequence | None, rest: np.ndarray, faces: np.ndarray) -> None:
    report = rig.report
    row.bones, row.sliding = int(report["bones"]), int(report["sliding_joints"])
    row.shape_joints, row.outside = int(report["shape_joints"]), int(report["joints_outside"])
    row.rmse, row.free_rmse = float(report["rmse"]), float(report["free_bones_rmse"])
    if seq is not None:
        scores = skeleton_scores(rig.skeleton, seq.truth, rest, faces)
        row.j2j, row.b2b, row.joints_truth = scores.j2j, scores.b2b, seq.truth.num_joints
        motion_only = rig.skeleton.without(np.arange(rig.skeleton.num_joints) >= int(report["motion_bones"]))[0]
        row.motion_j2j = skeleton_scores(motion_only, seq.truth, rest, faces).j2j
        row.free_j2j = graph_scores(_free_centres(rig), np.zeros((0, 2), np.int64), seq.truth, rest, faces).j2j


def _run(row: MotionRigRow, build: Callable[[], Built], params: MotionRigParams) -> MotionRigRow:
    started = time.perf_counter()
    try:
        rest, faces, frames, fps, seq = build()
        row.frames, row.vertices = int(frames.shape[0]), int(frames.shape[1])
        rig = rig_from_motion(rest, faces, frames, fps, params)
        _score(row, rig, seq, rest, faces)
    except (SimcoreError, ValueError, np.linalg.LinAlgError) as exc:
        row.error = problem(exc)
    row.seconds = round(time.perf_counter() - started, 2)
    return row


def evaluate_motion_rig(directory: Path, *, motions: tuple[str, ...] = MOTIONS, split: str | None = None,
                        max_frames: int = 60, only: set[str] | None = None, params: MotionRigParams | None = None,
                        on_row: Callable[[str], None] = lambda name: None) -> MotionRigEvaluation:
    """Rows for every mesh-sequence file and every rigged asset (its clip, a random motion) of `directory`."""
    params = params or MotionRigParams()
    report = MotionRigEvaluation()
    if "sequence" in motions and split is None:
        for name, load in _sequence_files(directory):
            if only and name not in only:
                continue
            on_row(name)
            report.rows.append(_run(MotionRigRow(name, "sequence"), _unposed(load), params))
    if not {"clip", "random"} & set(motions):
        return report
    for name, _category, doc, asset in rigged_assets(directory, report.skipped, split=split):
        if only and name not in only:
            continue
        builders: list[tuple[str, Callable[[], PosedSequence]]] = []
        if "clip" in motions and doc.items("animations"):
            builders.append(("clip", partial(clip_sequence, doc, asset, max_frames)))
        if "random" in motions:
            builders.append(("random", partial(random_sequence, doc, asset, max_frames, zlib.crc32(name.encode()))))
        for motion, make in builders:
            on_row(f"{name} {motion}")
            report.rows.append(_run(MotionRigRow(name, motion), _posed(make), params))
    return report


Built = tuple[np.ndarray, np.ndarray, np.ndarray, float, PosedSequence | None]


def _unposed(load: Callable[[], tuple[np.ndarray, np.ndarray, np.ndarray, float]]) -> Callable[[], Built]:
    return lambda: (*load(), None)


def _posed(make: Callable[[], PosedSequence]) -> Callable[[], Built]:
    def build() -> Built:
        seq = make()
        return seq.rest, seq.faces, seq.frames, seq.fps, seq

    return build

"""Skeleton evaluation over a directory of rigged assets (`rigforge eval skeleton DIR`).

Each file goes through exactly what a job runs: the job's ingest (units, up axis, rest pose) and its skeleton
prediction (`simcore.skeleton.stage.predict_for_job`, ground plane left out), with default options and the
given method, so a figure here is what a user gets. Ground truth = the joints of every skin in the upload
(simcore.io.gltf_rig: their union, one tree) that influence a vertex (or have a descendant that does), at the
rest pose the job sees, in the job's frame; `simcore.metrics.skeleton` scores against the ingested mesh. Files
without a skin (e.g. morph-target sequences) are listed as skipped; a file that fails to load is skipped with its
reason, never an aborted run. Categories come from DIR/MANIFEST.tsv (`name` or `file` column → `category`) when
present, else "unknown". The ground-truth skeletons' token counts (naive vs optimised UniRig tokenisation) are
reported alongside.

`all` runs the voxel baseline and `auto` once, and also scores the best candidate of each method `auto` chose
among (humanoid, geometric): the same skeletons those methods give as job options.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Collection, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from simcore.errors import InvalidInput
from simcore.evaluation.assets import asset_files, problem, read_categories
from simcore.evaluation.methods import listed_methods
from simcore.evaluation.voxel_baseline import voxel_skeleton_graph
from simcore.geometry.voxelize import JOINT_TEST_RESOLUTION, VoxelGrid, solid_voxels
from simcore.io.gltf_rig import used_joints
from simcore.metrics.skeleton import SkeletonScores, graph_scores, used_skeleton
from simcore.skeleton.tokenizer import Normalization, SkeletonTokenizer
from simcore.skeleton.types import Skeleton

if TYPE_CHECKING:
    from simcore.geometry.mesh import IngestedMesh
    from simcore.skeleton.geometric import GeometricParams
    from simcore.skeleton.predict import SkeletonPrediction

PREDICTED_METHODS = ("auto", "geometric", "humanoid", "learned")
CANDIDATE_METHODS = ("humanoid", "geometric")  # the rows `all` takes from auto's candidates
METHODS = ("voxel", *PREDICTED_METHODS)  # what `--method` names besides "all" (`resolve_methods`)
__all__ = ["AssetResult", "EvalCase", "SkeletonEvaluation", "evaluate_asset", "evaluate_directory", "load_case",
           "read_categories", "resolve_methods"]
JOINT_RATIO = (0.5, 2.0)  # a predicted joint count within this factor of the artist's is plausible
METRIC_KEYS = ("j2j", "j2b", "b2b", "joints_pred", "joints_gt", "joint_ratio", "inside", "seconds", "j2j_matched")


@dataclass
class AssetResult:
    """One asset scored with one method. `scores` is None when the method failed (`error` says why) or did
    not apply (`note` says why, e.g. the humanoid fit found no biped)."""

    name: str
    category: str
    method: str
    scores: SkeletonScores | None
    seconds: float
    error: str | None = None
    note: str | None = None

    def to_dict(self) -> dict:
        out = {"name": self.name, "category": self.category, "method": self.method, "seconds": round(self.seconds, 3)}
        if self.scores is not None:
            out.update(self.scores.to_dict())
        if self.error:
            out["error"] = self.error
        if self.note:
            out["note"] = self.note
        return out


@dataclass
class SkeletonEvaluation:
    """All rows, the skipped files (name → reason) and the ground-truth token counts."""

    results: list[AssetResult] = field(default_factory=list)
    skipped: dict[str, str] = field(default_factory=dict)
    tokens: dict[str, dict[str, int]] = field(default_factory=dict)

    def methods(self) -> list[str]:
        return list(dict.fromkeys(r.method for r in self.results))

    def mean(self, method: str, category: str | None = None) -> dict:
        """Mean of every metric (that all of them have) over the successful rows of `method` (optionally one
        category), the share of them whose joint count is within JOINT_RATIO of the artist's, and the share with a
        lower J2J than the voxel baseline on the same asset (when it ran)."""
        rows = [r.to_dict() for r in self.results
                if r.method == method and r.scores is not None and (category is None or r.category == category)]
        failed = sum(1 for r in self.results if r.method == method and r.error is not None
                     and (category is None or r.category == category))
        out: dict = {"assets": len(rows), "failed": failed}
        if not rows:
            return out
        for key in METRIC_KEYS:
            if all(row.get(key) is not None for row in rows):
                out[key] = round(float(np.mean([row[key] for row in rows])), 6)
        lo, hi = JOINT_RATIO
        out["joint_ratio_ok"] = round(float(np.mean([lo <= row["joint_ratio"] <= hi for row in rows])), 4)
        voxel = {r.name: r.scores.j2j for r in self.results if r.method == "voxel" and r.scores is not None}
        paired = [row["j2j"] < voxel[row["name"]] for row in rows if row["name"] in voxel]
        if method != "voxel" and paired:
            out["beats_voxel"] = round(float(np.mean(paired)), 4)
        return out

    def categories(self) -> list[str]:
        return sorted({r.category for r in self.results})

    def token_saving(self) -> dict:
        """Naive vs optimised token totals over the ground-truth skeletons."""
        naive = sum(t["naive"] for t in self.tokens.values())
        optimized = sum(t["optimized"] for t in self.tokens.values())
        return {"skeletons": len(self.tokens), "naive": naive, "optimized": optimized,
                "saving": round(1.0 - optimized / naive, 4) if naive else 0.0}

    def to_dict(self) -> dict:
        """The JSON report: assets, mean and by_category (per method), skipped files, token saving."""
        methods = self.methods()
        return {
            "assets": [r.to_dict() for r in self.results],
            "mean": {m: self.mean(m) for m in methods},
            "by_category": {m: {c: self.mean(m, c) for c in self.categories()} for m in methods},
            "skipped": self.skipped,
            "tokens": {"per_asset": self.tokens, **self.token_saving()},
        }


def resolve_methods(method: str | Sequence[str]) -> list[str]:
    """The methods `--method` values stand for ("all" = the voxel baseline, auto with its candidates, learned)."""
    return listed_methods(method, METHODS, ("voxel", "auto", "learned"), "method")


@dataclass
class EvalCase:
    """One uploaded file as a job sees it: the ingested mesh, its ground-plane triangles, the ground truth and
    the mesh's solid for the inside test."""

    mesh: IngestedMesh
    ground: np.ndarray
    gt: Skeleton
    grid: VoxelGrid


def load_case(path: Path) -> EvalCase:
    """Ingest `path` as a job does (default options) and read its ground truth; InvalidInput no_skin without one."""
    from simcore.ingest import ingest
    from simcore.skeleton.stage import mesh_ground

    mesh = ingest(path.read_bytes(), path.suffix.lower().lstrip("."))
    rig = mesh.source_rig
    if rig is None:
        raise InvalidInput(f"{path.name} has no skinned mesh", code="no_skin", field="mesh")
    gt = used_skeleton(rig.skeleton, used_joints(rig.skeleton, rig.weights))
    grid = solid_voxels(mesh.vertices, mesh.faces, resolution=JOINT_TEST_RESOLUTION)
    return EvalCase(mesh, mesh_ground(mesh)[1], gt, grid)


def job_prediction(case: EvalCase, method: str, max_joints: int = 64, geometric_params: GeometricParams | None = None,
                   learned_model: Path | None = None) -> SkeletonPrediction:
    """The skeleton a job with options {skeleton: method, max_joints} predicts for the case's upload (with the
    learned method's weights from `learned_model` when given)."""
    from simcore.options import JobOptions
    from simcore.skeleton.stage import predict_for_job

    options = JobOptions(skeleton=method, max_joints=max_joints)
    return predict_for_job(case.mesh, options, case.ground, geometric_params, learned_model)


def _token_counts(case: EvalCase) -> dict[str, int]:
    tokenizer = SkeletonTokenizer(max_length=1 << 20)  # counting only: no context limit
    plan = tokenizer.plan(case.gt, Normalization.from_points(np.concatenate([case.mesh.vertices, case.gt.positions])))
    return {"joints": case.gt.num_joints, "naive": tokenizer.naive_length(plan), "optimized": tokenizer.optimized_length(plan)}


def scores_of(case: EvalCase, skeleton: Skeleton) -> SkeletonScores:
    """The metrics of `skeleton` (in the job frame) against the case's ground truth."""
    return graph_scores(skeleton.positions, skeleton.bones(), case.gt, case.mesh.vertices, case.mesh.faces, grid=case.grid)


def _candidate_rows(name: str, category: str, case: EvalCase, prediction: SkeletonPrediction,
                    max_joints: int) -> list[AssetResult]:
    """One row per method of CANDIDATE_METHODS from auto's candidates: the skeleton that method gives alone (under
    the root a job adds, `stage.job_root`)."""
    from simcore.options import JobOptions
    from simcore.skeleton.stage import job_root

    pool = prediction.candidates
    rows = []
    for method in CANDIDATE_METHODS:
        members = [k for k, c in enumerate(pool) if c.method == method]
        if not members:
            rows.append(AssetResult(name, category, method, None, 0.0, note="n/a: no biped fitted"))
            continue
        skeleton = job_root(pool[members[0]].skeleton, case.mesh, case.ground, JobOptions(skeleton=method, max_joints=max_joints))[0]
        rows.append(AssetResult(name, category, method, scores_of(case, skeleton), pool[members[0]].seconds))
    return rows


def evaluate_asset(name: str, category: str, case: EvalCase, methods: list[str], max_joints: int = 64,
                   geometric_params: GeometricParams | None = None, candidate_rows: bool = False,
                   learned_model: Path | None = None) -> list[AssetResult]:
    """Score every method on one case (a failing method gives a row with its error); with `candidate_rows`, `auto`
    also gives a row per candidate method (CANDIDATE_METHODS)."""
    rows: list[AssetResult] = []
    for method in methods:
        started = time.perf_counter()
        try:
            if method == "voxel":
                joints, edges = voxel_skeleton_graph(case.mesh.vertices, case.mesh.faces)
                scores = graph_scores(joints, edges, case.gt, case.mesh.vertices, case.mesh.faces, grid=case.grid)
                rows.append(AssetResult(name, category, method, scores, time.perf_counter() - started))
                continue
            prediction = job_prediction(case, method, max_joints, geometric_params, learned_model)
            seconds = time.perf_counter() - started
            if method == "humanoid" and prediction.method != "humanoid":
                # The auto and geometric rows already cover a fallback; do not count it as humanoid.
                rows.append(AssetResult(name, category, method, None, seconds,
                                        note=f"n/a: no biped fitted ({prediction.method} instead)"))
                continue
            note = f"chose {prediction.method}" if method == "auto" else None
            rows.append(AssetResult(name, category, method, scores_of(case, prediction.skeleton), seconds, note=note))
            if method == "auto" and candidate_rows:
                rows += _candidate_rows(name, category, case, prediction, max_joints)
        except Exception as exc:  # one failing method must not hide the other rows; the error is reported
            rows.append(AssetResult(name, category, method, None, time.perf_counter() - started, error=problem(exc)[:200]))
    return rows


def evaluate_directory(directory: Path, method: str | Sequence[str] = "all", *, max_joints: int = 64, split: str | None = None,
                       on_asset: Callable[[str], None] | None = None,
                       geometric_params: GeometricParams | None = None, learned_model: Path | None = None,
                       names: Collection[str] | None = None) -> SkeletonEvaluation:
    """Evaluate every rigged .glb/.gltf in `directory` with `method` ("all", "voxel", "auto", ..., or a list of
    them, each file read once for all); with `split`,
    only the files `directory`/MANIFEST.tsv lists for that split (the corpus layout); with `names`, only those
    file stems; `learned_model`: the learned method's weights to score instead of the shipped file."""
    methods = resolve_methods(method)
    report = SkeletonEvaluation()
    categories = read_categories(directory)
    for path in asset_files(directory, split, names):
        name = path.stem
        if on_asset is not None:
            on_asset(name)
        try:
            case = load_case(path)
            tokens = _token_counts(case)
        except Exception as exc:  # an unreadable file or one without a skin is listed; the others still run
            report.skipped[name] = problem(exc)
            continue
        report.tokens[name] = tokens
        report.results.extend(evaluate_asset(name, categories.get(name, "unknown"), case, methods, max_joints,
                                             geometric_params, candidate_rows=method == "all",
                                             learned_model=learned_model))
    return report

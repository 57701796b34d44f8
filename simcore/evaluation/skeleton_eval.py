"""Skeleton evaluation over a directory of rigged assets (`rigforge eval skeleton DIR`).

For every rigged .glb/.gltf in DIR: ground truth = the used skin joints at bind pose; each method
predicts a skeleton from the bind-pose mesh alone; `simcore.metrics.skeleton` scores it. Files without
a skin (e.g. morph-target sequences) are listed as skipped. Categories come from DIR/MANIFEST.tsv
(`name` or `file` column → `category`) when present, else "unknown". The ground-truth skeletons' token
counts (naive vs optimised UniRig tokenisation) are reported alongside.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from simcore.errors import InvalidInput, SimcoreError
from simcore.evaluation.assets import problem, read_categories, rigged_assets
from simcore.evaluation.voxel_baseline import voxel_skeleton_graph
from simcore.geometry.voxelize import solid_voxels
from simcore.io.gltf_rig import RiggedAsset
from simcore.metrics.skeleton import INSIDE_RESOLUTION, SkeletonScores, graph_scores, ground_truth_skeleton
from simcore.skeleton.tokenizer import Normalization, SkeletonTokenizer

PREDICTED_METHODS = ("auto", "geometric", "humanoid")
METHODS = ("all", "voxel", *PREDICTED_METHODS, "learned")  # "all" leaves out learned: it needs the trained weights
__all__ = ["AssetResult", "SkeletonEvaluation", "evaluate_asset", "evaluate_directory", "read_categories", "resolve_methods"]
METRIC_KEYS = ("j2j", "j2b", "b2b", "joints_pred", "joints_gt", "joint_ratio", "inside", "seconds")


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
        """Mean of every metric over the successful rows of `method` (optionally one category)."""
        rows = [r.to_dict() for r in self.results
                if r.method == method and r.scores is not None and (category is None or r.category == category)]
        failed = sum(1 for r in self.results if r.method == method and r.error is not None
                     and (category is None or r.category == category))
        out: dict = {"assets": len(rows), "failed": failed}
        for key in METRIC_KEYS:
            if rows:
                out[key] = round(float(np.mean([row[key] for row in rows])), 6)
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


def resolve_methods(method: str) -> list[str]:
    """The methods a `--method` value stands for ("all" = voxel + every predicted method)."""
    if method not in METHODS:
        raise InvalidInput(f"unknown method {method!r}; use one of {', '.join(METHODS)}", code="invalid_option", field="method")
    return ["voxel", *PREDICTED_METHODS] if method == "all" else [method]


def _load_predictor() -> Callable | None:
    try:
        from simcore.skeleton.predict import predict_skeleton
    except ImportError:  # the prediction module is optional here: the voxel baseline still runs
        return None
    return predict_skeleton


def _token_counts(asset: RiggedAsset, gt) -> dict[str, int]:
    tokenizer = SkeletonTokenizer(max_length=1 << 20)  # counting only: no context limit
    plan = tokenizer.plan(gt, Normalization.from_points(np.concatenate([asset.vertices, gt.positions])))
    return {"joints": gt.num_joints, "naive": tokenizer.naive_length(plan), "optimized": tokenizer.optimized_length(plan)}


def evaluate_asset(name: str, category: str, asset: RiggedAsset, methods: list[str], max_joints: int = 64) -> list[AssetResult]:
    """Score every method on one rigged asset (a failing method gives a row with its error)."""
    gt = ground_truth_skeleton(asset)
    grid = solid_voxels(asset.vertices, asset.faces, resolution=INSIDE_RESOLUTION)
    predict = _load_predictor()
    rows: list[AssetResult] = []
    for method in methods:
        started = time.perf_counter()
        note = None
        try:
            if method == "voxel":
                joints, edges = voxel_skeleton_graph(asset.vertices, asset.faces)
            elif predict is None:
                raise InvalidInput("simcore.skeleton.predict is not available", code="method_unavailable", field="method")
            else:
                prediction = predict(asset.vertices, asset.faces, method=method, max_joints=max_joints)
                if method == "humanoid" and prediction.method != "humanoid":
                    # The auto and geometric rows already cover a fallback; do not count it as humanoid.
                    note = f"n/a: no biped fitted ({prediction.method} instead)"
                    rows.append(AssetResult(name, category, method, None, time.perf_counter() - started, note=note))
                    continue
                joints, edges = prediction.skeleton.positions, prediction.skeleton.bones()
                note = None if method != "auto" else f"chose {prediction.method}"
            seconds = time.perf_counter() - started
            scores = graph_scores(joints, edges, gt, asset.vertices, asset.faces, grid=grid)
            rows.append(AssetResult(name, category, method, scores, seconds, note=note))
        except Exception as exc:  # one failing method must not hide the other rows; the error is reported
            kind = exc.code if isinstance(exc, SimcoreError) else type(exc).__name__
            rows.append(AssetResult(name, category, method, None, time.perf_counter() - started, error=f"{kind}: {exc}"[:200]))
    return rows


def evaluate_directory(directory: Path, method: str = "all", *, max_joints: int = 64, split: str | None = None,
                       on_asset: Callable[[str], None] | None = None) -> SkeletonEvaluation:
    """Evaluate every rigged .glb/.gltf in `directory` with `method` ("all", "voxel", "auto", ...); with `split`,
    only the files `directory`/MANIFEST.tsv lists for that split (the corpus layout)."""
    methods = resolve_methods(method)
    report = SkeletonEvaluation()
    for name, category, _, asset in rigged_assets(directory, report.skipped, split=split):
        if on_asset is not None:
            on_asset(name)
        try:
            tokens = _token_counts(asset, ground_truth_skeleton(asset))
            rows = evaluate_asset(name, category, asset, methods, max_joints)
        except Exception as exc:  # an asset whose ground truth cannot be built is listed; the others still run
            report.skipped[name] = problem(exc)
            continue
        report.tokens[name] = tokens
        report.results.extend(rows)
    return report

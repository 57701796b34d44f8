"""One entry point for skeleton prediction: geometric, humanoid template, learned, or `auto` (the best candidate)."""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal

import numpy as np

from simcore.errors import InvalidInput
from simcore.geometry.parts import SurfacePart, surface_parts
from simcore.geometry.referenced import referenced_mesh
from simcore.skeleton.axes import GLTF_UP, axis
from simcore.skeleton.candidate_score import shape_context
from simcore.skeleton.candidates import Candidate, geometric_candidate, humanoid_candidate
from simcore.skeleton.geometric import GeometricParams
from simcore.skeleton.select import select_candidate
from simcore.skeleton.types import Skeleton

Method = Literal["auto", "geometric", "humanoid", "learned"]
METHODS: tuple[str, ...] = ("auto", "geometric", "humanoid", "learned")


@dataclass
class SkeletonPrediction:
    """A predicted skeleton (in the input vertices' frame), the method that made it, a JSON-ready report, and
    (for `auto`) every candidate it chose among."""

    skeleton: Skeleton
    method: str
    report: dict[str, Any] = field(default_factory=dict)
    candidates: list[Candidate] = field(default_factory=list)


def _check_mesh(vertices: np.ndarray, faces: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Validated (vertices, faces), restricted to the vertices some face uses (same frame, so the skeleton is too)."""
    v = np.asarray(vertices, dtype=np.float64).reshape(-1, 3)
    f = np.asarray(faces, dtype=np.int64).reshape(-1, 3)
    if len(v) == 0 or len(f) == 0:
        raise InvalidInput("the mesh has no triangles to build a skeleton from", code="empty_mesh", field="mesh")
    if not np.all(np.isfinite(v)):
        raise InvalidInput("the mesh has non-finite vertex positions", code="invalid_mesh", field="mesh")
    if f.min() < 0 or f.max() >= len(v):
        raise InvalidInput("a face indexes a vertex that does not exist", code="invalid_mesh", field="mesh")
    mesh = referenced_mesh(v, f)  # vertices no face uses must not set the size or the solid
    if float(np.ptp(mesh.vertices, axis=0).max()) <= 0:
        raise InvalidInput("the mesh has zero extent", code="invalid_mesh", field="mesh")
    return mesh.vertices, mesh.faces


def _auto(v: np.ndarray, f: np.ndarray, parts: list[SurfacePart], up: np.ndarray, report: dict[str, Any], *,
          max_joints: int, up_axis: str | None, forward_axis: str | None, params: GeometricParams) -> SkeletonPrediction:
    """The humanoid and geometric candidates, the one with the best quality score chosen (simcore.skeleton.select).
    The learned model's samples are not among them: on the corpus's val split they never won the selection and cost
    most of its time (`rigforge eval skeleton --method all` reports them beside auto). Nor is plain thinning (the
    geometric method with every rule off, `--ablate`'s "all off" row): it never won on val, and on the train rigs
    where its score won, the geometric skeleton had the lower J2J."""
    started = time.perf_counter()
    shape = shape_context(v, f)
    timings = {"shape": round(time.perf_counter() - started, 3)}
    humanoid, report["humanoid"] = humanoid_candidate(v, f, parts, max_joints=max_joints, up_axis=up_axis,
                                                      forward_axis=forward_axis, force=False)  # a confident biped only
    pool = [] if humanoid is None else [humanoid]
    pool.append(geometric_candidate(v, f, parts, max_joints=max_joints, up=up, params=params))
    for c in pool:
        timings[c.method] = round(timings.get(c.method, 0.0) + c.seconds, 3)
    selection = select_candidate(pool, shape)
    report["geometric"] = next(c.report for c in pool if c.method == "geometric")
    report["auto"] = selection.report(pool)
    report["timings_s"] = timings
    return SkeletonPrediction(selection.chosen.skeleton, selection.chosen.method, report, pool)


def predict_skeleton(vertices: np.ndarray, faces: np.ndarray, *, method: str = "auto", max_joints: int = 64,
                     up_axis: str | None = None, forward_axis: str | None = None,
                     geometric_params: GeometricParams | None = None, learned_model: Path | None = None
                     ) -> SkeletonPrediction:
    """Predict a skeleton for a triangle mesh.

    vertices: (V, 3) float64 positions (metres; any frame, the skeleton comes back in the same frame).
    faces:    (F, 3) int64 triangles.
    method:   "geometric" (medial skeleton, any shape), "humanoid" (Mixamo template; falls back to geometric
              when no biped is found, saying so in the report), "learned" (the skeleton-token model,
              simcore.skeleton.learned; ModelUnavailable when its weights cannot be read) or "auto" (every
              method's candidates, the best by the quality score of simcore.skeleton.candidate_score; the report's
              "auto" says which won and why). A failed humanoid fit is retried without separate parts that may
              hide the biped (simcore.skeleton.props); the report counts what was left out.
    up_axis / forward_axis: "x", "-x", "y", … overrides for the humanoid fit; None = detect. The geometric method
              uses up_axis (default glTF's +Y) only to tell legs standing on the floor.
    geometric_params: the geometric method's tuning (None = the defaults; the ablation changes it).
    learned_model: the learned method's weights file (None = the shipped one; the eval scores a fresh model).
    Report keys: "method", "timings_s", and "humanoid" (detection, confidence, facing) / "geometric" / "learned"
    / "auto".
    """
    if method not in METHODS:
        raise InvalidInput(f"unknown skeleton method {method!r}; expected one of {', '.join(METHODS)}",
                           code="invalid_option", field="options.skeleton")
    if max_joints < 2:
        raise InvalidInput("max_joints must be at least 2", code="invalid_option", field="options.max_joints")
    up = axis(up_axis, "up_axis")  # both checked before any work, whichever method runs
    axis(forward_axis, "forward_axis")
    params = GeometricParams() if geometric_params is None else geometric_params
    v, f = _check_mesh(vertices, faces)
    report: dict[str, Any] = {"requested": method}
    if method == "learned":  # reads the mesh as glTF's +Y up, the frame it was trained in
        from simcore.skeleton.learned import learned_skeleton

        started = time.perf_counter()
        skeleton, report["learned"] = learned_skeleton(v, f, max_joints=max_joints, model_path=learned_model)
        report["timings_s"] = {"learned": round(time.perf_counter() - started, 3)}
        return SkeletonPrediction(skeleton, "learned", report)
    parts = surface_parts(v, f)
    up_vector = GLTF_UP if up is None else up
    if method == "auto":
        return _auto(v, f, parts, up_vector, report, max_joints=max_joints, up_axis=up_axis, forward_axis=forward_axis,
                     params=params)
    timings: dict[str, float] = {}
    if method == "humanoid":
        humanoid, report["humanoid"] = humanoid_candidate(v, f, parts, max_joints=max_joints, up_axis=up_axis,
                                                          forward_axis=forward_axis, force=True)
        if humanoid is not None:
            report["timings_s"] = {"humanoid": round(humanoid.seconds, 3)}
            return SkeletonPrediction(humanoid.skeleton, "humanoid", report)
    geometric = geometric_candidate(v, f, parts, max_joints=max_joints, up=up_vector, params=params)
    timings["geometric"] = round(geometric.seconds, 3)
    report["geometric"] = geometric.report
    report["timings_s"] = timings
    return SkeletonPrediction(geometric.skeleton, "geometric", report)

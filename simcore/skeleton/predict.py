"""One entry point for skeleton prediction: geometric, humanoid template, learned, or automatic choice."""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Any, Literal

import numpy as np

from simcore.errors import InvalidInput
from simcore.geometry.parts import SurfacePart, surface_parts
from simcore.geometry.referenced import referenced_mesh
from simcore.skeleton.axes import GLTF_UP, axis
from simcore.skeleton.geometric import geometric_skeleton
from simcore.skeleton.props import parts_to_try_without
from simcore.skeleton.types import Skeleton

Method = Literal["auto", "geometric", "humanoid", "learned"]
METHODS: tuple[str, ...] = ("auto", "geometric", "humanoid", "learned")


@dataclass
class SkeletonPrediction:
    """A predicted skeleton (in the input vertices' frame), the method that made it, and a JSON-ready report."""

    skeleton: Skeleton
    method: str
    report: dict[str, Any] = field(default_factory=dict)


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


def predict_skeleton(vertices: np.ndarray, faces: np.ndarray, *, method: str = "auto", max_joints: int = 64,
                     up_axis: str | None = None, forward_axis: str | None = None) -> SkeletonPrediction:
    """Predict a skeleton for a triangle mesh.

    vertices: (V, 3) float64 positions (metres; any frame, the skeleton comes back in the same frame).
    faces:    (F, 3) int64 triangles.
    method:   "geometric" (medial skeleton, any shape), "humanoid" (Mixamo template; falls back to geometric
              when no biped is found, saying so in the report) or "auto" (humanoid when an upright biped is
              detected with confidence, else geometric; never learned) or "learned" (the skeleton-token model,
              simcore.skeleton.learned; ModelUnavailable when its weights cannot be read). A failed humanoid fit is retried without separate
              parts that may hide the biped (simcore.skeleton.props); the report counts what was left out.
    up_axis / forward_axis: "x", "-x", "y", … overrides for the humanoid fit; None = detect. The geometric method
              uses up_axis (default glTF's +Y) only to tell legs standing on the floor.
    Report keys: "method", "timings_s", and "humanoid" (detection, confidence, facing) / "geometric" / "learned".
    """
    if method not in METHODS:
        raise InvalidInput(f"unknown skeleton method {method!r}; expected one of {', '.join(METHODS)}",
                           code="invalid_option", field="options.skeleton")
    if max_joints < 2:
        raise InvalidInput("max_joints must be at least 2", code="invalid_option", field="options.max_joints")
    up = axis(up_axis, "up_axis")  # both checked before any work, whichever method runs
    axis(forward_axis, "forward_axis")
    v, f = _check_mesh(vertices, faces)
    timings: dict[str, float] = {}
    report: dict[str, Any] = {"requested": method}
    if method == "learned":  # reads the mesh as glTF's +Y up, the frame it was trained in
        from simcore.skeleton.learned import learned_skeleton

        started = time.perf_counter()
        skeleton, report["learned"] = learned_skeleton(v, f, max_joints=max_joints)
        report["timings_s"] = {"learned": round(time.perf_counter() - started, 3)}
        return SkeletonPrediction(skeleton, "learned", report)
    parts: list[SurfacePart] | None = None  # connected parts, found once for the retries and the geometric method
    if method in ("auto", "humanoid"):
        from simcore.skeleton.humanoid import fit_humanoid

        started = time.perf_counter()
        fit = fit_humanoid(v, f, max_joints=max_joints, up_axis=up_axis, forward_axis=forward_axis,
                           force=method == "humanoid")
        if fit.skeleton is None:
            parts = surface_parts(v, f)
        tries = parts_to_try_without(parts, len(f)) if parts is not None else []  # a sword held up, a skirt
        if not fit.biped_layout:  # no biped layout at all (a quadruped): one try, without all of them
            tries = tries[-1:]
        for prop in tries:
            rest = referenced_mesh(v, f[~prop])
            retry = fit_humanoid(rest.vertices, rest.faces, max_joints=max_joints, up_axis=up_axis,
                                 forward_axis=forward_axis, force=method == "humanoid")
            if retry.skeleton is not None:
                fit = retry
                fit.report["prop_triangles_left_out"] = int(prop.sum())
                break
        timings["humanoid"] = round(time.perf_counter() - started, 3)
        report["humanoid"] = fit.report
        if fit.skeleton is not None:
            report["timings_s"] = timings
            return SkeletonPrediction(fit.skeleton, "humanoid", report)
    started = time.perf_counter()
    skeleton, geo_report = geometric_skeleton(v, f, max_joints=max_joints, parts=parts,
                                              up=GLTF_UP if up is None else up)
    timings["geometric"] = round(time.perf_counter() - started, 3)
    report["geometric"] = geo_report
    report["timings_s"] = timings
    return SkeletonPrediction(skeleton, "geometric", report)

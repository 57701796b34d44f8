"""Skeleton candidates: each method proposes skeletons for one mesh; `simcore.skeleton.select` picks one.

Methods: `humanoid` (the Mixamo template fitted on the medial tree; none when no biped layout is found) and
`geometric` (medial thinning with the special-case rules of `simcore.skeleton.geometric_rules`), which `auto`
weighs; and `learned` (the skeleton-token model's decoded sequences, several per mesh), of which the `learned` method
keeps the best.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from simcore.geometry.parts import SurfacePart
from simcore.geometry.referenced import referenced_mesh
from simcore.skeleton.geometric import GeometricParams, geometric_skeleton
from simcore.skeleton.props import parts_to_try_without
from simcore.skeleton.types import Skeleton


@dataclass
class Candidate:
    """One proposed skeleton (in the mesh's frame), the method that made it, its method report and seconds.
    log_prob: the learned model's mean log-probability per token (None for the other methods)."""

    skeleton: Skeleton
    method: str
    report: dict[str, Any] = field(default_factory=dict)
    seconds: float = 0.0
    log_prob: float | None = None


def humanoid_candidate(vertices: np.ndarray, faces: np.ndarray, parts: list[SurfacePart], *, max_joints: int,
                       up_axis: str | None, forward_axis: str | None, force: bool) -> tuple[Candidate | None, dict]:
    """The Mixamo template fit, or None with the fit's report saying why. A failed fit is retried without separate
    parts that may hide the biped (a sword held up, a skirt: simcore.skeleton.props); the report counts the
    triangles left out. force: accept a biped below the detection confidence threshold."""
    from simcore.skeleton.humanoid import fit_humanoid

    started = time.perf_counter()
    fit = fit_humanoid(vertices, faces, max_joints=max_joints, up_axis=up_axis, forward_axis=forward_axis, force=force)
    tries = parts_to_try_without(parts, len(faces)) if fit.skeleton is None else []
    if not fit.biped_layout:  # no biped layout at all (a quadruped): one try, without all of them
        tries = tries[-1:]
    for prop in tries:
        rest = referenced_mesh(vertices, faces[~prop])
        retry = fit_humanoid(rest.vertices, rest.faces, max_joints=max_joints, up_axis=up_axis,
                             forward_axis=forward_axis, force=force)
        if retry.skeleton is not None:
            fit = retry
            fit.report["prop_triangles_left_out"] = int(prop.sum())
            break
    if fit.skeleton is None:
        return None, fit.report
    return Candidate(fit.skeleton, "humanoid", fit.report, time.perf_counter() - started), fit.report


def geometric_candidate(vertices: np.ndarray, faces: np.ndarray, parts: list[SurfacePart], *, max_joints: int,
                        up: np.ndarray, params: GeometricParams) -> Candidate:
    """The geometric method's medial-thinning skeleton with `params`."""
    started = time.perf_counter()
    skeleton, report = geometric_skeleton(vertices, faces, max_joints=max_joints, parts=parts, up=up, params=params)
    return Candidate(skeleton, "geometric", report, time.perf_counter() - started)

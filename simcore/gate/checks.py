"""The quality gate: after each stage, measure what it produced, record report["quality"][stage] and a
warning per figure past its threshold (simcore.gate.thresholds), and fail the job with code `quality_gate`
when a figure is past a hard threshold, unless options.quality_gate is "warn".
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING, Any

import numpy as np

from simcore.errors import SimcoreError
from simcore.gate.measures import (
    BLOCK_VALUES,
    DeformationSeries,
    bone_radii,
    deformation_series,
    lbs_blocks,
    skeleton_figures,
    weight_figures,
)
from simcore.gate.thresholds import thresholds
from simcore.gate.warnings import add_warning

if TYPE_CHECKING:
    from simcore.pipeline import PipelineState


class QualityGateFailed(SimcoreError):
    """A result is past a hard quality threshold (options.quality_gate "warn" keeps it, flagged)."""

    code = "quality_gate"


class _Judge:
    """Compares one stage's figures with their thresholds, writing warnings into the report."""

    def __init__(self, state: PipelineState, stage: str) -> None:
        self.state, self.stage = state, stage
        self.hard: list[dict[str, Any]] = []

    def __call__(self, key: str, value: float, code: str, describe: Callable[[float], str], frame: int | None = None) -> None:
        t = thresholds()[key]
        if not t.past(float(value), t.warn):
            return
        fail = t.fail
        hard = bool(fail is not None and t.past(value, fail))
        limit = fail if fail is not None and hard else t.warn
        where = f" at frame {frame}" if frame is not None else ""
        entry = add_warning(self.state.report, code=code, stage=self.stage, message=f"{describe(value)}{where}; "
                            f"{'the job fails past' if hard else 'warned past'} {limit:.4g}",
                            figure=float(value), threshold=float(limit), hard=hard, frame=frame)
        if hard:
            self.hard.append(entry)


def _deformation(judge: _Judge, series: DeformationSeries, prefix: str) -> dict[str, Any]:
    """Judge the worst frames of a deformation series; returns the figures for the report."""
    lo, hi = int(np.argmin(series.stretch_low)), int(np.argmax(series.stretch_high))
    out: dict[str, Any] = {
        "frames": len(series.stretch_low),
        "stretch_low": round(float(series.stretch_low[lo]), 5), "stretch_low_frame": lo,
        "stretch_high": round(float(series.stretch_high[hi]), 5), "stretch_high_frame": hi,
    }
    judge("stretch_low", series.stretch_low[lo], f"{prefix}edge_compression",
          lambda v: f"edges shrink to {v:.3f}× their bind length (1st percentile)", lo)
    judge("stretch_high", series.stretch_high[hi], f"{prefix}edge_stretch",
          lambda v: f"edges stretch to {v:.3f}× their bind length (99th percentile)", hi)
    if series.volume_ratio is not None:
        vlo, vhi = int(np.argmin(series.volume_ratio)), int(np.argmax(series.volume_ratio))
        out.update(volume_low=round(float(series.volume_ratio[vlo]), 5), volume_low_frame=vlo,
                   volume_high=round(float(series.volume_ratio[vhi]), 5), volume_high_frame=vhi)
        judge("volume_low", series.volume_ratio[vlo], f"{prefix}volume_loss",
              lambda v: f"the enclosed volume drops to {v:.3f}× the bind pose's", vlo)
        judge("volume_high", series.volume_ratio[vhi], f"{prefix}volume_gain",
              lambda v: f"the enclosed volume grows to {v:.3f}× the bind pose's", vhi)
    return out


def check_skeleton(state: PipelineState, judge: _Judge) -> dict[str, Any] | None:
    if state.skeleton is None or state.mesh is None:
        return None
    fig = skeleton_figures(state.skeleton, state.mesh.vertices, state.body_faces())
    judge("joints_inside", fig["joints_inside"], "joints_outside",
          lambda v: f"only {100 * v:.1f} % of the joints lie inside the mesh")
    judge("zero_length_bone_share", fig["zero_length_bone_share"], "zero_length_bones",
          lambda v: f"{100 * v:.1f} % of the bones have no length")
    return fig


def check_weights(state: PipelineState, judge: _Judge) -> dict[str, Any] | None:
    if state.weights is None or state.mesh is None:
        return None
    fig = weight_figures(state.weights, np.unique(state.mesh.faces))
    judge("non_finite_weights", fig["non_finite_weights"], "non_finite_weights", lambda v: f"{v:.0f} weights are NaN or infinite")
    judge("unweighted_vertices", fig["unweighted_vertices"], "unweighted_vertices",
          lambda v: f"{v:.0f} vertices have no skinning weight (they would collapse to the origin)")
    judge("max_row_sum_error", fig["max_row_sum_error"], "weights_not_normalised",
          lambda v: f"a vertex's weights sum to 1 ± {v:.3g}")
    return fig


def _lbs_blocks(state: PipelineState):  # noqa: ANN202 - an iterator of (t, V, 3) arrays
    from simcore.motion.quality import skin_matrices

    assert state.mesh is not None and state.skeleton is not None and state.animation is not None, "checked by the caller"
    return lbs_blocks(state.mesh.vertices, state.weights, skin_matrices(state.skeleton, state.animation))


def check_animation(state: PipelineState, judge: _Judge) -> dict[str, Any] | None:
    if state.animation is None or state.weights is None or state.mesh is None:
        return None
    return _deformation(judge, deformation_series(state.mesh.vertices, state.body_faces(), _lbs_blocks(state)), "")


def _tear(state: PipelineState) -> tuple[float, int]:
    """Largest refined-vs-LBS displacement over the vertex's limb radius, and its frame."""
    frames = state.refined_frames
    assert frames is not None and state.mesh is not None and state.skeleton is not None, "checked by the caller"
    radius = bone_radii(state.skeleton, state.mesh.vertices, state.weights)
    worst, frame, start = 0.0, 0, 0
    for lbs in _lbs_blocks(state):
        ratio = np.linalg.norm(frames[start:start + len(lbs)] - lbs, axis=2) / radius  # (t, V)
        per_frame = ratio.max(axis=1)
        k = int(np.argmax(per_frame))
        if per_frame[k] > worst:
            worst, frame = float(per_frame[k]), start + k
        start += len(lbs)
    return worst, frame


def check_refinement(state: PipelineState, judge: _Judge) -> dict[str, Any] | None:
    if state.refined_frames is None or state.animation is None or state.mesh is None:
        return None
    report = state.report.get("refine", {})
    clamped = report.get("clamped", {})
    non_finite = int(clamped.get("non_finite_vertices_replaced_by_lbs", 0))
    samples = max(int(report.get("particles", 0)) * int(report.get("substeps_run", 0)), 1)
    tear, tear_frame = _tear(state)
    frames = state.refined_frames
    step = max(1, BLOCK_VALUES // frames.shape[1])
    series = deformation_series(state.mesh.vertices, state.body_faces(), (frames[i:i + step] for i in range(0, len(frames), step)))
    fig = {"non_finite_vertices": non_finite, "tear_radii": round(tear, 4), "tear_frame": tear_frame,
           "det_f_clamped_share": round(int(clamped.get("det_f", 0)) / samples, 8)}
    judge("refine_non_finite_vertices", non_finite, "refine_non_finite",
          lambda v: f"the simulation produced NaN at {v:.0f} vertex-frames (replaced by LBS)")
    judge("refine_tear_radii", tear, "refine_tear",
          lambda v: f"a vertex moved {v:.2f}× its limb's radius away from its LBS position", tear_frame)
    judge("refine_det_f_clamped_share", fig["det_f_clamped_share"], "refine_det_f_clamped",
          lambda v: f"the solver rejected {100 * v:.3g} % of particle deformation updates (det F out of range)")
    if "max_volume_change_added" in report:
        fig["volume_added"] = report["max_volume_change_added"]
        judge("refine_volume_added", fig["volume_added"], "refine_volume",
              lambda v: f"refinement changes the enclosed volume by {100 * v:.1f} % of the rest volume more than LBS does")
    if "max_displacement_from_lbs_heights" in report:
        fig["offset_heights"] = report["max_displacement_from_lbs_heights"]
        judge("refine_offset_heights", fig["offset_heights"], "refine_offset",
              lambda v: f"a vertex moved {v:.3f} character heights away from its LBS position")
    fig.update(_deformation(judge, series, "refine_"))
    return fig


CHECKS: dict[str, Callable[[PipelineState, _Judge], dict[str, Any] | None]] = {
    "skeleton": check_skeleton, "skin": check_weights, "motion": check_animation, "refine": check_refinement,
}


def check_stage(stage: str, state: PipelineState) -> None:
    """Run stage `stage`'s checks (if it has any); raise QualityGateFailed on a hard failure in "fail" mode."""
    check = CHECKS.get(stage)
    if check is None:
        return
    judge = _Judge(state, stage)
    figures = check(state, judge)
    if figures is None:
        return
    state.report.setdefault("quality", {})[stage] = figures
    if judge.hard and state.options.quality_gate == "fail":
        more = f" (and {len(judge.hard) - 1} more)" if len(judge.hard) > 1 else ""
        raise QualityGateFailed(f"quality gate, {stage}: {judge.hard[0]['message']}{more}; "
                                "options.quality_gate \"warn\" keeps such results, flagged")

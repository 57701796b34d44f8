"""The `skin` pipeline stage: weights for the ingested mesh on the stage-2 skeleton.

A ground plane the skeleton stage found (state.ground_faces) is left out of the weights and bound to the root.
"""

from __future__ import annotations

import time
from typing import TYPE_CHECKING

import numpy as np

from simcore.errors import InvalidInput
from simcore.metrics.skinning import weight_stats
from simcore.skinning.postprocess import bind_to_joint
from simcore.skinning.predict import compute_weights

if TYPE_CHECKING:
    from simcore.pipeline import PipelineState, StageProgress


def run(state: "PipelineState", progress: "StageProgress") -> None:
    """Set `state.weights` ((V, J) float32 CSR) and report["skinning"] (method, scores, weight stats, seconds)."""
    if state.mesh is None or state.skeleton is None:
        raise InvalidInput("the skin stage needs the ingested mesh and a skeleton", code="missing_stage_input", field="skinning")
    options = state.options
    started = time.perf_counter()

    def report(fraction: float) -> None:
        progress.check_cancel()
        progress(fraction)

    ground = state.ground_faces if state.ground_faces is not None else np.zeros(len(state.mesh.faces), bool)
    result = compute_weights(
        state.mesh.vertices,
        state.mesh.faces[~ground],
        state.skeleton,
        method=options.skinning,
        max_influences=options.max_influences,
        smooth_iterations=options.smooth_iterations,
        progress=report,
    )
    ground_only = np.setdiff1d(state.mesh.faces[ground], state.mesh.faces[~ground])
    state.weights = bind_to_joint(result.weights, ground_only, 0)  # joint 0 is the root (parents come first)
    stats = weight_stats(state.weights)
    if stats["unweighted_vertices"]:
        state.warn(f"{stats['unweighted_vertices']} vertices received no skinning weight")
    state.report["skinning"] = {
        "requested": options.skinning,
        "method": result.method,
        "max_influences": options.max_influences,
        "smooth_iterations": options.smooth_iterations,
        "scores": result.scores,
        "weights": stats,
        "seconds": round(time.perf_counter() - started, 3),
    }
    progress(1.0)

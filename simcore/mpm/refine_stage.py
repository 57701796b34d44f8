"""Pipeline stage `refine`: PhysRig soft-body refinement of the animated character (optional).

Runs when `options.refine.enabled` and the motion stage produced `state.animation`; sets
`state.refined_frames` (T, V, 3) float32 (the exporter bakes them into refined.glb / refined.usdc) and
`report["refine"]`.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from simcore.errors import InvalidInput

if TYPE_CHECKING:
    from simcore.pipeline import PipelineState, StageProgress


def run(state: PipelineState, progress: StageProgress) -> None:
    opts = state.options.refine
    if not opts.enabled:
        return
    if state.animation is None:
        state.report["refine"] = {"skipped": "no animation to drive the simulation"}
        state.warn("refine.enabled is set but the job has no motion clip; refinement skipped")
        return
    if state.mesh is None or state.skeleton is None or state.weights is None:
        raise InvalidInput("refinement needs the mesh, skeleton and skinning weights", code="refine_needs_rig",
                           field="refine.enabled")
    from simcore.mpm.refine import refine_character, rigid_vertices, soft_faces

    rigid = rigid_vertices(state.mesh.vertices, state.mesh.faces, state.weights)
    if not len(soft_faces(state.mesh.faces, rigid)):
        state.report["refine"] = {"skipped": "every piece of the mesh rides one joint alone: nothing can deform",
                                  "rigid_piece_vertices": int(rigid.sum())}
        state.warn("refine.enabled is set but every piece of the mesh is bound to one joint alone (nothing deforms); "
                   "refinement skipped")
        return

    def on_estimate(estimate: dict) -> None:
        # Written before the simulation starts, so a report read mid-run (or after a cancel) has it.
        state.report["refine"] = {"estimate": estimate}

    result = refine_character(state.mesh.vertices, state.mesh.faces, state.skeleton, state.weights, state.animation,
                              opts, progress=progress, check_cancel=progress.check_cancel, on_estimate=on_estimate,
                              rigid=rigid)
    state.refined_frames = result.frames
    state.report["refine"] = result.report
    for note in result.notes:
        state.warn(f"refine: {note}")
    progress(1.0)

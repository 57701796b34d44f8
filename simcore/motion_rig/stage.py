"""Pipeline stage `skeleton` for mesh-sequence uploads: skeleton, weights and animation recovered from motion.

It stands in for the skeleton, skin and motion stages (simcore.pipeline plans it when ingest found a sequence and
options.skeleton is "auto" or "from_motion"). Options used: `sequence_bones` (the bone count to fit, and the joint
cap), `max_joints` (the cap of the chosen count), `max_influences`, `motion.fps` (resampling rate of a morph
animation, read at ingest).
Writes skeleton.json and report["skeleton"], report["skinning"], report["motion_rig"] (per-frame RMSE of the rig
and of free Dem Bones at the same count, in units of the first frame's bounding-box diagonal, bone count, times).
"""

from __future__ import annotations

import json
from typing import TYPE_CHECKING

from simcore.errors import InvalidInput
from simcore.gate.checks import check_stage
from simcore.metrics.skinning import weight_stats
from simcore.motion_rig.solve import MotionRigParams, rig_from_motion

if TYPE_CHECKING:
    from simcore.options import JobOptions
    from simcore.pipeline import PipelineState, StageProgress


def params_for(options: JobOptions) -> MotionRigParams:
    """The solver parameters a job's options ask for: a fit of `sequence_bones` bones with at most that many joints in
    all, when given; else a count chosen up to `max_joints`, shape joints included."""
    fixed = options.sequence_bones
    return MotionRigParams(max_influences=int(options.max_influences), bones=fixed,
                           max_bones=options.max_joints if fixed is None else fixed)


def run(state: PipelineState, progress: StageProgress) -> None:
    """Set state.skeleton, state.weights and state.animation from state.mesh_sequence."""
    mesh, sequence = state.mesh, state.mesh_sequence
    if mesh is None or sequence is None:
        raise InvalidInput("skeleton 'from_motion' needs a mesh sequence upload (a glTF morph-target animation, a "
                           ".zip of per-frame OBJ/PLY files, or USD with time-sampled points)", code="no_mesh_sequence",
                           field="options.skeleton")

    def report(fraction: float) -> None:
        progress.check_cancel()
        progress(fraction)

    rig = rig_from_motion(mesh.vertices, mesh.faces, sequence.frames, sequence.fps, params_for(state.options),
                          progress=report, name=sequence.name)
    state.skeleton, state.weights, state.animation = rig.skeleton, rig.weights, rig.animation
    path = state.workdir / "skeleton.json"
    path.write_text(json.dumps({"method": "from_motion", **rig.skeleton.to_dict(), "tokens": None}))
    state.artifacts["skeleton.json"] = path
    state.report["skeleton"] = {"method": "from_motion", "requested": state.options.skeleton,
                                "joints": rig.skeleton.num_joints, "seconds": rig.report["seconds"]}
    state.report["skinning"] = {"method": "from_motion", "max_influences": state.options.max_influences,
                                **weight_stats(rig.weights)}
    state.report["motion"] = {"clip": {"name": sequence.name, "fps": sequence.fps, "frames": rig.animation.num_frames},
                              "source": "mesh sequence"}
    state.report["motion_rig"] = rig.report
    if rig.report["sliding_joints"]:
        state.warn(f"{rig.report['sliding_joints']} joint(s) slide: the two bones they join do not turn about one "
                   "point in this motion (the surface stretches there), so the child's offset is animated",
                   code="sliding_joints", figure=rig.report["sliding_joints"])
    state.stage = "skin"
    check_stage("skin", state)  # weight invariants; the joint checks follow this stage as for any skeleton
    state.stage = "skeleton"
    progress(1.0)

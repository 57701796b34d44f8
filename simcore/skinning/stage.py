"""The `skin` pipeline stage: weights for the ingested mesh on the stage-2 skeleton.

A ground plane the skeleton stage found (state.ground_faces) is left out of the weights and bound to the root.
Joints matching options.exclude_joints (a kept rig's IK targets and controls) get no weight: they stay in the
tree as helpers (no bone of their own, `compute_weights(exclude=...)`) and keep empty columns. So do, with
`skeleton: keep`, the joints the upload's own weights never use: pole targets, bone-end markers and sockets, whose
bind transforms exporters often leave at an armature root or the origin, where they would pull whatever mesh lies
there.
"""

from __future__ import annotations

import fnmatch
import time
from typing import TYPE_CHECKING

import numpy as np
import scipy.sparse as sp

from simcore.errors import InvalidInput
from simcore.io.gltf_rig import root_holds_weight, weightless_joints
from simcore.metrics.skinning import weight_stats
from simcore.skeleton.origin_root import body_tree
from simcore.skinning.postprocess import bind_to_joint
from simcore.skinning.predict import compute_weights

if TYPE_CHECKING:
    from simcore.io.gltf_rig import RiggedAsset
    from simcore.pipeline import PipelineState, StageProgress


def run(state: PipelineState, progress: StageProgress) -> None:
    """Set `state.weights` ((V, J) float32 CSR) and report["skinning"] (method, scores, weight stats, seconds)."""
    if state.mesh is None or state.skeleton is None:
        raise InvalidInput("the skin stage needs the ingested mesh and a skeleton", code="missing_stage_input", field="skinning")
    options = state.options
    started = time.perf_counter()

    def report(fraction: float) -> None:
        progress.check_cancel()
        progress(fraction)

    ground = state.ground_faces if state.ground_faces is not None else np.zeros(len(state.mesh.faces), bool)
    drop = _excluded(state)
    helpers = _weightless_in_upload(state) & ~drop
    tree, skipped = body_tree(state.skeleton)  # a helper root at the file's origin: the body is skinned as without it
    result = compute_weights(
        state.mesh.vertices,
        state.mesh.faces[~ground],
        tree,
        method=options.skinning,
        max_influences=options.max_influences,
        smooth_iterations=options.smooth_iterations,
        progress=report,
        root_deforms=bool(skipped) or _root_deforms(state),
        exclude=(drop | helpers)[skipped:],
    )
    weights = sp.hstack([sp.csr_matrix((len(state.mesh.vertices), skipped)), result.weights], format="csr")
    on_body = np.zeros(len(state.mesh.vertices), bool)
    on_body[state.mesh.faces[~ground]] = True
    on_ground = np.zeros(len(state.mesh.vertices), bool)
    on_ground[state.mesh.faces[ground]] = True
    # joint 0 is the root (parents come first)
    state.weights = bind_to_joint(weights, np.flatnonzero(on_ground & ~on_body), 0)
    stats = weight_stats(state.weights)
    if stats["unweighted_vertices"]:
        state.warn(f"{stats['unweighted_vertices']} vertices received no skinning weight")
    state.report["skinning"] = {
        "requested": options.skinning,
        "method": result.method,
        "reason": result.reason,
        "mirror": result.mirror,
        "max_influences": options.max_influences,
        "smooth_iterations": options.smooth_iterations,
        "excluded_joints": [name for name, out in zip(state.skeleton.names, drop) if out],
        "weightless_in_upload": [name for name, out in zip(state.skeleton.names, helpers) if out],
        "scores": result.scores,
        "weights": stats,
        "seconds": round(time.perf_counter() - started, 3),
    }
    progress(1.0)


def _kept_rig(state: PipelineState) -> RiggedAsset | None:
    """The upload's own rig when the job keeps its skeleton (not a skeleton file), else None."""
    assert state.mesh is not None, "run() checked it"
    keeping = state.options.skeleton == "keep" and state.inputs.skeleton_path is None
    return state.mesh.source_rig if keeping else None


def _root_deforms(state: PipelineState) -> bool:
    """Whether the skeleton's root bends the mesh: a predicted skeleton's does; a kept rig's does when the upload's
    own weights put more than a trace on it (a toy rig's first bone, a Mixamo Hips root), not when it is an armature
    root (most artist rigs; a skeleton file without weights is taken as one)."""
    if state.options.skeleton != "keep":
        return True
    rig = _kept_rig(state)
    return rig is not None and root_holds_weight(rig.weights)


def _weightless_in_upload(state: PipelineState) -> np.ndarray:
    """(J,) bool: the kept rig's joints that its own weights never use (but the root); none for other skeletons."""
    assert state.skeleton is not None, "run() checked it"
    rig = _kept_rig(state)
    return weightless_joints(rig.weights) if rig is not None else np.zeros(state.skeleton.num_joints, bool)


def _excluded(state: PipelineState) -> np.ndarray:
    """(J,) bool: the joints options.exclude_joints names (glob, case-insensitive); warns of patterns that match none."""
    assert state.skeleton is not None, "run() checked it"
    names = [n.lower() for n in state.skeleton.names]
    drop = np.zeros(len(names), bool)
    for pattern in state.options.exclude_joints:
        hit = np.array([fnmatch.fnmatchcase(n, pattern.lower()) for n in names])
        if not hit.any():
            state.warn(f"options.exclude_joints pattern {pattern!r} matches no joint")
        drop |= hit
    if drop[0]:
        raise InvalidInput(f"options.exclude_joints leaves out the root joint {state.skeleton.names[0]!r}; every vertex "
                           "needs a joint to follow", code="invalid_option", field="options.exclude_joints")
    return drop

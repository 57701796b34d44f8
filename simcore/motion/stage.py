"""Pipeline stage `motion`: load the clip (BVH, glTF/GLB, optional FBX), retarget it onto the job's
skeleton, set `state.animation` and write report["motion"]. Skips quietly when there is no motion."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from simcore.errors import InvalidInput, SimcoreError, UnsupportedFormat
from simcore.motion.types import MotionClip

if TYPE_CHECKING:
    from simcore.pipeline import PipelineState, StageProgress

MAX_MOTION_BYTES = 64 * 1024 * 1024


def _as_motion_error(exc: SimcoreError) -> SimcoreError:
    """Errors raised by shared readers name `mesh`; in this stage the offending upload is the motion."""
    if exc.field in (None, "mesh"):
        exc.field = "motion"
    return exc


def _clip_from_gltf_bytes(data: bytes, state: PipelineState) -> MotionClip:
    from simcore.io.gltf_document import GltfDocument
    from simcore.motion.gltf_clips import read_gltf_clip

    opts = state.options.motion
    try:
        return read_gltf_clip(GltfDocument.from_bytes(data), opts.clip, opts.fps)
    except SimcoreError as exc:
        raise _as_motion_error(exc) from None


def load_uploaded_clip(path: Path, fmt: str | None, state: PipelineState) -> MotionClip:
    """Read the uploaded motion file (bvh, glb, gltf; fbx through assimp when installed)."""
    fmt = (fmt or path.suffix.lstrip(".")).lower()
    if path.stat().st_size > MAX_MOTION_BYTES:
        from simcore.errors import LimitExceeded

        raise LimitExceeded(f"motion file is over {MAX_MOTION_BYTES} bytes", code="file_too_large", field="motion")
    data = path.read_bytes()
    if fmt == "bvh":
        from simcore.io.bvh import parse_bvh

        return parse_bvh(data, state.options.motion.unit_scale, name=state.inputs.motion_name or path.stem)
    if fmt in ("glb", "gltf"):
        return _clip_from_gltf_bytes(data, state)
    if fmt == "fbx":
        from simcore.motion.fbx_convert import fbx_to_glb

        return _clip_from_gltf_bytes(fbx_to_glb(data), state)
    raise UnsupportedFormat(f"motion format {fmt!r} is not supported (use bvh, glb or gltf)",
                            code="unsupported_format", field="motion")


def clip_from_mesh_upload(state: PipelineState) -> MotionClip:
    """The clip `options.motion.clip` names inside the mesh upload, moved into the ingested mesh's frame."""
    from simcore.motion.clip_frame import skeleton_similarity, transform_clip
    from simcore.motion.gltf_clips import read_gltf_clip

    mesh = state.mesh
    doc = getattr(mesh, "source_doc", None)
    if doc is None or not doc.items("animations"):
        raise InvalidInput("options.motion.clip is set but the mesh upload carries no animation clips",
                           code="no_clips", field="motion.clip")
    clip = read_gltf_clip(doc, state.options.motion.clip, state.options.motion.fps)
    rig = getattr(mesh, "source_rig", None)
    if rig is not None and rig.skeleton.num_joints == clip.skeleton.num_joints:
        order = [rig.skeleton.names.index(n) for n in clip.skeleton.names] if set(rig.skeleton.names) == set(clip.skeleton.names) else None
        if order is not None:
            s, r, t = skeleton_similarity(clip.skeleton, rig.skeleton, np.asarray(order))
            # the mesh's own bind pose, in its frame, and its skin over the clip's joints
            clip = replace(transform_clip(clip, s, r, t), shares_bind_pose=True, bind_weights=rig.weights[:, order])
    return clip


def motion_report(state: PipelineState, clip: MotionClip, result: Any) -> dict[str, Any]:
    """JSON-ready report["motion"]: mapping, clip facts and LBS quality scores."""
    from simcore.geometry.referenced import referenced_mesh
    from simcore.motion.quality import foot_sliding, self_penetration, skin_matrices

    anim = result.animation
    out: dict[str, Any] = {
        "status": "retargeted",
        "clip": {
            "name": anim.name, "source_format": clip.source_format, "frames": anim.num_frames,
            "fps": round(anim.fps, 4), "duration_s": round(anim.duration, 4), "loop": anim.loop,
            "source_frames": clip.animation.num_frames, "source_fps": round(clip.animation.fps, 4),
            "unit_scale": round(clip.unit_scale, 6), "unit": clip.unit,
        },
        "mapping_method": result.method,
        "joint_map": result.mapping,
        "unmapped_target_joints": result.unmapped_target,
        "unmapped_source_joints": result.unmapped_source,
        "root_scale": round(result.root_scale, 5),
        "facing_quarter_turns": result.facing_turns,
        "contact_joints": result.contact_joints,
    }
    assert state.skeleton is not None, "run() returns before retargeting without one"
    if state.weights is not None and state.mesh is not None:
        mats = skin_matrices(state.skeleton, anim)
        used = referenced_mesh(state.mesh.vertices, state.mesh.faces).ids  # stray vertices would move the ground
        vertices, weights = state.mesh.vertices[used], state.weights[used]
        out["foot_sliding"] = foot_sliding(vertices, weights, mats, anim.fps)
        out["self_penetration"] = self_penetration(state.skeleton, vertices, weights, mats)
    return out


def _relax(state: PipelineState) -> dict[str, Any] | None:
    """Relax state.weights under state.animation (relax_weights.py); its figures, or None without weights."""
    from simcore.motion.quality import skin_matrices
    from simcore.motion.relax_weights import relax_weights

    if state.weights is None or state.mesh is None or state.skeleton is None or state.animation is None:
        return None
    mats = skin_matrices(state.skeleton, state.animation)
    relaxed = relax_weights(state.mesh.vertices, state.body_faces(), state.weights, mats, state.options.max_influences)
    state.weights = relaxed.weights
    return relaxed.figures()


def run(state: PipelineState, progress: StageProgress) -> None:
    """Retarget the job's motion onto state.skeleton; set state.animation and report["motion"]."""
    from simcore.motion.retarget import retarget

    opts = state.options.motion
    if state.options.stages is not None and "motion" not in state.options.stages:
        state.report["motion"] = {"status": "skipped", "reason": "not among the requested stages"}
        return
    motion_path = state.inputs.motion_path
    if motion_path is None and opts.clip is None:
        state.report["motion"] = {"status": "none", "reason": "no motion uploaded and no options.motion.clip"}
        return
    if state.skeleton is None:
        state.report["motion"] = {"status": "skipped", "reason": "no skeleton to animate"}
        state.warn("motion was given but no skeleton was built, so it was not applied")
        return
    progress(0.05)
    if motion_path is not None:
        clip = load_uploaded_clip(Path(motion_path), state.inputs.motion_format, state)
    else:
        clip = clip_from_mesh_upload(state)
    progress(0.3)
    progress.check_cancel()
    result = retarget(clip, state.skeleton, opts, state.weights)
    state.animation = result.animation
    progress(0.5)
    progress.check_cancel()
    relaxation = _relax(state) if opts.relax_weights else None
    progress(0.8)
    progress.check_cancel()
    state.report["motion"] = motion_report(state, clip, result)
    state.report["motion"]["relaxation"] = relaxation
    unmapped = len(result.unmapped_target)
    if unmapped > 0.5 * state.skeleton.num_joints:
        state.warn(f"motion: {unmapped} of {state.skeleton.num_joints} joints had no match in the clip and follow their parents")
    if not np.all(np.isfinite(result.animation.rotations)):
        raise InvalidInput("retargeting produced non-finite rotations", code="retarget_failed", field="motion")
    progress(1.0)

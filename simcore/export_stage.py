"""Pipeline stage `export`: rigged / animated / refined GLB and UsdSkel files, each validated.

Writes into state.workdir and state.artifacts:
  rigged.glb, rigged.usdc, rigged.usdz         always (needs state.mesh, state.skeleton, state.weights)
  texture_<i>.png|jpg                          the upload's images, which the .usdc files' materials reference
  animated.glb, animated.usdc, animated.usdz   when state.animation is set
  refined.glb, refined.usdc                    when state.refined_frames is set (frames of that animation; keyed
                                               at the simulation rate, compact morph targets / blend shapes)
  rigged.fbx, animated.fbx                     when options.fbx (its unit and axes) and Blender's bpy is there
                                               (simcore/io/fbx_export.py)
Joints are named first, by `options.naming` (simcore/export_naming.py).
Every GLB goes through the Khronos validator and every USD through usd-core's compliance checker;
results land in report["validation"]. A file with validator errors fails the job (code
`export_invalid`); a validator that is not installed is a report warning only.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

from simcore.errors import SimcoreError
from simcore.export_naming import apply_naming

if TYPE_CHECKING:
    from simcore.pipeline import PipelineState, StageProgress


class ExportInvalid(SimcoreError):
    """An exported file failed its format validator: a bug on our side, reported as a job failure."""

    code = "export_invalid"


def _write_glbs(state: PipelineState, progress: StageProgress) -> list[Path]:
    from simcore.io.glb_rig_writer import write_rigged_glb

    assert state.mesh is not None and state.skeleton is not None, "ingest and skeleton run before export"
    mesh, k = state.mesh, int(state.options.max_influences)
    plans: list[tuple[str, dict]] = [("rigged.glb", {})]
    if state.animation is not None:
        plans.append(("animated.glb", {"animation": state.animation}))
        if state.refined_frames is not None:
            plans.append(("refined.glb", {"animation": state.animation, "morph_frames": state.refined_frames,
                                          "morph_rate": state.options.refine.rate}))
    written = []
    for i, (name, extra) in enumerate(plans):
        progress.check_cancel()
        path = state.workdir / name
        result = write_rigged_glb(mesh.glb, state.skeleton, state.weights, max_influences=k, out_path=path, **extra)
        if name == "rigged.glb":  # merged: the skin stage may already have put its quality scores there
            state.report.setdefault("weights", {}).update(result.influences.stats)
        state.report.setdefault("export", {})[name] = {k2: v for k2, v in result.stats.items() if k2 != "influences"}
        state.artifacts[name] = path
        written.append(path)
        progress(0.4 * (i + 1) / len(plans))
    return written


def _write_usds(state: PipelineState, progress: StageProgress) -> list[Path]:
    from simcore.io.usd_skel_writer import write_usd_skel

    assert state.mesh is not None and state.skeleton is not None, "ingest and skeleton run before export"
    k = int(state.options.max_influences)
    rigged = state.workdir / "rigged.usdc"
    written = write_usd_skel(state.mesh.glb, state.skeleton, state.weights, rigged, max_influences=k,
                             usdz_path=state.workdir / "rigged.usdz")
    if state.animation is not None:
        progress.check_cancel()
        written += write_usd_skel(state.mesh.glb, state.skeleton, state.weights, state.workdir / "animated.usdc",
                                  max_influences=k, animation=state.animation,
                                  usdz_path=state.workdir / "animated.usdz")
        if state.refined_frames is not None:
            progress.check_cancel()
            written += write_usd_skel(state.mesh.glb, state.skeleton, state.weights, state.workdir / "refined.usdc",
                                      max_influences=k, animation=state.animation,
                                      refined_frames=state.refined_frames, refined_rate=state.options.refine.rate)
    for path in written:
        state.artifacts[path.name] = path
    progress(0.7)
    return sorted({p for p in written if p.suffix.startswith(".usd")})


def _write_fbxs(state: PipelineState, glbs: list[Path]) -> None:
    """rigged.fbx / animated.fbx from the validated GLBs when options.fbx asks; a missing writer is a warning."""
    from simcore.io.fbx_export import blender_python, fbx_frame, write_fbx

    frame = fbx_frame(state.options.fbx)
    if frame is None:
        return
    if blender_python() is None:
        state.warn("FBX was asked for but this worker has no FBX writer (Blender's bpy: `make fbx-writer` or "
                   "RIGFORGE_BLENDER_PYTHON); the GLB and USD files are complete", code="fbx_unavailable")
        return
    fps = state.animation.fps if state.animation is not None else 30.0
    for glb in glbs:
        if glb.name not in ("rigged.glb", "animated.glb"):
            continue
        result = write_fbx(glb, glb.with_suffix(".fbx"), fps=fps, frame=frame)
        state.artifacts[result.path.name] = result.path
        state.report.setdefault("export", {})[result.path.name] = {
            "writer": result.writer, "seconds": result.seconds, "bytes": result.path.stat().st_size,
            "units": frame.units, "up_axis": frame.up_axis}


def _validate(state: PipelineState, glbs: list[Path], usds: list[Path]) -> None:
    from simcore.io.gltf_validate import ValidatorUnavailable, validate_gltf_files
    from simcore.io.usd_validate import validate_usd_file

    results = state.report.setdefault("validation", {})
    failures = []
    try:
        for res in validate_gltf_files(glbs):
            results[Path(res.path).name] = res.summary()
            if not res.ok:
                failures.append(f"{Path(res.path).name}: {res.messages[:3]}")
    except ValidatorUnavailable as exc:
        state.warn(f"glTF files not validated: {exc}")
        results.update({p.name: {"skipped": str(exc)} for p in glbs})
    for path in usds:
        usd_res = validate_usd_file(path)
        results[path.name] = usd_res.summary()
        if not usd_res.ok:
            failures.append(f"{path.name}: {usd_res.errors[:3]}")
    if failures:
        raise ExportInvalid("exported files failed validation: " + "; ".join(failures))


def run(state: PipelineState, progress: StageProgress) -> None:
    """Write, validate and register every export this job's state supports."""
    if state.options.stages is not None and "export" not in state.options.stages:
        return
    if state.mesh is None or state.skeleton is None or state.weights is None:
        state.warn("export skipped: the job produced no skeleton and weights")
        return
    if state.refined_frames is not None and state.animation is None:
        state.warn("refined frames were dropped from the export: they need the animation they refine")
    apply_naming(state)
    glbs = _write_glbs(state, progress)
    usds = _write_usds(state, progress)
    _validate(state, glbs, usds)
    progress.check_cancel()
    _write_fbxs(state, glbs)
    progress(1.0)

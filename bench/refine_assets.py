"""Per-asset stability of forward PhysRig refinement: every dev character with a clip, plus xbot + CMU mocap.

For each rigged dev asset carrying clips (loader stress tests excluded): its artist rig plays its first clip
(the first `--seconds`), refined with the default options (30 fps simulation, CFL substeps, limited drivers,
tether); xbot also plays mocap_cmu_01_01.bvh retargeted onto its skeleton at the BVH's own rate. Per row:
time estimate vs measured wall time and CPU time (all threads; the machine is shared, so wall time depends
on the load, recorded with each row), substeps, the largest per-key volume change (refined, LBS, and what
refinement adds beyond LBS), the largest offset from LBS in character heights, clamp counts, the size of
the refined points as float32 (at the clip's rate and at the simulation rate: what a plain point cache would
take), the sizes of the refined.glb and refined.usdc the export stage writes (compact morph targets / blend
shapes keyed at the simulation rate), their validators' error counts and the largest vertex error the compact
form adds, and the quality gate's verdict on the refine stage (the same checks a job runs); a character whose
every piece rides one joint alone is skipped, as the refine stage skips it. Writes
bench/results/refine_assets.json and prints a table.

    .venv/bin/python bench/refine_assets.py [--seconds 4] [--only xbot,fox] [--no-mocap]
"""

from __future__ import annotations

import argparse
import json
import os
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np

REPO = Path(__file__).resolve().parents[1]
ASSETS = REPO.parent / "shared" / "assets" / "dev"
MOCAP = "mocap_cmu_01_01.bvh"
EXCLUDED = {"recursive_skeletons"}  # a loader stress test of 84 skins, not a character


def _crop(animation: Any, seconds: float) -> Any:
    from simcore.motion.types import JointAnimation

    n = min(animation.num_frames, int(round(seconds * animation.fps)) + 1)
    return JointAnimation(animation.joint_names, animation.fps, animation.rotations[:n], animation.translations[:n],
                          animation.name, animation.loop)


def _gate(vertices: np.ndarray, faces: np.ndarray, skeleton: Any, weights: Any, animation: Any, result: Any,
          opts: Any, workdir: Path) -> tuple[bool, list[str]]:
    """(passes, hard failure codes) of the quality gate's refine checks on this result."""
    from simcore.gate.checks import check_stage
    from simcore.geometry.mesh import IngestedMesh
    from simcore.options import JobOptions
    from simcore.pipeline import PipelineInputs, PipelineState

    state = PipelineState(PipelineInputs(workdir / "in.glb", "glb"), JobOptions(quality_gate="warn", refine=opts), workdir)
    state.mesh, state.skeleton, state.weights, state.animation = IngestedMesh(vertices, faces, b""), skeleton, weights, animation
    state.refined_frames, state.report["refine"], state.stage = result.frames, result.report, "refine"
    check_stage("refine", state)
    hard = [w["code"] for w in state.report.get("warnings", []) if w.get("hard")]
    warned = [w["code"] for w in state.report.get("warnings", []) if not w.get("hard")]
    return not hard, hard + [f"warn:{c}" for c in warned]


def _export_sizes(name: str, vertices: np.ndarray, skeleton: Any, weights: Any, animation: Any, frames: np.ndarray,
                  rate: float, workdir: Path) -> dict[str, Any]:
    """refined.glb / refined.usdc as the export stage writes them: MB, validator errors, compact-form error."""
    from simcore.ingest import ingest
    from simcore.io.glb_rig_writer import write_rigged_glb
    from simcore.io.gltf_validate import ValidatorUnavailable, validate_gltf_file
    from simcore.io.usd_skel_writer import write_usd_skel
    from simcore.io.usd_validate import validate_usd_file

    path = next(p for p in sorted(ASSETS.glob(f"{name}.*")) if p.suffix in (".glb", ".gltf"))
    mesh = ingest(path.read_bytes(), path.suffix.lstrip("."))
    if mesh.vertices.shape != vertices.shape or np.abs(mesh.vertices - vertices).max() > 1e-4 * np.ptp(vertices):
        return {"export": "skipped: the ingested mesh's vertices differ from the bench's"}
    glb = write_rigged_glb(mesh.glb, skeleton, weights, animation=animation, morph_frames=frames, morph_rate=rate,
                           out_path=workdir / "refined.glb")
    usd = write_usd_skel(mesh.glb, skeleton, weights, workdir / "refined.usdc", animation=animation,
                         refined_frames=frames, refined_rate=rate)[0]
    try:
        glb_errors: Any = validate_gltf_file(workdir / "refined.glb").errors
    except ValidatorUnavailable:
        glb_errors = "n/a"
    morph = glb.stats["morph"]
    return {"glb_MB": round(glb.stats["bytes"] / 2**20, 2), "usdc_MB": round(usd.stat().st_size / 2**20, 2),
            "glb_errors": glb_errors, "usd_errors": len(validate_usd_file(usd).errors),
            "morph_keys": morph["keys"], "morph_basis": morph["basis_shapes"],
            "morph_max_error_heights": round(morph["max_error"] / max(float(np.ptp(vertices, axis=0).max()), 1e-12), 6)}


def run_case(name: str, clip: str, vertices: np.ndarray, faces: np.ndarray, skeleton: Any, weights: Any,
             animation: Any, workdir: Path) -> dict[str, Any]:
    from simcore.mpm.refine import refine_character, rigid_vertices, soft_faces
    from simcore.options import RefineOptions

    opts = RefineOptions(enabled=True)
    rigid = rigid_vertices(vertices, faces, weights)
    if not len(soft_faces(faces, rigid)):  # what the refine stage skips: every piece rides one joint alone
        return {"asset": name, "clip": clip, "vertices": len(vertices), "skipped": "every piece rides one joint alone"}
    started, cpu = time.perf_counter(), time.process_time()
    result = refine_character(vertices, faces, skeleton, weights, animation, opts, rigid=rigid)
    total, cpu = time.perf_counter() - started, time.process_time() - cpu
    r = result.report
    passes, codes = _gate(vertices, faces, skeleton, weights, animation, result, opts, workdir)
    mb = 12 * len(vertices) / 2**20
    return {
        "asset": name, "clip": clip, "vertices": len(vertices), "particles": r["particles"],
        "clip_frames": animation.num_frames, "clip_fps": round(float(animation.fps), 3),
        "seconds_of_clip": round((animation.num_frames - 1) / animation.fps, 3), "keys": r["frames"],
        "substeps": r["substeps_run"], "estimate_s": r["estimate_estimate_s"], "simulation_s": r["simulation_s"],
        "total_s": round(total, 2), "cpu_s": round(cpu, 2), "load_average": round(os.getloadavg()[0], 1),
        "ms_per_substep": r["ms_per_substep"],
        "max_volume_change_refined": r["max_volume_change_refined"], "max_volume_change_lbs": r["max_volume_change_lbs"],
        "max_volume_change_added": r["max_volume_change_added"],
        "max_offset_heights": r["max_displacement_from_lbs_heights"],
        "driver_speed_unlimited_m_s": r["max_driver_speed_unlimited_m_s"], "driver_speed_m_s": r["max_driver_speed_m_s"],
        "driver_steps_capped": r["driver_steps_capped"], "clamped": r["clamped"],
        "points_MB_clip_rate": round(mb * animation.num_frames, 2), "points_MB_sim_rate": round(mb * r["frames"], 2),
        **_export_sizes(name, vertices, skeleton, weights, animation, result.frames, opts.rate, workdir),
        "gate_passes": passes, "gate_codes": codes,
    }


Case = tuple[str, str, np.ndarray, np.ndarray, Any, Any, Any]


def cases(seconds: float, only: set[str] | None, mocap: bool) -> Iterator[Case]:
    """(name, clip, vertices, faces, skeleton, weights, animation) per asset clip."""
    from simcore.evaluation.assets import rigged_assets
    from simcore.evaluation.motion_eval import world_bind
    from simcore.io.bvh import parse_bvh
    from simcore.motion.gltf_clips import read_gltf_clip
    from simcore.motion.retarget import retarget
    from simcore.options import MotionOptions

    skipped: dict[str, str] = {}
    for name, _category, doc, asset in rigged_assets(ASSETS, skipped):
        if name in EXCLUDED or (only and name not in only) or not doc.items("animations"):
            continue
        clip = read_gltf_clip(doc, 0, asset=asset)
        vertices, clip = world_bind(doc, asset, clip)
        yield name, clip.animation.name, vertices, asset.faces, clip.skeleton, asset.weights, _crop(clip.animation, seconds)
        if mocap and name == "xbot":
            bvh = parse_bvh((ASSETS / MOCAP).read_bytes(), name=Path(MOCAP).stem)
            anim = retarget(bvh, clip.skeleton, MotionOptions(end=seconds)).animation
            yield name, Path(MOCAP).stem, vertices, asset.faces, clip.skeleton, asset.weights, anim
    for k, v in skipped.items():
        print(f"skipped {k}: {v}", flush=True)


def main() -> None:
    import tempfile

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=4.0, help="clip length refined per asset")
    parser.add_argument("--only", default="", help="comma-separated asset names")
    parser.add_argument("--no-mocap", action="store_true", help="skip xbot + CMU mocap")
    parser.add_argument("--mocap-only", action="store_true", help="only xbot + CMU mocap")
    parser.add_argument("--out", type=Path, default=REPO / "bench" / "results" / "refine_assets.json")
    args = parser.parse_args()
    only = {s for s in args.only.split(",") if s} or None
    rows = []
    head = (f"{'asset':<18} {'clip':<22} {'verts':>6} {'parts':>6} {'keys':>4} {'subst':>6} {'est s':>7} {'sim s':>7} "
            f"{'vol ref':>8} {'vol lbs':>8} {'added':>7} {'off/h':>6} {'MB clip':>8} {'MB sim':>7} {'glb MB':>7} "
            f"{'usd MB':>7} gate")
    print(head + "   (wall s / CPU s / load)", flush=True)
    with tempfile.TemporaryDirectory() as tmp:
        for case in cases(args.seconds, {"xbot"} if args.mocap_only else only, not args.no_mocap):
            if args.mocap_only and case[1] != Path(MOCAP).stem:
                continue
            try:
                r = run_case(*case, workdir=Path(tmp))
            except Exception as exc:  # one failing asset is a row of the table, not the end of the bench
                r = {"asset": case[0], "clip": case[1], "error": f"{type(exc).__name__}: {exc}"}
                print(f"{case[0]:<18} {case[1][:22]:<22} ERROR {r['error']}", flush=True)
                rows.append(r)
                continue
            rows.append(r)
            if "skipped" in r:
                print(f"{r['asset']:<18} {r['clip'][:22]:<22} {r['vertices']:>6} skipped, as a job skips it: {r['skipped']}",
                      flush=True)
                continue
            print(f"{r['asset']:<18} {r['clip'][:22]:<22} {r['vertices']:>6} {r['particles']:>6} {r['keys']:>4} "
                  f"{r['substeps']:>6} {r['estimate_s']:>7.1f} {r['simulation_s']:>7.1f} "
                  f"{r['max_volume_change_refined']:>8.4f} {r['max_volume_change_lbs']:>8.4f} "
                  f"{r['max_volume_change_added']:>7.4f} {r['max_offset_heights']:>6.4f} {r['points_MB_clip_rate']:>8.1f} "
                  f"{r['points_MB_sim_rate']:>7.1f} {r.get('glb_MB', float('nan')):>7.2f} {r.get('usdc_MB', float('nan')):>7.2f} "
                  f"{'pass' if r['gate_passes'] else 'FAIL'} {' '.join(r['gate_codes'])}"
                  f"   ({r['total_s']:.0f} / {r['cpu_s']:.0f} / {r['load_average']})",
                  flush=True)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps({"seconds": args.seconds, "rows": rows}, indent=2))
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()

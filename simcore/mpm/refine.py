"""Forward PhysRig refinement of an animated character: simulate at the key rate, interpolate to the clip's
frames, report stability figures (volume, offset from LBS, clamps) and the time estimate made before the run."""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import scipy.sparse as sp

from simcore.errors import InvalidInput
from simcore.motion.types import JointAnimation
from simcore.mpm.measures import part_volumes, vertex_parts, volume_change, volume_parts
from simcore.mpm.sampling import nearest_rows
from simcore.mpm.scene import CharacterScene, build_scene, particle_budget
from simcore.options import RefineOptions
from simcore.skeleton.kinematics import skinning_matrices
from simcore.skeleton.types import Skeleton
from simcore.skinning.lbs import linear_blend
from simcore.skinning.parts import rigid_piece_vertices

PROBE_SUBSTEPS = 3  # timed substeps (after one untimed) behind the estimate
VOLUME_BLOCK = 16  # frames per block of volume measurement


@dataclass
class RefineResult:
    """frames: (T, V, 3) float32 refined vertex positions at animation frames; report: JSON-ready summary."""

    frames: np.ndarray
    report: dict[str, Any]
    notes: list[str] = field(default_factory=list)


def _fill_unsimulated(offsets: np.ndarray, vertices: np.ndarray, vertex_particles: np.ndarray, rigid: np.ndarray) -> None:
    """Vertices thinned by the budget take the offsets (K, V, 3) of their nearest simulated vertices; those on
    rigid pieces (`rigid` (V,) bool, never simulated) keep none."""
    offsets[:, rigid] = 0.0
    missing = (vertex_particles < 0) & ~rigid
    if not missing.any():
        return
    simulated = vertex_particles >= 0
    blend = nearest_rows(vertices[simulated], sp.identity(int(simulated.sum()), format="csr"), vertices[missing])
    for k in range(len(offsets)):
        offsets[k, missing] = blend @ offsets[k, simulated]


def rigid_vertices(vertices: np.ndarray, faces: np.ndarray, weights: sp.csr_matrix) -> np.ndarray:
    """(V,) bool: vertices of separate pieces the weights bind to one joint alone (skinning.parts): the simulation
    leaves them out and they follow that joint rigidly."""
    return rigid_piece_vertices(vertex_parts(vertices, faces), sp.csr_matrix(weights))


def soft_faces(faces: np.ndarray, rigid: np.ndarray) -> np.ndarray:
    """The faces with a vertex off the rigid pieces (`rigid_vertices`): what the simulation samples; none means
    nothing can deform."""
    return faces[~rigid[faces].all(axis=1)]


def interpolate_offsets(offsets: np.ndarray, key_times: np.ndarray, frame_times: np.ndarray) -> np.ndarray:
    """(T, V, 3) offsets at frame_times (s) by linear interpolation of key offsets (K, V, 3) at key_times (K,)."""
    f = np.interp(frame_times, key_times, np.arange(len(key_times)))
    lo = np.floor(f).astype(int)
    hi = np.minimum(lo + 1, len(key_times) - 1)
    a = (f - lo).astype(np.float32)[:, None, None]
    return (1.0 - a) * offsets[lo] + a * offsets[hi]


def estimate_seconds(ms_per_substep: float, scene: CharacterScene) -> float:
    """Simulation time the run should take at the probed speed."""
    return ms_per_substep * 1e-3 * scene.total_substeps()


def refine_character(vertices: np.ndarray, faces: np.ndarray, skeleton: Skeleton, weights: sp.csr_matrix,
                     animation: JointAnimation, opts: RefineOptions, *,
                     progress: Callable[[float], None] = lambda f: None,
                     check_cancel: Callable[[], None] = lambda: None,
                     on_estimate: Callable[[dict[str, Any]], None] = lambda e: None,
                     device: str | None = None, seed: int = 0, rigid: np.ndarray | None = None) -> RefineResult:
    """Simulate the character's volume driven by its animated skeleton.

    vertices: (V, 3) float bind pose, metres; faces: (F, 3) int; weights: (V, J) rows summing to 1.
    rigid: (V,) bool `rigid_vertices` (computed when None): those pieces get no particles and no offset; some
    face must have a vertex off them.
    Returns refined positions for every animation frame (frame 0 after `opts.preroll_frames` keys of easing in).
    on_estimate receives {"substeps", "ms_per_substep", "estimate_s"} before the simulation starts.
    """
    import warp as wp

    from simcore.mpm.simulate import DeviceDrive, advance_frame
    from simcore.mpm.solver import MPMSolver, Tether, warp_device

    vertices = np.asarray(vertices, np.float64)
    faces = np.asarray(faces, np.int64)
    dev = warp_device(device)
    budget, budget_source = particle_budget(opts.max_particles, dev)
    started = time.perf_counter()
    rigid = rigid_vertices(vertices, faces, weights) if rigid is None else rigid
    soft = soft_faces(faces, rigid)  # the particle budget goes to what can deform
    if not len(soft):
        raise InvalidInput("every piece of the mesh rides one joint alone: nothing to simulate",
                           code="refine_nothing_to_simulate", field="refine.enabled")
    scene = build_scene(vertices, soft, skeleton, sp.csr_matrix(weights), animation, opts, device=dev,
                        max_particles=budget, seed=seed)
    s = scene.sample
    solver = MPMSolver(s.count, scene.grid, scene.dx, scene.density * s.particle_volume, s.particle_volume, device=dev,
                       bound=3)
    a, b = solver.new_state(s.positions), solver.new_state()
    mu = wp.array(scene.mu, dtype=float, device=dev)
    lam = wp.array(scene.lam, dtype=float, device=dev)
    tether = None
    if scene.tether_radius.max() > 0:
        tether = Tether(wp.array(s.positions.astype(np.float32), dtype=wp.vec3, device=dev),
                        wp.array(scene.skin_joints, dtype=wp.vec4i, device=dev),
                        wp.array(scene.skin_weights, dtype=wp.vec4, device=dev),
                        wp.zeros(1, dtype=wp.mat44, device=dev), 0, wp.array(scene.tether_radius, dtype=float, device=dev),
                        wp.zeros(1, dtype=wp.int32, device=dev))
    setup_s = time.perf_counter() - started

    # Estimate: time a few substeps of the first interval on a scratch state (the first run compiles/loads).
    probe = DeviceDrive(scene.plan(0), dev, tether=tether)
    pa, pb = solver.new_state(s.positions), solver.new_state()
    solver.substep(pa, pb, probe.inputs(0, mu, lam))
    wp.synchronize_device(dev)
    t0 = time.perf_counter()
    for k in range(PROBE_SUBSTEPS):
        solver.substep(pb if k % 2 == 0 else pa, pa if k % 2 == 0 else pb, probe.inputs(0, mu, lam))
    wp.synchronize_device(dev)
    probe_ms = 1e3 * (time.perf_counter() - t0) / PROBE_SUBSTEPS
    solver.take_clamp_counts()
    if tether is not None:
        tether.count.zero_()
    estimate = {"substeps": scene.total_substeps(), "ms_per_substep": round(probe_ms, 3),
                "estimate_s": round(estimate_seconds(probe_ms, scene), 1)}
    on_estimate(estimate)

    vp = s.vertex_particles
    keys = len(scene.keys)
    outputs = keys - scene.first_output
    sim = np.zeros((outputs, len(vertices), 3), np.float32)  # unsimulated vertices: filled from their neighbours below
    det_dev, clamps, tethered = [], [0, 0], 0
    sim_started = time.perf_counter()
    substeps_run = 0

    def record(k: int) -> None:
        i = k - scene.first_output
        if i >= 0:
            sim[i, vp >= 0] = a.x.numpy()[vp[vp >= 0]]
            det_dev.append(solver.mean_det_deviation(a))

    record(0)
    for k in range(keys - 1):
        check_cancel()
        plan = scene.plan(k)
        a, b = advance_frame(solver, a, b, DeviceDrive(plan, dev, tether=tether), mu, lam)
        substeps_run += plan.substeps
        v, d = solver.take_clamp_counts()
        clamps[0] += v
        clamps[1] += d
        record(k + 1)
        progress((k + 1) / max(keys - 1, 1))
    sim_s = time.perf_counter() - sim_started
    if tether is not None:
        tethered = int(tether.count.numpy()[0])

    key_world = scene.world[scene.first_output:]
    w = sp.csr_matrix(weights)
    lbs_keys = np.empty_like(sim)
    for start in range(0, outputs, VOLUME_BLOCK):
        lbs_keys[start:start + VOLUME_BLOCK] = linear_blend(vertices, w, key_world[start:start + VOLUME_BLOCK] @ scene.inv_bind[None])
    offsets = sim - lbs_keys
    _fill_unsimulated(offsets, vertices, vp, rigid)  # a piece bound to one joint alone stays rigid on it (a plate)
    bad = ~np.isfinite(offsets)
    nan_replaced = int(bad.any(axis=2).sum())
    if nan_replaced:  # never hand a NaN to the exporters: no offset there (LBS) and say so
        offsets[bad] = 0.0
    from simcore.mpm.drivers import animation_world_transforms

    frame_times = np.arange(animation.num_frames) / float(animation.fps)
    mats = skinning_matrices(skeleton, animation_world_transforms(skeleton, animation))
    out = np.empty((animation.num_frames, len(vertices), 3), np.float32)
    key_times = scene.keys[scene.first_output:]
    for start in range(0, animation.num_frames, VOLUME_BLOCK):
        block = slice(start, start + VOLUME_BLOCK)
        out[block] = linear_blend(vertices, w, mats[block]) + interpolate_offsets(offsets, key_times, frame_times[block])
    report = _report(scene, lbs_keys + offsets, lbs_keys, vertices, faces)
    report.update({
        "particle_budget": budget, "particle_budget_source": budget_source, "device": dev,
        "setup_s": round(setup_s, 3), "simulation_s": round(sim_s, 3), **{f"estimate_{k}": v for k, v in estimate.items()},
        "substeps_run": substeps_run, "preroll_frames": scene.first_output,
        "ms_per_substep": round(1e3 * sim_s / max(substeps_run, 1), 3),
        "particle_substeps_per_s": round(s.count * substeps_run / max(sim_s, 1e-9)),
        "mean_abs_det_f_minus_1": [round(x, 6) for x in det_dev],
        "rigid_piece_vertices": int(rigid.sum()),
        "clamped": {"velocity": clamps[0], "det_f": clamps[1], "tethered": tethered,
                    "non_finite_vertices_replaced_by_lbs": nan_replaced},
    })
    return RefineResult(out, report, list(scene.info.get("notes", [])))


def _part_volumes(frames: np.ndarray, faces: np.ndarray, face_parts: np.ndarray) -> np.ndarray:
    return np.concatenate([part_volumes(frames[i:i + VOLUME_BLOCK], faces, face_parts)
                           for i in range(0, len(frames), VOLUME_BLOCK)])


def _report(scene: CharacterScene, refined: np.ndarray, lbs: np.ndarray, vertices: np.ndarray, faces: np.ndarray) -> dict:
    """Figures at the simulated keys on the clip: volume change (per surface part, measures.part_volumes, so open
    and multi-part meshes are measured by deformation alone), offsets from LBS."""
    face_parts = volume_parts(vertices, faces)
    rest_parts = part_volumes(vertices, faces, face_parts)[0]
    rest = float(rest_parts.sum())
    safe = rest if abs(rest) > 1e-12 else 1.0
    parts_lbs, parts_ref = _part_volumes(lbs, faces, face_parts), _part_volumes(refined, faces, face_parts)
    change_lbs, change_ref = volume_change(parts_lbs, rest_parts), volume_change(parts_ref, rest_parts)
    disp = np.linalg.norm(refined - lbs, axis=2)  # (K, V)
    # volume change refinement adds beyond LBS's own, per key (≤ 0 where it keeps volume better than LBS)
    added = change_ref - change_lbs
    return {
        **scene.info,
        "frames": int(len(refined)),
        "rest_volume_m3": round(rest, 8),
        "volume_parts": int(len(rest_parts)),
        "volume_ratio_lbs": [round(float(x), 5) for x in parts_lbs.sum(axis=1) / safe],
        "volume_ratio_refined": [round(float(x), 5) for x in parts_ref.sum(axis=1) / safe],
        "max_volume_change_lbs": round(float(np.max(change_lbs)), 5),
        "max_volume_change_refined": round(float(np.max(change_ref)), 5),
        "max_volume_change_added": round(float(np.max(added)), 5),
        "max_displacement_from_lbs_m": round(float(disp.max()), 6),
        "max_displacement_from_lbs_heights": round(float(disp.max()) / max(scene.height, 1e-12), 6),
        "mean_displacement_from_lbs_m": [round(float(x), 6) for x in disp.mean(axis=1)],
    }

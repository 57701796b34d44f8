"""Set up the soft-body simulation of a rigged, animated character: grid, particles, materials, drivers, Δt.

The grid is a cube of `grid` nodes that follows the body: each frame it is centred on the LBS pose's
bounding box (moving the Eulerian grid between substeps is legal in MPM, it holds no state), and its cell
size fits the largest posed extent over the clip plus a margin. Particles are sampled at half a cell
(about 8 per cell). Δt = min(frame Δt / substeps scaled to 25 fps, CFL bound of the P-wave speed, CFL bound
of the fastest driver), so stiff presets or fast motion take more substeps and report it.
"""

from __future__ import annotations

import os
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import scipy.sparse as sp

from simcore.errors import InvalidInput
from simcore.geometry.referenced import referenced_mesh
from simcore.motion.types import JointAnimation
from simcore.mpm.drivers import DrivingPoints, animation_world_transforms, driver_positions, leaf_tips, place_drivers, substep_drive
from simcore.mpm.materials import PRESETS, max_wave_speed, particle_lame, prototype_weights, region_stiffness, seed_prototypes
from simcore.mpm.sampling import ParticleSample, nearest_rows, sample_volume
from simcore.mpm.simulate import FramePlan
from simcore.options import RefineOptions
from simcore.skeleton.kinematics import bind_matrices, skinning_matrices
from simcore.skeleton.types import Skeleton
from simcore.skinning.lbs import linear_blend

BOUND = 3  # wall band in nodes
MARGIN_NODES = 4  # free nodes between the body's box and the wall band on each side
CFL_WAVE = 0.4  # Δt ≤ CFL_WAVE · dx / P-wave speed
CFL_DRIVE = 0.25  # Δt ≤ CFL_DRIVE · dx / fastest driver speed
PAPER_FPS = 25.0  # substeps option counts per 25 fps frame (PhysRig: 100 → Δt = 4e-4 s)
MAX_SUBSTEPS = 2000


def particle_budget(option: int | None, device: str) -> tuple[int, str]:
    """(budget, where it came from): the job option, else RIGFORGE_MPM_MAX_PARTICLES, else 30k CPU / 200k GPU."""
    if option is not None:
        return int(option), "options.refine.max_particles"
    env = os.environ.get("RIGFORGE_MPM_MAX_PARTICLES")
    if env:
        try:
            value = int(env)
        except ValueError:
            raise InvalidInput(f"RIGFORGE_MPM_MAX_PARTICLES must be an integer, got {env!r}",
                               code="invalid_setting", field="RIGFORGE_MPM_MAX_PARTICLES") from None
        if value < 1000:
            raise InvalidInput("RIGFORGE_MPM_MAX_PARTICLES must be at least 1000", code="invalid_setting",
                               field="RIGFORGE_MPM_MAX_PARTICLES")
        return value, "RIGFORGE_MPM_MAX_PARTICLES"
    return (200_000 if device.startswith("cuda") else 30_000), "default"


@dataclass
class CharacterScene:
    """Everything the refine loop needs; arrays in world space, metres.

    sample: particles; mu, lam: (N,) float32 Pa; drivers: driving points; density: kg/m³;
    grid, dx: nodes per axis and spacing (m); dt, substeps: per animation frame; frame_dt: 1 / fps;
    world: (T, J, 4, 4) joint world transforms per frame; bind_world: (J, 4, 4);
    lbs: (T, V, 3) float64 LBS vertex positions per frame; centres: (T, 3) grid centre per frame (bind: bind_centre).
    """

    sample: ParticleSample
    mu: np.ndarray
    lam: np.ndarray
    drivers: DrivingPoints
    density: float
    grid: int
    dx: float
    dt: float
    substeps: int
    frame_dt: float
    world: np.ndarray
    bind_world: np.ndarray
    lbs: np.ndarray
    centres: np.ndarray
    bind_centre: np.ndarray
    info: dict[str, Any] = field(default_factory=dict)

    def origin(self, centre: np.ndarray) -> np.ndarray:
        return np.asarray(centre, dtype=np.float64) - 0.5 * (self.grid - 1) * self.dx

    def plan(self, world_a: np.ndarray, world_b: np.ndarray, centre_a: np.ndarray, centre_b: np.ndarray,
             substeps: int, ease: bool = False) -> FramePlan:
        """The FramePlan of one interval between two skeleton poses and grid centres."""
        dt = self.dt
        dp, dv = substep_drive(self.drivers, world_a, world_b, substeps, dt, ease=ease)
        a = (np.arange(substeps) / substeps)[:, None]
        origins = self.origin((1.0 - a) * centre_a + a * centre_b)
        return FramePlan(dt, origins, dp, dv)

    def preroll_plans(self, frames: int) -> list[FramePlan]:
        """Frames easing from the bind pose into animation frame 0 (not output)."""
        if frames <= 0:
            return []
        poses = [self.bind_world, self.world[0]]
        plan = self.plan(poses[0], poses[1], self.bind_centre, self.centres[0], self.substeps * frames, ease=True)
        n = self.substeps
        return [FramePlan(plan.dt, plan.origins[i * n:(i + 1) * n], plan.dp[i * n:(i + 1) * n], plan.dv[i * n:(i + 1) * n])
                for i in range(frames)]

    def frame_plan(self, t: int) -> FramePlan:
        """Interval from animation frame t to t + 1."""
        return self.plan(self.world[t], self.world[t + 1], self.centres[t], self.centres[t + 1], self.substeps)


def build_scene(vertices: np.ndarray, faces: np.ndarray, skeleton: Skeleton, weights: sp.csr_matrix, animation: JointAnimation,
                opts: RefineOptions, *, device: str, max_particles: int, seed: int = 0) -> CharacterScene:
    """Sample, parameterise and schedule the simulation of `vertices` (V, 3) bind pose driven by `animation`."""
    info: dict[str, Any] = {}
    grid = int(np.ceil(opts.grid / 4) * 4)
    if grid != opts.grid:
        info["grid_note"] = f"grid rounded up from {opts.grid} to {grid} (multiple of the 4³ block)"
    world = animation_world_transforms(skeleton, animation)
    bind_world = bind_matrices(skeleton)
    lbs = linear_blend(vertices, weights, skinning_matrices(skeleton, world))
    used = referenced_mesh(vertices, faces).ids  # vertices no face uses must not widen the domain
    surface, moving = vertices[used], lbs[:, used]
    boxes = np.concatenate([np.stack([surface.min(0), surface.max(0)])[None], np.stack([moving.min(1), moving.max(1)], axis=1)])
    extent = float((boxes[:, 1] - boxes[:, 0]).max())
    dx = extent / (grid - 2 * (BOUND + MARGIN_NODES))
    centres = 0.5 * (boxes[1:, 0] + boxes[1:, 1])
    bind_centre = 0.5 * (boxes[0, 0] + boxes[0, 1])

    sample = sample_volume(vertices, faces, 0.5 * dx, max_particles=max_particles, seed=seed)
    material = PRESETS[opts.preset]
    protos = seed_prototypes(sample.positions, opts.prototypes, material, sample.volume, seed=seed)
    stiffness = None
    if opts.bone_stiffness:
        pw = nearest_rows(vertices, weights, sample.positions)
        stiffness = region_stiffness(pw, skeleton.names, opts.bone_stiffness)
    mu, lam = particle_lame(prototype_weights(sample.positions, protos), protos, stiffness)

    drivers = place_drivers(skeleton, opts.drivers, dx, tips=leaf_tips(skeleton, surface, weights[used]))
    frame_dt = 1.0 / float(animation.fps)
    dt_paper = (1.0 / PAPER_FPS) / opts.substeps
    dt_wave = CFL_WAVE * dx / max_wave_speed(protos, material.density, stiffness)
    path = driver_positions(drivers, np.concatenate([bind_world[None], world]))
    v_drive = float(np.linalg.norm(np.diff(path, axis=0), axis=2).max() / frame_dt) if len(path) > 1 else 0.0
    dt_drive = CFL_DRIVE * dx / v_drive if v_drive > 0 else np.inf
    dt_bound = min(dt_paper, dt_wave, dt_drive)
    substeps = int(np.ceil(frame_dt / dt_bound - 1e-9))
    if substeps > MAX_SUBSTEPS:
        raise InvalidInput(f"refinement would need {substeps} substeps per frame (motion too fast or material too "
                           f"stiff for grid {grid}); use a softer preset or a coarser grid",
                           code="refine_too_stiff", field="refine.preset")
    info.update({
        "grid": grid, "dx_m": round(dx, 6), "particles": sample.count, "particle_counts": sample.counts,
        "driving_points": drivers.count, "drivers": opts.drivers, "preset": opts.preset,
        "prototypes": protos.count, "substeps_per_frame": substeps, "dt_s": frame_dt / substeps,
        "dt_limits_s": {"paper": dt_paper, "wave_cfl": dt_wave, "drive_cfl": None if np.isinf(dt_drive) else dt_drive},
        "max_driver_speed_m_s": round(v_drive, 4), "notes": list(sample.notes),
    })
    return CharacterScene(sample, mu, lam, drivers, material.density, grid, dx, frame_dt / substeps, substeps, frame_dt,
                          world, bind_world, lbs, centres, bind_centre, info)

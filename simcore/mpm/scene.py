"""Set up the soft-body simulation of a rigged, animated character: grid, particles, materials, drivers, Δt.

Timeline: the clip is resampled at `opts.rate` (slerped joint transforms), after `opts.preroll_frames` keys
easing from the bind pose into clip frame 0; the simulation steps from key to key and the refine loop
records the keys that fall on the clip. The grid is a cube of `grid` nodes that follows the body: at each key
it is centred on the LBS pose's bounding box (moving the Eulerian grid between substeps is legal in MPM, it
holds no state), and its cell size fits the largest posed extent plus a margin. Particles are sampled at half
a cell (about 8 per cell).

Drivers: the key joint transforms are smoothed once and speed-limited per joint (a joint whose driving
points would move faster than `DRIVER_SPEED_HEIGHTS` character heights per second lags and catches up,
`limit_world`), so a skeleton pop in a mocap clip cannot fling the flesh; the refined offset is measured
from the LBS of these limited keys and added to the clip's own LBS. Within a key interval drivers move
linearly.
Δt = min(CFL bound of the P-wave speed, CFL bound of the fastest (limited) driver, the optional
`substeps` floor), and each key interval takes as many equal substeps as that bound needs.
Tether: every particle stays within `opts.max_offset` character heights of its skinned position, and within
`TETHER_LIMB` of its limb's radius (`simcore.gate.measures.bone_radii` at its nearest vertex: a thin part may
move less than a thick one before its volume changes), so the refined surface is bounded by the character's
size whatever the motion (`kernels.tether`).
"""

from __future__ import annotations

import os
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import scipy.sparse as sp
from scipy.spatial import cKDTree

from simcore.errors import InvalidInput
from simcore.gate.measures import bone_radii
from simcore.geometry.referenced import referenced_mesh
from simcore.motion.types import JointAnimation
from simcore.mpm.drivers import DrivingPoints, animation_world_transforms, driver_positions, interpolate_transforms, leaf_tips, place_drivers
from simcore.mpm.materials import PRESETS, max_wave_speed, particle_lame, prototype_weights, region_stiffness, seed_prototypes
from simcore.mpm.sampling import ParticleSample, nearest_rows, sample_on_grid
from simcore.mpm.simulate import FramePlan
from simcore.options import RefineOptions
from simcore.skeleton.kinematics import bind_matrices
from simcore.skeleton.types import Skeleton
from simcore.skinning.lbs import linear_blend

BOUND = 3  # wall band in nodes
MARGIN_NODES = 4  # free nodes between the body's box and the wall band on each side
CFL_WAVE = 0.4  # Δt ≤ CFL_WAVE · dx / P-wave speed
CFL_DRIVE = 0.5  # Δt ≤ CFL_DRIVE · dx / fastest driver speed (half a cell, as the particle velocity clamp)
PAPER_FPS = 25.0  # the substeps option counts per 25 fps frame (PhysRig: 100 → Δt = 4e-4 s)
MAX_SUBSTEPS = 2000
# Driver speed limit in character heights per second: a sprinter's foot moves under 10 heights/s, a
# retargeting pop (a joint flipping between two keys) far faster.
DRIVER_SPEED_HEIGHTS = 8.0
INFLUENCES = 4  # skinning influences per particle for the tether
TETHER_LIMB = 0.25  # tether radius at most this share of the limb's radius


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


def key_times(frames: int, fps: float, rate: float) -> np.ndarray:
    """(K,) clip times (s) of the simulation keys: every 1 / rate from 0, plus the clip's last frame time."""
    duration = (frames - 1) / float(fps)
    times = np.arange(int(np.floor(duration * rate + 1e-9)) + 1) / float(rate)
    if duration - times[-1] > 1e-6:
        times = np.append(times, duration)
    return times


def resample_world(world: np.ndarray, fps: float, times: np.ndarray) -> np.ndarray:
    """(K, J, 4, 4) joint world transforms at `times` (s) from per-frame ones (T, J, 4, 4) at `fps` (slerp + lerp)."""
    f = np.clip(np.asarray(times) * fps, 0.0, len(world) - 1)
    lo = np.minimum(np.floor(f).astype(int), len(world) - 1)
    hi = np.minimum(lo + 1, len(world) - 1)
    return np.stack([interpolate_transforms(world[a], world[b], np.array([t - a]))[0] for a, b, t in zip(lo, hi, f)])


def limit_world(world: np.ndarray, drivers: DrivingPoints, times: np.ndarray, limit: float) -> tuple[np.ndarray, int]:
    """Smooth joint key transforms (K, J, 4, 4) once (each key halfway to its neighbours' midpoint, ends kept),
    then cap every joint's speed: where one of its driving points would move faster than `limit` m/s between
    keys at `times` (K,), the joint only goes the allowed fraction of the way (slerp) and catches up later.
    Drivers and the tether's skinned targets both follow the result, so they never disagree.
    Returns the transforms and how many (key, joint) steps were capped."""
    smooth = world.copy()
    if len(world) > 2:
        mid = np.stack([interpolate_transforms(world[k - 1], world[k + 1], np.array([0.5]))[0] for k in range(1, len(world) - 1)])
        smooth[1:-1] = np.stack([interpolate_transforms(world[k], mid[k - 1], np.array([0.5]))[0] for k in range(1, len(world) - 1)])
    out = smooth.copy()
    joints = world.shape[1]
    capped = 0
    for k in range(1, len(out)):
        reach = limit * float(times[k] - times[k - 1])
        step = np.linalg.norm(driver_positions(drivers, smooth[k:k + 1])[0] - driver_positions(drivers, out[k - 1:k])[0], axis=1)
        worst = np.zeros(joints)
        np.maximum.at(worst, drivers.joints, step)
        alpha = np.where(worst > reach, reach / np.maximum(worst, 1e-12), 1.0)
        if (alpha < 1.0).any():
            capped += int((alpha < 1.0).sum())
            out[k] = interpolate_transforms(out[k - 1], smooth[k], alpha[None])[0]
    return out, capped


def top_influences(weights: sp.spmatrix, k: int = INFLUENCES) -> tuple[np.ndarray, np.ndarray]:
    """(N, k) int32 joint indices and (N, k) float32 weights (rows renormalised) of the k largest weights per row."""
    dense = np.asarray(sp.csr_matrix(weights).todense(), np.float64)
    k = min(k, dense.shape[1])
    idx = np.argsort(-dense, axis=1)[:, :k]
    w = np.take_along_axis(dense, idx, axis=1)
    w /= np.maximum(w.sum(axis=1, keepdims=True), 1e-12)
    pad = INFLUENCES - k
    if pad:
        idx = np.pad(idx, ((0, 0), (0, pad)))
        w = np.pad(w, ((0, 0), (0, pad)))
    return idx.astype(np.int32), w.astype(np.float32)


@dataclass
class CharacterScene:
    """Everything the refine loop needs; arrays in world space, metres.

    sample: particles; mu, lam: (N,) float32 Pa; drivers: driving points; density: kg/m³;
    grid, dx: nodes per axis and spacing (m); dt: largest stable substep (s);
    keys: (K,) key times (s), preroll keys first (negative times); world: (K, J, 4, 4) limited joint transforms;
    paths: (K, D, 3) limited driver positions per key; centres: (K, 3) grid centre per key;
    first_output: index of the key at clip time 0; inv_bind: (J, 4, 4);
    skin_joints, skin_weights: (N, 4) particle skinning influences; tether_radius: (N,) float32 m (all 0: no tether);
    height: character height (largest bind extent), m.
    """

    sample: ParticleSample
    mu: np.ndarray
    lam: np.ndarray
    drivers: DrivingPoints
    density: float
    grid: int
    dx: float
    dt: float
    keys: np.ndarray
    world: np.ndarray
    paths: np.ndarray
    centres: np.ndarray
    first_output: int
    inv_bind: np.ndarray
    skin_joints: np.ndarray
    skin_weights: np.ndarray
    tether_radius: np.ndarray
    height: float
    info: dict[str, Any] = field(default_factory=dict)

    def origin(self, centre: np.ndarray) -> np.ndarray:
        return np.asarray(centre, dtype=np.float64) - 0.5 * (self.grid - 1) * self.dx

    def substeps(self, k: int) -> int:
        """Substeps of the interval from key k to k + 1."""
        return max(1, int(np.ceil((self.keys[k + 1] - self.keys[k]) / self.dt - 1e-9)))

    def total_substeps(self) -> int:
        return sum(self.substeps(k) for k in range(len(self.keys) - 1))

    def plan(self, k: int) -> FramePlan:
        """The FramePlan of the interval from key k to k + 1."""
        n = self.substeps(k)
        h = float(self.keys[k + 1] - self.keys[k])
        a = np.arange(n + 1) / n
        pos = (1.0 - a)[:, None, None] * self.paths[k][None] + a[:, None, None] * self.paths[k + 1][None]
        dv = np.repeat(((self.paths[k + 1] - self.paths[k]) / h)[None], n, axis=0)
        origins = self.origin((1.0 - a[:-1, None]) * self.centres[k] + a[:-1, None] * self.centres[k + 1])
        skin = None
        if self.tether_radius.max() > 0:
            skin = interpolate_transforms(self.world[k], self.world[k + 1], a) @ self.inv_bind[None]
        return FramePlan(h / n, origins, pos[:-1].astype(np.float32), dv.astype(np.float32), skin)


def _boxes(surface: np.ndarray, weights: sp.csr_matrix, world: np.ndarray, inv_bind: np.ndarray) -> np.ndarray:
    """(K, 2, 3) LBS bounding box (min, max) per key, in blocks: (K, V, 3) at once is large for long clips."""
    out = []
    for start in range(0, len(world), 32):
        moving = linear_blend(surface, weights, world[start:start + 32] @ inv_bind[None])
        out.append(np.stack([moving.min(1), moving.max(1)], axis=1))
    return np.concatenate(out)


def build_scene(vertices: np.ndarray, faces: np.ndarray, skeleton: Skeleton, weights: sp.csr_matrix, animation: JointAnimation,
                opts: RefineOptions, *, device: str, max_particles: int, seed: int = 0) -> CharacterScene:
    """Sample, parameterise and schedule the simulation of `vertices` (V, 3) bind pose driven by `animation`."""
    info: dict[str, Any] = {}
    clip_world = animation_world_transforms(skeleton, animation)
    bind_world = bind_matrices(skeleton)
    inv_bind = np.linalg.inv(bind_world)
    times = key_times(animation.num_frames, animation.fps, opts.rate)
    world = resample_world(clip_world, animation.fps, times)
    pre = int(opts.preroll_frames)
    if pre:
        a = np.arange(pre) / pre
        ease = a * a * (3.0 - 2.0 * a)
        world = np.concatenate([interpolate_transforms(bind_world, world[0], ease), world])
        times = np.concatenate([(np.arange(pre) - pre) / float(opts.rate), times])
    used = referenced_mesh(vertices, faces).ids  # vertices no face uses must not widen the domain
    surface = vertices[used]
    w_used = sp.csr_matrix(weights)[used]
    box = np.concatenate([np.stack([surface.min(0), surface.max(0)])[None], _boxes(surface, w_used, world, inv_bind)])
    extent = float((box[:, 1] - box[:, 0]).max())
    height = float((box[0, 1] - box[0, 0]).max())
    placed = sample_on_grid(vertices, faces, extent, opts.grid, 2 * (BOUND + MARGIN_NODES), max_particles=max_particles,
                            seed=seed)
    sample, grid, dx = placed.sample, placed.grid, placed.dx
    if placed.note:
        info["grid_note"] = placed.note
    material = PRESETS[opts.preset]
    protos = seed_prototypes(sample.positions, opts.prototypes, material, sample.volume, seed=seed)
    particle_w = nearest_rows(vertices[used], w_used, sample.positions)
    stiffness = region_stiffness(particle_w, skeleton.names, opts.bone_stiffness) if opts.bone_stiffness else None
    mu, lam = particle_lame(prototype_weights(sample.positions, protos), protos, stiffness)
    skin_joints, skin_weights = top_influences(particle_w)
    limb = bone_radii(skeleton, vertices[used], w_used)[cKDTree(vertices[used]).query(sample.positions)[1]]
    tether = np.minimum(float(opts.max_offset) * height, TETHER_LIMB * limb).astype(np.float32)

    drivers = place_drivers(skeleton, opts.drivers, dx, tips=leaf_tips(skeleton, surface, w_used))
    raw = driver_positions(drivers, world)
    limit = DRIVER_SPEED_HEIGHTS * height
    world, capped = limit_world(world, drivers, times, limit)
    paths = driver_positions(drivers, world)
    limited_box = _boxes(surface, w_used, world, inv_bind)
    centres = 0.5 * (limited_box[:, 0] + limited_box[:, 1])
    gaps = np.diff(times)[:, None]
    v_raw = float((np.linalg.norm(np.diff(raw, axis=0), axis=2) / gaps).max()) if len(raw) > 1 else 0.0
    v_drive = float((np.linalg.norm(np.diff(paths, axis=0), axis=2) / gaps).max()) if len(paths) > 1 else 0.0
    dt_floor = (1.0 / PAPER_FPS) / opts.substeps if opts.substeps else np.inf
    dt_wave = CFL_WAVE * dx / max_wave_speed(protos, material.density, stiffness)
    dt_drive = CFL_DRIVE * dx / v_drive if v_drive > 0 else np.inf
    dt = float(min(dt_floor, dt_wave, dt_drive))
    longest = float(np.diff(times).max()) if len(times) > 1 else 0.0
    if longest / dt > MAX_SUBSTEPS:
        raise InvalidInput(f"refinement would need {int(np.ceil(longest / dt))} substeps per key (material too "
                           f"stiff for grid {grid}); use a softer preset or a coarser grid",
                           code="refine_too_stiff", field="refine.preset")
    scene = CharacterScene(sample, mu, lam, drivers, material.density, grid, dx, dt, times, world, paths, centres,
                           pre, inv_bind, skin_joints, skin_weights, tether, height, info)
    info.update({
        "grid": grid, "dx_m": round(dx, 6), "particles": sample.count, "particle_counts": sample.counts,
        "particles_per_cell": round(placed.per_cell, 2),
        "driving_points": drivers.count, "drivers": opts.drivers, "preset": opts.preset,
        "prototypes": protos.count, "rate_fps": opts.rate, "keys": len(times), "clip_fps": float(animation.fps),
        "substeps_total": scene.total_substeps(), "dt_s": dt,
        "dt_limits_s": {"floor": None if np.isinf(dt_floor) else dt_floor, "wave_cfl": dt_wave,
                        "drive_cfl": None if np.isinf(dt_drive) else dt_drive},
        "driver_speed_limit_m_s": round(limit, 4), "max_driver_speed_m_s": round(v_drive, 4),
        "max_driver_speed_unlimited_m_s": round(v_raw, 4), "driver_steps_capped": capped,
        "height_m": round(height, 5), "tether_radius_m": {"max": round(float(tether.max()), 6),
                                                          "median": round(float(np.median(tether)), 6)},
        "notes": list(sample.notes),
    })
    return scene

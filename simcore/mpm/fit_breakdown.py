"""Where the physics fit's error comes from: forward runs that are told more and more of the answer (no fitting).

On the fit's own scene (grid, particles, substeps, material), with every other setting as the fit has it:
- `observed`: every particle is a driving point aimed, at each frame end, at the observed motion (a vertex at its
  observed position, any other particle moved with the displacement of its nearest vertices). Nothing is left to
  the material or to the fit, so what remains is the solver's own floor: the grid carries velocity, not particles,
  and a particle moves with the grid's smoothed velocity field, not with its own target;
- `anchor_motion`: every particle aimed at where its joints' per-frame rigid motions put it (the motions the
  fit's driving points are aimed at, blended with the particle's coarse weights): all that the drivers know,
  given to every particle;
- `drivers`: the fit's driving points alone, the body carried by the material (the physics fit before any step).

Beside them, LBS with the coarse weights and those same rigid motions and no optimiser step (`lbs_motion`): what
the `anchor_motion` row would be without the solver.
"""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Callable
from typing import Any

import numpy as np
from scipy.spatial import cKDTree

from simcore.mpm.fit import FitConfig, FitScene, PhysicsFit, per_frame_chamfer
from simcore.mpm.lbs_fit import fit_lbs

NEAREST = 8  # vertices whose observed displacement moves a particle in the `observed` row


def observed_motion(scene: FitScene) -> np.ndarray:
    """(T, N, 3) every particle moved as the observed sequence moves: vertices exactly, other particles by the
    inverse-square-distance blend of the displacements of their NEAREST nearest frame-0 vertices."""
    rest = scene.targets[0]
    dist, idx = cKDTree(rest).query(scene.x0, k=min(NEAREST, len(rest)))
    dist, idx = dist.reshape(len(scene.x0), -1), idx.reshape(len(scene.x0), -1)
    w = 1.0 / np.maximum(dist, 1e-9) ** 2
    w /= w.sum(axis=1, keepdims=True)
    moved = scene.x0[None] + np.einsum("nk,tnka->tna", w, (scene.targets - rest[None])[:, idx])
    simulated = scene.vertex_particles >= 0
    moved[:, scene.vertex_particles[simulated]] = scene.targets[:, simulated]
    return moved


def anchor_motion(scene: FitScene) -> np.ndarray:
    """(T, N, 3) every particle moved by its joints' per-frame rigid motions (the scene's `joint_motion`, the
    fit's anchors' source) blended with its coarse weights (`particle_weights`)."""
    if scene.joint_motion is None or scene.particle_weights is None:
        raise ValueError("the scene has no joint motions (prepare_scene makes them)")
    rot, trans = scene.joint_motion
    w = scene.particle_weights / np.maximum(scene.particle_weights.sum(axis=1, keepdims=True), 1e-12)
    return np.einsum("nm,tmab,nb->tna", w, rot, scene.x0) + np.einsum("nm,tma->tna", w, trans)


def every_particle_driven(scene: FitScene, paths: np.ndarray) -> FitScene:
    """The scene with one driving point per particle, each aimed at its own path (T, N, 3) (anchored drive,
    embedded in its own particle, so each interval starts from where the particle is)."""
    n = len(scene.x0)
    return dataclasses.replace(scene, drivers0=scene.x0.copy(), anchors=np.asarray(paths, np.float64),
                               driver_particles=np.arange(n)[:, None], velocities=np.zeros((len(paths) - 1, n, 3)))


def forward_chamfer(scene: FitScene, config: FitConfig) -> np.ndarray:
    """(T,) per-frame chamfer of one forward run of the scene (anchored drive, no fitted correction)."""
    return per_frame_chamfer(PhysicsFit(scene, dataclasses.replace(config, drive="anchored")).simulate(), scene.targets)


def error_breakdown(scene: FitScene, config: FitConfig) -> dict[str, Any]:
    """Mean chamfer ×100 over frames ≥ 1 (and seconds) of each row of the module docstring on one prepared scene."""
    rows: dict[str, Any] = {}

    def timed(name: str, run: Callable[[], np.ndarray]) -> None:
        started = time.perf_counter()
        per_frame = run()
        rows[name] = {"mean": round(100 * float(per_frame[1:].mean()), 4), "seconds": round(time.perf_counter() - started, 2)}

    timed("observed", lambda: forward_chamfer(every_particle_driven(scene, observed_motion(scene)), config))
    timed("anchor_motion", lambda: forward_chamfer(every_particle_driven(scene, anchor_motion(scene)), config))
    timed("drivers", lambda: forward_chamfer(scene, config))
    timed("lbs_motion", lambda: per_frame_chamfer(fit_lbs(scene.targets, scene.joints, 0, scale=scene.dx,
                                                          init_weights=scene.joint_weights,
                                                          init_motion=scene.joint_motion)[0], scene.targets))
    return {"grid": scene.grid, "dx": round(scene.dx, 5), "particles": int(len(scene.x0)), "substeps": scene.substeps,
            "driving_points": int(len(scene.drivers0)), "grid_note": scene.grid_note, "rows": rows}


def scaled_config(config: FitConfig, grid: int) -> FitConfig:
    """config at another grid with the same particles per cell (budget × (grid / config.grid)³) and the same
    substep length in cells (substeps × grid / config.grid)."""
    ratio = grid / config.grid
    return dataclasses.replace(config, grid=grid, max_particles=int(round(config.max_particles * ratio**3)),
                               substeps=max(1, int(round(config.substeps * ratio))))

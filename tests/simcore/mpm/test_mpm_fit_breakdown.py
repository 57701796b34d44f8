import dataclasses

import numpy as np
from scipy.spatial.transform import Rotation

from simcore.mpm.fit import FitConfig, prepare_scene
from simcore.mpm.fit_breakdown import error_breakdown, every_particle_driven, forward_chamfer, observed_motion, scaled_config
from simcore.mpm.fit_experiment import synthetic_bar

CONFIG = FitConfig(prototypes=2, grid=24, substeps=10, max_particles=800, drivers="virtual", virtual_joints=2)


def _bending_bar(frames: int = 5) -> tuple[np.ndarray, np.ndarray]:
    """A bar whose +X half bends up about its middle by 8° a frame, blended over the middle fifth."""
    vertices, faces = synthetic_bar(8)
    share = np.clip((vertices[:, 0] + 0.1) / 0.2, 0.0, 1.0)
    turns = [Rotation.from_rotvec(np.outer(np.radians(8.0 * t) * share, [0.0, 0.0, 1.0])) for t in range(frames)]
    return np.stack([turn.apply(vertices) for turn in turns]), faces


def test_observed_motion_puts_vertices_on_their_targets_and_carries_a_translation_exactly():
    vertices, faces = synthetic_bar(8)
    targets = np.stack([vertices + [0.02 * t, 0.0, 0.0] for t in range(4)])
    scene = prepare_scene(targets, faces, 25.0, CONFIG)
    moved = observed_motion(scene)
    assert np.allclose(moved[:, scene.vertex_particles], targets)
    assert np.allclose(moved - scene.x0[None], targets[:, :1] - targets[:1, :1])
    # told every particle's path, the solver follows a translation to rounding
    assert forward_chamfer(every_particle_driven(scene, moved), CONFIG)[1:].max() < 1e-4


def test_the_breakdown_rows_fall_as_the_runs_are_told_more():
    targets, faces = _bending_bar()
    scene = prepare_scene(targets, faces, 25.0, CONFIG)
    rows = error_breakdown(scene, CONFIG)["rows"]
    assert set(rows) == {"observed", "anchor_motion", "drivers", "lbs_motion"}
    assert rows["observed"]["mean"] < rows["drivers"]["mean"]
    assert all(np.isfinite(r["mean"]) and r["mean"] >= 0 for r in rows.values())


def test_a_scaled_config_keeps_particles_per_cell_and_substep_length_in_cells():
    scaled = scaled_config(dataclasses.replace(CONFIG, grid=32, max_particles=3000, substeps=25), 64)
    assert (scaled.grid, scaled.max_particles, scaled.substeps) == (64, 24000, 50)

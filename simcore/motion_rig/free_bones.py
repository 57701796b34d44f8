"""Free rigid bones, sparse weights and per-frame bone transforms from Dem Bones (SSDR, `py-dem-bones`)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from simcore.errors import SimcoreError


class MotionRigUnavailable(SimcoreError):
    """The Dem Bones solver (`py-dem-bones`) is not installed on this worker."""

    code = "motion_rig_unavailable"


@dataclass
class BoneFit:
    """An LBS fit of a mesh sequence.

    weights:    (V, B) float64, rows sum to 1, at most `max_influences` non-zeros per row.
    transforms: (T, B, 4, 4) float64 rigid bone transforms from the rest pose to frame t (column vectors).
    """

    weights: np.ndarray
    transforms: np.ndarray

    @property
    def num_bones(self) -> int:
        return int(self.weights.shape[1])


def _solver_module():  # noqa: ANN202 - the native module has no stubs
    try:
        from py_dem_bones import portable
    except ImportError as exc:
        raise MotionRigUnavailable("rigging from motion needs py-dem-bones (pip install py-dem-bones)") from exc
    return portable


def _prepared(rest: np.ndarray, frames: np.ndarray, faces: np.ndarray, bones: int, max_influences: int,
              iterations: int):  # noqa: ANN202
    """A Dem Bones solver loaded with one subject (the layout py_dem_bones.portable uses; faces are our own
    checked triangles, so its per-face Python validation is skipped)."""
    portable = _solver_module()
    from py_dem_bones import DemBones

    solver = DemBones()
    count, steps = rest.shape[0], frames.shape[0]
    solver.nV, solver.nF, solver.nS, solver.nB = count, steps, 1, int(bones)
    solver.nnz = int(min(max_influences, bones))
    solver.nIters = int(iterations)
    solver.fStart = np.array([0, steps], dtype=np.int32)
    solver.subjectID = np.zeros(steps, dtype=np.int32)
    solver.u = np.ascontiguousarray(rest.T, dtype=np.float64)
    solver.v = np.ascontiguousarray(frames.transpose(0, 2, 1).reshape(3 * steps, count), dtype=np.float64)
    solver.fv = np.asarray(faces, dtype=np.int64).tolist()
    return portable, solver


def _one_thread():  # noqa: ANN202
    """Dem Bones' OpenMP threads busy-wait; on cores shared with other work they stall each other (run on one)."""
    from threadpoolctl import threadpool_limits

    return threadpool_limits(1, user_api="openmp")


def solve_free_bones(rest: np.ndarray, frames: np.ndarray, faces: np.ndarray, bones: int, *,
                     max_influences: int, iterations: int) -> BoneFit:
    """Dem Bones from scratch: up to `bones` free rigid bones (it may return fewer), weights and transforms.

    rest: (V, 3) bind pose; frames: (T, V, 3) the sequence, same vertex order; faces: (F, 3) int.
    """
    portable, solver = _prepared(rest, frames, faces, bones, max_influences, iterations)
    with _one_thread():
        solver.compute()
    result = portable._read_skinning_result(solver)
    return _compact(BoneFit(result.weights.T.copy(), result.transforms))


def solve_from_clusters(rest: np.ndarray, frames: np.ndarray, faces: np.ndarray, bones: int, *,
                        max_influences: int, iterations: int) -> BoneFit:
    """Dem Bones started from `bones` k-means clusters of the vertex trajectories (rigidly bound), for sequences
    where its own cluster splitting stalls."""
    from sklearn.cluster import KMeans

    trajectories = frames.transpose(1, 0, 2).reshape(frames.shape[1], -1)
    labels = KMeans(n_clusters=int(bones), n_init=1, random_state=0).fit_predict(trajectories)
    start = np.zeros((int(bones), len(rest)))
    start[labels, np.arange(len(rest))] = 1.0
    portable, solver = _prepared(rest, frames, faces, bones, max_influences, iterations)
    solver.set_weights(start)
    with _one_thread():
        solver.compute()
    result = portable._read_skinning_result(solver)
    return _compact(BoneFit(result.weights.T.copy(), result.transforms))


def solve_weights(rest: np.ndarray, frames: np.ndarray, faces: np.ndarray, fit: BoneFit, *, max_influences: int,
                  iterations: int) -> np.ndarray:
    """(V, B) weights re-solved by Dem Bones for the fixed `fit.transforms`, starting from `fit.weights`."""
    portable, solver = _prepared(rest, frames, faces, fit.num_bones, max_influences, iterations)
    solver.m = portable._pack_transformations(fit.transforms)
    solver.lockM = np.ones(fit.num_bones, np.int32)  # transforms stay as given: only weights move
    solver.set_weights(np.ascontiguousarray(fit.weights.T))
    with _one_thread():
        solver.compute()
    return np.asarray(solver.get_weights(), dtype=np.float64).T.copy()


def _compact(fit: BoneFit) -> BoneFit:
    """Drop bones that weigh no vertex (Dem Bones may leave some empty)."""
    used = fit.weights.max(axis=0) > 0
    return BoneFit(fit.weights[:, used], fit.transforms[:, used])


def reconstruct(rest: np.ndarray, weights: np.ndarray, transforms: np.ndarray) -> np.ndarray:
    """(T, V, 3) LBS of `rest` (V, 3) by `weights` (V, B) and `transforms` (T, B, 4, 4)."""
    out = np.zeros((transforms.shape[0], len(rest), 3))
    for b in range(weights.shape[1]):  # bone by bone over its own vertices: memory stays (T, V, 3)
        on = np.flatnonzero(weights[:, b])
        moved = np.einsum("tij,vj->tvi", transforms[:, b, :3, :3], rest[on]) + transforms[:, b, None, :3, 3]
        out[:, on] += weights[on, b, None] * moved
    return out


def rmse(reconstructed: np.ndarray, frames: np.ndarray) -> np.ndarray:
    """(T,) per-frame root-mean-square vertex distance between two (T, V, 3) sequences."""
    return np.sqrt(((reconstructed - frames) ** 2).sum(-1).mean(-1))

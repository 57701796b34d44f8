"""Skinning weights for a mesh and a skeleton: the methods, post-processing and the `auto` choice."""

from __future__ import annotations

import threading
import time
from collections.abc import Callable
from concurrent.futures import FIRST_COMPLETED, ThreadPoolExecutor, wait
from dataclasses import dataclass, field
from typing import Literal

import numpy as np
import scipy.sparse as sp
from scipy.spatial import cKDTree

from simcore.cores import usable_cores
from simcore.errors import Canceled, InvalidInput, LimitExceeded
from simcore.geometry.laplacian import adjacency
from simcore.geometry.parts import part_labels, welded_part_labels
from simcore.geometry.referenced import ReferencedMesh, referenced_mesh
from simcore.geometry.weld import weld_vertices
from simcore.model_weights import ModelUnavailable
from simcore.skeleton.types import JointKind, Skeleton
from simcore.skinning.geodesic import geodesic_weights
from simcore.skinning.heat import heat_weights
from simcore.skinning.learned import SHIPPED, LearnedSkinning, learned_summary, learned_weights
from simcore.skinning.mirror_weights import weight_mirror
from simcore.skinning.parts import bind_rigid_parts
from simcore.skinning.postprocess import SMOOTH_ITERATIONS, normalize_rows, smooth_on_surface, top_k
from simcore.skinning.proxy import PROXY_VERTICES, simplified, transfer
from simcore.skinning.quality import quality_scores
from simcore.skinning.steepness import limit_steepness

Method = Literal["auto", "learned", "geodesic", "heat"]
METHODS: dict[str, Callable[..., np.ndarray]] = {  # (vertices, faces, skeleton, *, progress) -> (V, J) weights
    "learned": learned_weights,
    "geodesic": geodesic_weights,
    "heat": heat_weights,
}
HAND_WRITTEN = ("geodesic", "heat")  # what `auto` compares by unsupervised score when the learned model is unavailable
MAX_VERTICES = 2_000_000
MAX_JOINTS = 1024
# The methods hold dense (vertices × joints) arrays: bench/skinning.py peaks at 3.7 GB for 530k × 60 (about
# 115 bytes per entry), so 100M entries is ~11.5 GB, what one job may take of a 24 GB, 2-worker machine.
MAX_ENTRIES = 100_000_000
PROGRESS_POLL_S = 0.25  # how often `auto`'s caller hears the methods' progress (and can cancel)
SMOOTH_STRENGTH = 0.25  # per pass: evens out voxel-grid steps while keeping weights as sharp as artists' are
SMOOTH_REACH = 1 / 16  # × the model size: edges up to this long count fully in the smoothing (8 geodesic-grid voxels)


@dataclass
class SkinningResult:
    """weights: (V, J) float32 CSR, ≤ max_influences per row, rows sum to 1.
    method: the method that produced them; scores: method → unsupervised quality signals (see quality.py),
    plus "seconds" per method; reason: why `auto` chose it (empty for a named method)."""

    weights: sp.csr_matrix
    method: str
    scores: dict[str, dict[str, float]] = field(default_factory=dict)
    reason: str = ""
    mirror: dict[str, object] | None = None  # report of `mirror_weights` when the weights were mirrored, else None


def _check_inputs(vertices: np.ndarray, faces: np.ndarray, skeleton: Skeleton, max_influences: int) -> tuple[np.ndarray, np.ndarray]:
    v = np.asarray(vertices, dtype=np.float64)
    f = np.asarray(faces)
    if v.ndim != 2 or v.shape[1] != 3 or len(v) == 0:
        raise InvalidInput("vertices must be a non-empty (V, 3) array", code="invalid_mesh", field="mesh")
    if len(v) > MAX_VERTICES:
        raise LimitExceeded(f"{len(v)} vertices is over the skinning limit of {MAX_VERTICES}", code="too_many_vertices", field="mesh")
    if not np.all(np.isfinite(v)):
        raise InvalidInput("vertices contain NaN or infinity", code="invalid_mesh", field="mesh")
    if f.ndim != 2 or f.shape[1] != 3 or len(f) == 0 or not np.issubdtype(f.dtype, np.integer):
        raise InvalidInput("faces must be a non-empty (F, 3) integer array", code="invalid_mesh", field="mesh")
    if f.min() < 0 or f.max() >= len(v):
        raise InvalidInput("a face indexes a vertex that does not exist", code="invalid_mesh", field="mesh")
    skeleton.validate()
    if skeleton.num_joints > MAX_JOINTS:
        raise LimitExceeded(f"{skeleton.num_joints} joints is over the skinning limit of {MAX_JOINTS}", code="too_many_joints", field="skeleton")
    if len(v) * skeleton.num_joints > MAX_ENTRIES:
        raise LimitExceeded(f"{len(v)} vertices × {skeleton.num_joints} joints is over the skinning limit of {MAX_ENTRIES:,} "
                            "weights; lower max_joints or decimate the mesh", code="too_large_to_skin", field="mesh")
    if max_influences < 1:
        raise InvalidInput("max_influences must be at least 1", code="invalid_option", field="max_influences")
    return v, f.astype(np.int64)


def compute_weights(
    vertices: np.ndarray,
    faces: np.ndarray,
    skeleton: Skeleton,
    *,
    method: Method = "auto",
    max_influences: int = 4,
    smooth_iterations: int = SMOOTH_ITERATIONS,
    progress: Callable[[float], None] | None = None,
    root_deforms: bool = False,
    exclude: np.ndarray | None = None,
    learned: LearnedSkinning = SHIPPED,
) -> SkinningResult:
    """Skinning weights of a mesh for a skeleton in the same space.

    vertices: (V, 3) float, faces: (F, 3) int, skeleton: J joints. Every method's weights end with each separate
    mesh part that leans mostly on one joint, or holds no joint, bound to one joint alone (parts.py).
    `auto` takes the learned model, which scores better than the hand-written methods on the corpus's `val`
    split (its file carries those figures); when its weights cannot be read, `auto` runs geodesic and heat
    and keeps the lower unsupervised `score`. root_deforms: the skeleton was predicted, so its root is a body joint
    that bends the mesh, not an artist's armature root (the learned method uses it; see learned.py).
    exclude: (J,) bool joints that get no weight (never the root): they stay in the tree, so every other bone keeps
    its shape, but own no bone to skin to (JointKind.HELPER, see bones.py) and their columns stay empty.
    learned: the learned method's weights file and prior share (the shipped ones; evaluations try others).
    Raises InvalidInput / LimitExceeded for unusable input.
    """
    if exclude is not None and np.any(exclude):
        if exclude[0]:
            raise InvalidInput(f"the root joint {skeleton.names[0]!r} cannot be left out; every vertex needs a joint to follow",
                               code="invalid_option", field="options.exclude_joints")
        skeleton = skeleton.with_helpers(exclude)
    if method != "auto" and method not in METHODS:
        raise InvalidInput(f"unknown skinning method {method!r}; use auto, {', '.join(METHODS)}", code="invalid_option", field="skinning")
    reason, use_learned = "", False
    if method == "auto":
        try:
            reason, use_learned = learned_summary(learned), True
        except ModelUnavailable as exc:
            reason = f"{exc}; chose the hand-written method with the best unsupervised score"
    v, f = _check_inputs(vertices, faces, skeleton, max_influences)
    mesh = referenced_mesh(v, f)  # vertices no face uses would stretch the voxel grid; they get weights at the end
    v, f = mesh.vertices, mesh.faces
    on_proxy = len(v) > PROXY_VERTICES  # large meshes: weights on a simplified copy, memory bounded (proxy.py)
    if on_proxy:
        v, f = simplified(v, f)
    report = progress or (lambda fraction: None)
    welded = weld_vertices(v, f)
    adj = adjacency(welded.faces, len(welded.vertices))
    first = np.unique(welded.index, return_index=True)[1]  # one original vertex per welded vertex
    reach = SMOOTH_REACH * float(np.ptp(welded.vertices, axis=0).max())
    helpers = np.array([kind == JointKind.HELPER for kind in skeleton.kinds])

    def run(name: str, step: Callable[[float], None]) -> tuple[sp.csr_matrix, dict[str, float]]:
        started = time.perf_counter()
        extra: dict = {"learned": learned, "root_deforms": root_deforms} if name == "learned" else {}
        dense = METHODS[name](v, f, skeleton, progress=lambda fraction: step(0.8 * fraction), **extra)
        if helpers.any():  # a helper owns no bone, but a method may still leave it a trace (a far learned candidate)
            dense[:, helpers] = 0.0
            dense = normalize_rows(dense)
        # Smooth on the welded surface so seam duplicates stay identical, then map back.
        on_welded = np.zeros((len(welded.vertices), dense.shape[1]))
        on_welded[welded.index] = dense
        smoothed = smooth_on_surface(on_welded, adj, smooth_iterations, SMOOTH_STRENGTH, welded.vertices, reach)
        if smooth_iterations > 0:  # no edge steeper than a bend can carry (steepness.py); 0 passes: the raw weights
            smoothed = limit_steepness(smoothed, welded.faces, welded.vertices, skeleton)
        mirror = mirrored.result()
        dense = (smoothed if mirror is None else mirror.apply(smoothed))[welded.index]
        weights = top_k(dense, max_influences)
        seconds = time.perf_counter() - started
        step(0.9)
        scores = quality_scores(welded.vertices, welded.faces, skeleton, weights[first])
        scores["seconds"] = round(seconds, 3)
        step(1.0)
        return weights, scores

    chosen: list[str] = [method] if method != "auto" else (["learned"] if use_learned else list(HAND_WRITTEN))
    results: dict[str, sp.csr_matrix] = {}
    scores: dict[str, dict[str, float]] = {}
    tracker = _MethodProgress(chosen)
    # The methods are independent and spend most of their time in numpy/scipy calls that release the GIL, so they
    # run side by side; the cost is that every method's (V, J) array lives at once. The mirror search runs beside
    # them too (a method's serial stretches leave a core free).
    with ThreadPoolExecutor(max_workers=max(1, min(len(chosen), usable_cores())) + 1) as pool:
        mirrored = pool.submit(weight_mirror, welded.vertices, skeleton)  # None: the character is not symmetric
        futures = {pool.submit(run, name, tracker.updater(name)): name for name in chosen}
        pending = set(futures)
        try:
            while pending:  # only this thread calls `report` (it may write to the job's database row, or cancel)
                done, pending = wait(pending, timeout=PROGRESS_POLL_S, return_when=FIRST_COMPLETED)
                for future in done:
                    results[futures[future]], scores[futures[future]] = future.result()
                report(tracker.overall())
        except BaseException:
            tracker.stop.set()  # the other method stops at its next checkpoint instead of running on
            raise
    best = min(chosen, key=lambda name: scores[name]["score"])
    weights = transfer(results[best], v, mesh.vertices, max_influences) if on_proxy else results[best]
    # separate pieces mostly on one joint, or holding none, follow one; the parts come from the weld above unless that was the proxy's
    labels = part_labels(mesh.vertices, mesh.faces) if on_proxy else welded_part_labels(welded, adj)
    weights = bind_rigid_parts(mesh.vertices, labels, weights, skeleton.positions[~helpers])  # helpers hold no part
    mirror = mirrored.result()
    return SkinningResult(_all_vertices(weights, mesh, np.asarray(vertices, dtype=np.float64)), best, scores, reason,
                          None if mirror is None else mirror.report())


class _MethodProgress:
    """Each method's fraction done, written by its worker thread and read by the caller's thread; once `stop`
    is set, a method raises Canceled at its next checkpoint."""

    def __init__(self, names: list[str]):
        self.fractions = dict.fromkeys(names, 0.0)
        self.stop = threading.Event()

    def updater(self, name: str) -> Callable[[float], None]:
        def update(fraction: float) -> None:
            if self.stop.is_set():
                raise Canceled("skinning stopped: the other method failed or the job was canceled")
            self.fractions[name] = fraction

        return update

    def overall(self) -> float:
        return sum(self.fractions.values()) / len(self.fractions)


def _all_vertices(weights: sp.csr_matrix, mesh: ReferencedMesh, vertices: np.ndarray) -> sp.csr_matrix:
    """(V, J) weights of every vertex from those of the referenced ones (U, J): an unreferenced vertex takes
    the row of the nearest referenced vertex, so it follows the surface around it."""
    if mesh.complete:
        return weights
    source = np.empty(mesh.count, dtype=np.int64)
    source[mesh.ids] = np.arange(len(mesh.ids))
    stray = np.setdiff1d(np.arange(mesh.count), mesh.ids)
    source[stray] = cKDTree(mesh.vertices).query(vertices[stray])[1]
    return weights[source].tocsr()

"""Driving points (PhysRig §3.3): l = 8 points per joint, carried rigidly by the animated skeleton.

Placement modes:
  "joints": 8 points on the corners of a cube of half-edge `spacing / 2` around each joint.
  "bones":  8 points spread along the bone cores leaving each joint (split over its child bones, evenly
            spaced, the joint end first); a leaf joint's core runs to the centroid of the vertices it
            dominates, to their far end (else it gets the "joints" cube). Each point moves with the joint at the bone's start.
Within a frame, joint world transforms are interpolated (slerp rotations, lerp positions) at every substep and
the velocity imposed over a substep is the displacement over it divided by dt, so the drivers follow the
animated skeleton exactly at frame times.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
from scipy.spatial.transform import Rotation

from simcore.io.joint_tracks import joint_tracks
from simcore.motion.types import JointAnimation
from simcore.skeleton.kinematics import bind_matrices, compose, global_transforms
from simcore.skeleton.types import Skeleton

PER_JOINT = 8  # the paper's l
CUBE = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], dtype=np.float64)


@dataclass
class DrivingPoints:
    """rest: (D, 3) float64 bind-pose positions; joints: (D,) int64 joint whose transform carries each point;
    offsets: (D, 3) float64 position in that joint's bind frame."""

    rest: np.ndarray
    joints: np.ndarray
    offsets: np.ndarray

    @property
    def count(self) -> int:
        return int(len(self.rest))


def leaf_tips(skeleton: Skeleton, vertices: np.ndarray, weights: sp.spmatrix) -> dict[int, np.ndarray]:
    """Bone-core end of each leaf joint, from the vertices it dominates (weight > 0.5): along the direction to
    their centroid, as far as the 90th percentile of their extent in that direction.

    A leaf has no child to point its bone at; without this its part (a head, a tail tip) would be held by a
    cube at its base only and droop. vertices: (V, 3); weights: (V, J).
    """
    w = sp.csc_matrix(weights)
    out = {}
    for j, kids in enumerate(skeleton.children()):
        own = np.asarray(vertices, np.float64)[w[:, j].toarray().ravel() > 0.5]
        if kids or not len(own):
            continue
        axis = own.mean(axis=0) - skeleton.positions[j]
        length = float(np.linalg.norm(axis))
        if length > 1e-9:
            reach = float(np.percentile((own - skeleton.positions[j]) @ (axis / length), 90))
            out[j] = skeleton.positions[j] + axis / length * max(reach, length)
    return out


def place_drivers(skeleton: Skeleton, mode: str, spacing: float, tips: dict[int, np.ndarray] | None = None) -> DrivingPoints:
    """PER_JOINT driving points for every joint (see module doc); spacing: grid cell size, metres.

    tips: bone-core ends for leaf joints (`leaf_tips`); in "bones" mode a leaf's 8 points then run from the
    joint to its tip instead of sitting on a cube around the joint.
    """
    pos, children = skeleton.positions, skeleton.children()
    tips = tips or {}
    points, owners = [], []
    for j in range(skeleton.num_joints):
        ends = [pos[c] for c in children[j]] or ([tips[j]] if j in tips else [])
        if mode == "bones" and ends:
            share = np.full(len(ends), PER_JOINT // len(ends))
            share[: PER_JOINT - share.sum()] += 1  # 8 in total even with 3, 5, ... children
            for end, k in zip(ends, share):
                if k:
                    t = np.arange(k)[:, None] / max(k, 1)  # joint end first, child end excluded
                    points.append(pos[j] + t * (end - pos[j]))
                    owners.append(np.full(k, j))
        else:
            points.append(pos[j] + CUBE * 0.5 * spacing)
            owners.append(np.full(PER_JOINT, j))
    rest = np.concatenate(points)
    joints = np.concatenate(owners).astype(np.int64)
    inv_bind = np.linalg.inv(bind_matrices(skeleton))[joints]  # (D, 4, 4)
    offsets = np.einsum("dab,db->da", inv_bind[:, :3, :3], rest) + inv_bind[:, :3, 3]
    return DrivingPoints(rest, joints, offsets)


def animation_world_transforms(skeleton: Skeleton, animation: JointAnimation) -> np.ndarray:
    """(T, J, 4, 4) float64 world joint transforms per frame of `animation` (joints matched by name)."""
    tracks = joint_tracks(skeleton, animation)
    return global_transforms(skeleton, compose(tracks.rotations, tracks.translations))


def _slerp(qa: np.ndarray, qb: np.ndarray, alphas: np.ndarray) -> np.ndarray:
    """(K, J, 4) quaternions between qa and qb (J, 4) xyzw at fractions alphas (K,) or (K, J), shortest arc."""
    qb = np.where(np.sum(qa * qb, axis=1, keepdims=True) < 0, -qb, qb)
    cos = np.clip(np.sum(qa * qb, axis=1), -1.0, 1.0)[None, :, None]
    theta = np.arccos(cos)
    a = alphas[:, :, None] if alphas.ndim == 2 else alphas[:, None, None]
    sin = np.sin(theta)
    small = sin < 1e-6  # nearly equal: linear blend is exact to float precision
    wa = np.where(small, 1.0 - a, np.sin((1.0 - a) * theta) / np.where(small, 1.0, sin))
    wb = np.where(small, a, np.sin(a * theta) / np.where(small, 1.0, sin))
    q = wa * qa[None] + wb * qb[None]
    return q / np.linalg.norm(q, axis=2, keepdims=True)


def interpolate_transforms(world_a: np.ndarray, world_b: np.ndarray, alphas: np.ndarray) -> np.ndarray:
    """(K, J, 4, 4) rigid transforms between world_a and world_b (J, 4, 4) at alphas (K,) or per joint (K, J),
    in [0, 1]."""
    qa = Rotation.from_matrix(world_a[:, :3, :3]).as_quat()
    qb = Rotation.from_matrix(world_b[:, :3, :3]).as_quat()
    q = _slerp(qa, qb, np.asarray(alphas, dtype=np.float64))
    k, j = q.shape[:2]
    out = np.zeros((k, j, 4, 4))
    out[:, :, :3, :3] = Rotation.from_quat(q.reshape(-1, 4)).as_matrix().reshape(k, j, 3, 3)
    a = np.asarray(alphas)
    a = a[:, :, None] if a.ndim == 2 else a[:, None, None]
    out[:, :, :3, 3] = (1.0 - a) * world_a[None, :, :3, 3] + a * world_b[None, :, :3, 3]
    out[:, :, 3, 3] = 1.0
    return out


def driver_positions(drivers: DrivingPoints, world: np.ndarray) -> np.ndarray:
    """(K, D, 3) float64 driver positions for joint world transforms (K, J, 4, 4)."""
    m = world[:, drivers.joints]  # (K, D, 4, 4)
    return np.einsum("kdab,db->kda", m[:, :, :3, :3], drivers.offsets) + m[:, :, :3, 3]


def substep_drive(drivers: DrivingPoints, world_a: np.ndarray, world_b: np.ndarray, substeps: int, dt: float,
                  ease: bool = False) -> tuple[np.ndarray, np.ndarray]:
    """Driver positions and velocities at each substep start of one frame interval.

    Returns (substeps, D, 3) float32 positions and (substeps, D, 3) float32 velocities (m/s), the latter the
    displacement to the next substep over dt. ease: smoothstep the interpolation (pre-roll from bind pose).
    """
    alphas = np.arange(substeps + 1) / substeps
    if ease:
        alphas = alphas * alphas * (3.0 - 2.0 * alphas)
    pos = driver_positions(drivers, interpolate_transforms(world_a, world_b, alphas))
    return pos[:-1].astype(np.float32), (np.diff(pos, axis=0) / dt).astype(np.float32)

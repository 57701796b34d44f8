"""Synthetic creatures for tests and benchmarks: capsule soups (overlapping, not unioned) with the skeleton they were built on."""

from __future__ import annotations

import numpy as np
import trimesh

from simcore.skeleton.types import Skeleton


def capsule_between(a: np.ndarray, b: np.ndarray, radius: float, count: int = 12) -> trimesh.Trimesh:
    """A capsule whose axis runs from point `a` to point `b` (3,), metres; `count` segments around and along."""
    a, b = np.asarray(a, float), np.asarray(b, float)
    axis = b - a
    length = float(np.linalg.norm(axis))
    mesh = trimesh.creation.capsule(height=length, radius=radius, count=[count, count])
    align = trimesh.geometry.align_vectors([0.0, 0.0, 1.0], axis / length)
    mesh.apply_transform(align)
    mesh.apply_translation((a + b) / 2.0)
    return mesh


def soup(skeleton: Skeleton, radii: dict[int, float], count: int = 12) -> tuple[np.ndarray, np.ndarray]:
    """One capsule per bone (child index → radius) concatenated as a self-intersecting triangle soup."""
    parts = [capsule_between(skeleton.positions[p], skeleton.positions[c], radii[int(c)], count)
             for p, c in skeleton.bones()]
    mesh = trimesh.util.concatenate(parts)
    assert isinstance(mesh, trimesh.Trimesh)  # trimesh types it as any Geometry; capsules concatenate to a Trimesh
    return np.asarray(mesh.vertices, np.float64), np.asarray(mesh.faces, np.int64)


def quadruped(count: int = 12, *, trunk: float = 0.45, girth: float = 0.16) -> tuple[np.ndarray, np.ndarray, Skeleton]:
    """A dog-like soup (+X forward, +Y up) and its 13-joint skeleton: hips and shoulders `trunk` m either side of
    the middle, a chest capsule of radius `girth` (the default dog is 1.9 m long); `count` sets tessellation."""
    named = {
        "pelvis": ((-trunk, 0.6, 0.0), None), "chest": ((trunk, 0.6, 0.0), "pelvis"),
        "neck": ((trunk + 0.25, 0.9, 0.0), "chest"), "head": ((trunk + 0.5, 0.9, 0.0), "neck"),
        "tail": ((-trunk - 0.5, 0.75, 0.0), "pelvis"),
    }
    for side, z in (("l", 0.13), ("r", -0.13)):
        for end, x in (("front", trunk), ("back", -trunk)):
            top = "chest" if end == "front" else "pelvis"
            named[f"{end}_{side}_knee"] = ((x + 0.05, 0.3, z), top)
            named[f"{end}_{side}_foot"] = ((x, 0.05, z), f"{end}_{side}_knee")
    names = list(named)
    parents = [names.index(parent) if (parent := named[n][1]) else -1 for n in names]
    skeleton = Skeleton(np.array([named[n][0] for n in names]), np.array(parents), names)
    radii = {}
    for c, n in enumerate(names):
        radii[c] = girth if n == "chest" else 0.1 if n in ("neck", "head") else 0.05 if n == "tail" else 0.06
    v, f = soup(skeleton, radii, count)
    return v, f, skeleton


def stick_humanoid(pose: str = "t", facing: str = "+z", count: int = 12, feet: bool = True
                   ) -> tuple[np.ndarray, np.ndarray, dict[str, np.ndarray]]:
    """A 1.8 m capsule biped standing on y = 0, facing +Z, in T- or A-pose, then turned to `facing` (+z, +x, -z, -x).
    feet=False: the thighs splay out to the knees and the shins stand straight on the floor with no feet forward.

    Returns (vertices, faces, Mixamo bare name → the joint position it was built on, (3,)).
    """
    arm_drop = 0.0 if pose == "t" else np.tan(np.deg2rad(40))  # A-pose: arms 40° below horizontal
    j = {
        "Hips": (0.0, 0.95, 0.0), "Spine": (0.0, 1.05, 0.0), "Spine1": (0.0, 1.17, 0.0), "Spine2": (0.0, 1.3, 0.0),
        "Neck": (0.0, 1.48, 0.0), "Head": (0.0, 1.58, 0.0), "HeadTop": (0.0, 1.72, 0.0),
    }
    for side, s in (("Left", 1.0), ("Right", -1.0)):
        j[f"{side}Shoulder"] = (0.06 * s, 1.42, 0.0)
        j[f"{side}Arm"] = (0.18 * s, 1.42, 0.0)
        for name, reach in ((f"{side}ForeArm", 0.28), (f"{side}Hand", 0.54), (f"{side}HandEnd", 0.70)):
            j[name] = (s * (0.18 + reach * np.cos(np.arctan(arm_drop))), 1.42 - reach * np.sin(np.arctan(arm_drop)), 0.0)
        j[f"{side}UpLeg"] = (0.12 * s, 0.9, 0.0)
        j[f"{side}Leg"] = (0.12 * s, 0.5, 0.02)
        j[f"{side}Foot"] = (0.12 * s, 0.09, 0.0)
        j[f"{side}ToeBase"] = (0.12 * s, 0.05, 0.14)
        j[f"{side}ToeEnd"] = (0.12 * s, 0.05, 0.22)
        if not feet:
            j[f"{side}Leg"], j[f"{side}Foot"] = (0.22 * s, 0.5, 0.0), (0.22 * s, 0.09, 0.0)
            j[f"{side}ToeBase"] = j[f"{side}ToeEnd"] = (0.22 * s, 0.05, 0.0)
    bones = [("Hips", "Spine", 0.15), ("Spine", "Spine1", 0.15), ("Spine1", "Spine2", 0.16), ("Spine2", "Neck", 0.06),
             ("Neck", "HeadTop", 0.1)]
    for side in ("Left", "Right"):
        bones += [("Spine2", f"{side}Arm", 0.06), (f"{side}Arm", f"{side}ForeArm", 0.05),
                  (f"{side}ForeArm", f"{side}Hand", 0.04), (f"{side}Hand", f"{side}HandEnd", 0.035),
                  ("Hips", f"{side}UpLeg", 0.07), (f"{side}UpLeg", f"{side}Leg", 0.065),
                  (f"{side}Leg", f"{side}Foot", 0.055), (f"{side}Foot", f"{side}ToeEnd", 0.045)]
    turn = {"+z": 0, "+x": 90, "-z": 180, "-x": 270}[facing]
    rot = trimesh.transformations.rotation_matrix(np.deg2rad(turn), [0, 1, 0])[:3, :3]
    parts = [capsule_between(np.array(j[a]) @ rot.T, np.array(j[b]) @ rot.T, r, count) for a, b, r in bones]
    mesh = trimesh.util.concatenate(parts)
    assert isinstance(mesh, trimesh.Trimesh)  # trimesh types it as any Geometry; capsules concatenate to a Trimesh
    joints = {k: np.array(p) @ rot.T for k, p in j.items()}
    return np.asarray(mesh.vertices, np.float64), np.asarray(mesh.faces, np.int64), joints

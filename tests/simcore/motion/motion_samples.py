"""Small synthetic skeletons and BVH texts for the motion tests (generated, not committed assets)."""

from __future__ import annotations

import numpy as np

from simcore.skeleton.mixamo import BODY_JOINTS, BODY_PARENTS
from simcore.skeleton.types import JointKind, Skeleton

# Rest positions of a 1.8 m figure, Y up, facing +Z, arms along ±X (T-pose); metres.
_T_POSE = {
    "Hips": (0, 1.0, 0), "Spine": (0, 1.1, 0), "Spine1": (0, 1.2, 0), "Spine2": (0, 1.3, 0), "Neck": (0, 1.5, 0),
    "Head": (0, 1.6, 0),
    "LeftShoulder": (0.05, 1.45, 0), "LeftArm": (0.18, 1.45, 0), "LeftForeArm": (0.45, 1.45, 0), "LeftHand": (0.7, 1.45, 0),
    "LeftUpLeg": (0.1, 0.95, 0), "LeftLeg": (0.1, 0.52, 0), "LeftFoot": (0.1, 0.1, 0), "LeftToeBase": (0.1, 0.02, 0.12),
}


def humanoid(arm_drop_degrees: float = 0.0, prefix: str = "mixamorig:", scale: float = 1.0) -> Skeleton:
    """The 22-joint Mixamo body; arms rotated down about the shoulder by `arm_drop_degrees` (45 = A-pose)."""
    pos: dict[str, np.ndarray] = {}
    for name in BODY_JOINTS:
        base = name.replace("Right", "Left")
        p = np.array(_T_POSE[base], dtype=np.float64)
        if name.startswith("Right"):
            p[0] = -p[0]
        pos[name] = p
    a = np.deg2rad(arm_drop_degrees)
    for side, sign in (("Left", 1.0), ("Right", -1.0)):
        pivot = pos[f"{side}Arm"]
        rot = np.array([[np.cos(a), sign * np.sin(a), 0], [-sign * np.sin(a), np.cos(a), 0], [0, 0, 1]])
        for part in ("ForeArm", "Hand"):
            pos[f"{side}{part}"] = pivot + rot @ (pos[f"{side}{part}"] - pivot)
    names = list(BODY_JOINTS)
    parents = [-1 if (parent := BODY_PARENTS[n]) is None else names.index(parent) for n in names]
    return Skeleton(np.array([pos[n] for n in names]) * scale, np.array(parents), [prefix + n for n in names],
                    [JointKind.BODY] * len(names)).validate()


def bvh_text(skeleton: Skeleton, root_positions: np.ndarray, angles: np.ndarray, orders: list[str],
             frame_time: float = 1 / 30, unit: float = 100.0) -> str:
    """BVH for `skeleton` (units: metres × unit): root positions (T, 3) metres, angles (T, J, 3) degrees given
    in each joint's channel order `orders[j]` (e.g. "ZXY"). Joints are written depth-first."""
    children = skeleton.children()
    lines: list[str] = ["HIERARCHY"]

    def write(j: int, depth: int) -> None:
        pad = "\t" * depth
        p = skeleton.parents[j]
        off = (skeleton.positions[j] - (skeleton.positions[p] if p >= 0 else 0.0)) * unit
        if p < 0:
            off = np.zeros(3)
        lines.append(f"{pad}{'ROOT' if p < 0 else 'JOINT'} {skeleton.names[j]}")
        lines.append(f"{pad}{{")
        lines.append(f"{pad}\tOFFSET {off[0]:.6f} {off[1]:.6f} {off[2]:.6f}")
        rot = " ".join(f"{axis}rotation" for axis in orders[j])
        lines.append(f"{pad}\tCHANNELS {'6 Xposition Yposition Zposition ' if p < 0 else '3 '}{rot}")
        for c in children[j]:
            write(c, depth + 1)
        if not children[j]:
            lines.extend([f"{pad}\tEnd Site", f"{pad}\t{{", f"{pad}\t\tOFFSET 0 5 0", f"{pad}\t}}"])
        lines.append(f"{pad}}}")

    write(0, 0)
    order = _depth_first(skeleton)
    lines += ["MOTION", f"Frames: {len(angles)}", f"Frame Time: {frame_time:.6f}"]
    for t in range(len(angles)):
        row = list(root_positions[t] * unit) + [v for j in order for v in angles[t, j]]
        lines.append(" ".join(f"{v:.6f}" for v in row))
    return "\n".join(lines) + "\n"


def _depth_first(skeleton: Skeleton) -> list[int]:
    children, out, stack = skeleton.children(), [], [0]
    while stack:
        j = stack.pop()
        out.append(j)
        stack.extend(reversed(children[j]))
    return out


def body_cloud(skeleton: Skeleton, per_bone: int = 40, radius: float = 0.05, seed: int = 0):
    """(V, 3) points around every bone of `skeleton` and their (V, J) rigid weights (CSR) to the bone's parent
    joint: a stand-in skinned body for LBS-based scores."""
    import scipy.sparse as sp

    rng = np.random.default_rng(seed)
    points, owners = [], []
    for parent, child in skeleton.bones():
        a, b = skeleton.positions[parent], skeleton.positions[child]
        u = rng.uniform(0, 1, (per_bone, 1))
        offset = rng.normal(size=(per_bone, 3))
        offset *= radius / np.linalg.norm(offset, axis=1, keepdims=True)
        points.append(a + u * (b - a) + offset)
        owners.append(np.full(per_bone, parent))
    v = np.concatenate(points)
    o = np.concatenate(owners)
    w = sp.csr_matrix((np.ones(len(v)), (np.arange(len(v)), o)), shape=(len(v), skeleton.num_joints))
    return v, w


# A two-joint clip of two frames: the smallest valid BVH (parser tests, hostile-input edits).
SMALL_BVH = """HIERARCHY
ROOT Hips
{
  OFFSET 0 0 0
  CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation
  JOINT Spine
  {
    OFFSET 0 10 0
    CHANNELS 3 Zrotation Xrotation Yrotation
    End Site
    {
      OFFSET 0 10 0
    }
  }
}
MOTION
Frames: 2
Frame Time: 0.033333
0 90 0 0 0 0 0 0 0
1 90 0 10 20 30 40 50 60
"""

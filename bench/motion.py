"""Motion speed: retarget + bake a 1,000-frame clip onto a 60-joint skeleton (target ≤ 2 s on 2 cores).

Source: the first 1,000 frames of the dev `mocap_cmu_01_01.bvh` (120 fps, 38 joints with end sites) when
../shared is beside the repo, else a generated 1,000-frame BVH of the same length. Target: a 60-joint
Mixamo-named rig (22 body + 30 finger joints + an 8-joint tail). Steps timed: BVH parse, retarget, bake
(glTF/USD joint tracks + per-frame LBS skinning matrices, what export and refine consume). Reference in
the same run: the bake done frame by frame (a per-frame forward-kinematics loop, as a naive exporter
would). Prints a table and writes bench/results/motion.json.

    .venv/bin/python bench/motion.py [--repeat 3]
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import time
from pathlib import Path

import numpy as np

from simcore.io.bvh import parse_bvh
from simcore.motion.retarget import retarget
from simcore.motion.types import JointAnimation
from simcore.skeleton import kinematics
from simcore.skeleton.mixamo import BODY_JOINTS, BODY_PARENTS, FINGERS, HAND_JOINTS, HAND_PARENTS
from simcore.skeleton.types import JointKind, Skeleton

REPO = Path(__file__).resolve().parents[1]
DEV = Path(os.environ.get("RIGFORGE_DEV_ASSETS", REPO.parent / "shared" / "assets" / "dev"))
FRAMES = 1000
BUDGET_S = 2.0
# Left-side body joint heads of a 1.8 m figure in T-pose (mirrored for the right side), metres.
LEFT_BODY = {
    "Hips": (0, 1.0, 0), "Spine": (0, 1.1, 0), "Spine1": (0, 1.2, 0), "Spine2": (0, 1.3, 0), "Neck": (0, 1.5, 0),
    "Head": (0, 1.6, 0), "LeftShoulder": (0.05, 1.45, 0), "LeftArm": (0.18, 1.45, 0), "LeftForeArm": (0.45, 1.45, 0),
    "LeftHand": (0.7, 1.45, 0), "LeftUpLeg": (0.1, 0.95, 0), "LeftLeg": (0.1, 0.52, 0), "LeftFoot": (0.1, 0.1, 0),
    "LeftToeBase": (0.1, 0.02, 0.12),
}


def target_rig() -> Skeleton:
    """60 joints: Mixamo body, three-phalanx fingers fanned along the hand, an 8-joint tail behind the hips."""
    pos: dict[str, np.ndarray] = {}
    for name in BODY_JOINTS:
        p = np.array(LEFT_BODY[name.replace("Right", "Left")], dtype=np.float64)
        pos[name] = p * ([-1, 1, 1] if name.startswith("Right") else 1)
    for name in HAND_JOINTS:
        side = "Left" if name.startswith("Left") else "Right"
        finger = next(f for f in FINGERS if f in name)
        k = int(name[-1])
        spread = (FINGERS.index(finger) - 2) * 0.02
        pos[name] = pos[f"{side}Hand"] + np.array([(0.04 + 0.025 * k) * (1 if side == "Left" else -1), 0.0, spread])
    names = list(BODY_JOINTS) + list(HAND_JOINTS)
    parents_by_name = {**BODY_PARENTS, **HAND_PARENTS}
    parents = [-1 if (parent := parents_by_name[n]) is None else names.index(parent) for n in names]
    kinds = [JointKind.BODY] * len(BODY_JOINTS) + [JointKind.HAND] * len(HAND_JOINTS)
    for k in range(8):
        names.append(f"Tail{k + 1}")
        parents.append(names.index("Hips") if k == 0 else len(names) - 2)
        pos[names[-1]] = np.array([0.0, 0.95 - 0.02 * k, -0.08 - 0.07 * k])
        kinds.append(JointKind.SPRING)
    return Skeleton(np.array([pos[n] for n in names]), np.array(parents), ["mixamorig:" + n for n in names], kinds).validate()


def source_bvh() -> tuple[str, str]:
    """(label, BVH text) with FRAMES frames."""
    path = DEV / "mocap_cmu_01_01.bvh"
    if path.exists():
        lines = path.read_text().splitlines()
        at = lines.index("MOTION")
        head = lines[:at + 1] + [f"Frames: {FRAMES}", lines[at + 2]]
        return "mocap_cmu_01_01 (first 1,000 frames)", "\n".join(head + lines[at + 3:at + 3 + FRAMES]) + "\n"
    rng = np.random.default_rng(0)
    joints = ["Hips", "Spine", "Neck", "Head", "LeftUpLeg", "LeftLeg", "LeftFoot", "RightUpLeg", "RightLeg", "RightFoot"]
    text = ["HIERARCHY"]
    # A flat generated hierarchy is enough for timing: every joint a child of the previous one.
    for k, n in enumerate(joints):
        text += [("ROOT " if k == 0 else "JOINT ") + n, "{", "OFFSET 0 10 0",
                 "CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation" if k == 0 else "CHANNELS 3 Zrotation Xrotation Yrotation"]
    text += ["End Site", "{", "OFFSET 0 5 0", "}"] + ["}"] * len(joints)
    values = rng.uniform(-30, 30, (FRAMES, 3 + 3 * len(joints)))
    text += ["MOTION", f"Frames: {FRAMES}", "Frame Time: 0.008333"] + [" ".join(f"{v:.4f}" for v in row) for row in values]
    return "generated chain", "\n".join(text) + "\n"


def bake(skeleton: Skeleton, anim: JointAnimation) -> np.ndarray:
    """Vectorised bake: writer-ready joint tracks and (T, J, 4, 4) LBS skinning matrices."""
    try:
        from simcore.io.joint_tracks import joint_tracks
    except ImportError:  # the exporter's track layout is optional for this benchmark
        world = kinematics.global_transforms(skeleton, kinematics.compose(anim.rotations, anim.translations))
        return kinematics.skinning_matrices(skeleton, world)
    return joint_tracks(skeleton, anim).skin_matrices(skeleton)


def bake_per_frame(skeleton: Skeleton, anim: JointAnimation) -> np.ndarray:
    """Reference: the same skinning matrices frame by frame, joint by joint."""
    inv_bind = np.linalg.inv(kinematics.bind_matrices(skeleton))
    out = np.empty((anim.num_frames, skeleton.num_joints, 4, 4))
    for t in range(anim.num_frames):
        local = kinematics.compose(anim.rotations[t], anim.translations[t])
        world = np.empty_like(local)
        for j, p in enumerate(skeleton.parents):
            world[j] = local[j] if p < 0 else world[p] @ local[j]
        out[t] = world @ inv_bind
    return out


def best_of(repeat: int, fn):
    times, result = [], None
    for _ in range(repeat):
        started = time.perf_counter()
        result = fn()
        times.append(time.perf_counter() - started)
    return min(times), result


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--out", type=Path, default=REPO / "bench" / "results" / "motion.json")
    args = parser.parse_args()
    label, text = source_bvh()
    target = target_rig()
    t_parse, clip = best_of(args.repeat, lambda: parse_bvh(text))
    t_retarget, result = best_of(args.repeat, lambda: retarget(clip, target))
    t_bake, mats = best_of(args.repeat, lambda: bake(target, result.animation))
    t_ref, ref = best_of(1, lambda: bake_per_frame(target, result.animation))
    assert np.allclose(mats, ref, atol=1e-9), "vectorised and per-frame bakes disagree"
    total = t_retarget + t_bake
    rows = [
        ("parse BVH", t_parse), ("retarget", t_retarget), ("bake (tracks + skin matrices)", t_bake),
        ("retarget + bake", total), ("reference: per-frame bake", t_ref),
    ]
    print(f"source: {label}, {clip.animation.num_frames} frames, {clip.skeleton.num_joints} joints → "
          f"target {target.num_joints} joints ({len(result.mapping)} mapped, {result.method})")
    print(f"{'step':<32}{'seconds':>10}")
    for name, secs in rows:
        print(f"{name:<32}{secs:>10.3f}")
    verdict = "PASS" if total <= BUDGET_S else "FAIL"
    print(f"retarget + bake {total:.3f} s vs budget {BUDGET_S:.1f} s: {verdict}; per-frame reference is {t_ref / max(t_bake, 1e-9):.1f}x the bake")
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps({
        "source": label, "frames": clip.animation.num_frames, "source_joints": clip.skeleton.num_joints,
        "target_joints": target.num_joints, "mapped": len(result.mapping), "budget_s": BUDGET_S,
        "seconds": {name: round(secs, 4) for name, secs in rows}, "pass": total <= BUDGET_S,
        "machine": {"platform": platform.platform(), "cpus": os.cpu_count(), "python": platform.python_version()},
        "repeat": args.repeat,
    }, indent=1))
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()

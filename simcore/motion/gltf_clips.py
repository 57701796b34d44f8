"""Animation clips carried by a rigged glTF: list them, pick one, sample it into a MotionClip.

The clip is expressed in glTF world space (+Y up): the source skeleton's rest pose is the skin's bind pose
placed where the root joint's rest pose puts it (`bind_placement`), and every frame holds each
joint node's world transform, scale removed, as local rotations/translations relative to its parent joint.
Node animation channels are sampled at a uniform rate: LINEAR (slerp for rotations), STEP, CUBICSPLINE.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation

from simcore.errors import InvalidInput
from simcore.geometry.similarity import rotation_from_covariance
from simcore.io.bind_pose import bind_placement
from simcore.io.gltf_document import GltfDocument
from simcore.io.gltf_rig import RiggedAsset, read_rigged_asset
from simcore.motion.timing import sample_track
from simcore.motion.types import JointAnimation, MotionClip
from simcore.skeleton.types import Skeleton

MAX_CLIP_FRAMES = 100_000
DEFAULT_FPS = 30.0
PATHS = ("translation", "rotation", "scale")


def clip_names(doc: GltfDocument) -> list[str]:
    """Name of every animation in the file (`clip<i>` for unnamed ones), in file order."""
    return [str(a.get("name") or f"clip{i}") for i, a in enumerate(doc.items("animations"))]


def select_clip(doc: GltfDocument, clip: str | int | None) -> int:
    """Index of the animation named or numbered by `clip` (None → the first); InvalidInput when absent."""
    names = clip_names(doc)
    if not names:
        raise InvalidInput("the file carries no animation clips", code="no_clips", field="motion.clip")
    if clip is None:
        return 0
    if isinstance(clip, str) and clip in names:
        return names.index(clip)
    if isinstance(clip, int) or (isinstance(clip, str) and clip.strip().lstrip("-").isdigit()):
        index = int(clip)
        if 0 <= index < len(names):
            return index
    raise InvalidInput(
        f"clip {clip!r} not found; the file has {len(names)}: {', '.join(map(repr, names))}",
        code="unknown_clip", field="motion.clip",
    )


def _estimate_fps(times: list[np.ndarray]) -> float:
    """The keys' own rate (median key spacing), clamped to 10..60 fps; 30 when every track is static."""
    steps = np.concatenate([np.diff(t) for t in times if len(t) > 1] or [np.zeros(0)])
    steps = steps[steps > 1e-6]
    if not len(steps):
        return DEFAULT_FPS
    return float(np.clip(np.round(1.0 / np.median(steps)), 10.0, 60.0))


def _static_trs(node: dict) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
    """(t, r xyzw, s) of a TRS node, None for a matrix node."""
    if "matrix" in node:
        return None
    return (
        np.asarray(node.get("translation", [0, 0, 0]), dtype=np.float64),
        np.asarray(node.get("rotation", [0, 0, 0, 1]), dtype=np.float64),
        np.asarray(node.get("scale", [1, 1, 1]), dtype=np.float64),
    )


def _ordered(asset: RiggedAsset) -> tuple[Skeleton, np.ndarray, np.ndarray]:
    """The skin skeleton with parents before children, and its joint nodes / bind matrices in that order."""
    skel = asset.skeleton
    if np.all(skel.parents < np.arange(skel.num_joints)):
        return skel, asset.joint_nodes, asset.bind_matrices
    placed_order: list[int] = []
    placed = np.zeros(skel.num_joints, bool)
    while len(placed_order) < skel.num_joints:
        for j, p in enumerate(skel.parents):
            if not placed[j] and (p < 0 or placed[p]):
                placed_order.append(j)
                placed[j] = True
    order = np.asarray(placed_order)
    return skel.reordered(order), asset.joint_nodes[order], asset.bind_matrices[order]


def sample_node_worlds(doc: GltfDocument, anim_index: int, times: np.ndarray, nodes: np.ndarray) -> np.ndarray:
    """(T, len(nodes), 4, 4) world matrices of `nodes` at `times` under animation `anim_index`."""
    anim = doc.items("animations")[anim_index]
    samplers = anim.get("samplers", [])
    all_nodes = doc.items("nodes")
    parents = doc.node_parents()
    needed: set[int] = set()
    for n in nodes.tolist():
        while n >= 0 and n not in needed:
            needed.add(n)
            n = int(parents[n])
    t = len(times)
    trs: dict[int, list[np.ndarray]] = {}
    for n in needed:
        static = _static_trs(all_nodes[n])
        if static is not None:
            trs[n] = [np.broadcast_to(v, (t, len(v))).copy() for v in static]
    for ch in anim.get("channels", []):
        target = ch.get("target", {})
        n, path = target.get("node"), target.get("path")
        if n not in needed or path not in PATHS:
            continue  # morph weights and unrelated nodes do not move the skeleton
        if n not in trs:
            raise InvalidInput(f"node {n} is animated but has a matrix (glTF forbids it)", code="invalid_gltf", field="motion")
        sampler_index = ch.get("sampler")
        if not isinstance(sampler_index, int) or not 0 <= sampler_index < len(samplers):
            raise InvalidInput(f"animation channel points to missing sampler {sampler_index}", code="invalid_gltf", field="motion")
        sampler = samplers[sampler_index]
        key_times = doc.accessor(sampler["input"]).reshape(-1)
        values = doc.accessor(sampler["output"]).astype(np.float64)
        if not (np.all(np.isfinite(key_times)) and np.all(np.isfinite(values))):
            raise _non_finite(doc, anim_index, f"times or {path} values of node {n}")
        trs[n][PATHS.index(path)] = sample_track(
            key_times, values, times, sampler.get("interpolation", "LINEAR"), rotation=path == "rotation"
        )
    world: dict[int, np.ndarray] = {}
    for n in sorted(needed, key=lambda k: _depth(parents, k)):
        if n in trs:
            tr, rot, sc = trs[n]
            local = np.zeros((t, 4, 4))
            local[:, :3, :3] = Rotation.from_quat(rot).as_matrix() * sc[:, None, :]
            local[:, :3, 3] = tr
            local[:, 3, 3] = 1.0
        else:
            local = np.broadcast_to(doc.node_local_matrix(n), (t, 4, 4))
        p = int(parents[n])
        world[n] = local if p < 0 else world[p] @ local
    return np.stack([world[int(n)] for n in nodes], axis=1)


def _depth(parents: np.ndarray, n: int) -> int:
    d = 0
    while parents[n] >= 0:
        n, d = int(parents[n]), d + 1
    return d


def _non_finite(doc: GltfDocument, anim_index: int, what: str) -> InvalidInput:
    """The error refusing a clip whose keyframes hold NaN or infinite numbers."""
    name = doc.items("animations")[anim_index].get("name") or f"#{anim_index}"
    return InvalidInput(f"animation {name!r} has NaN or infinite keyframe {what}; the clip is refused",
                        code="non_finite_keyframes", field="motion")


def clip_time_range(doc: GltfDocument, anim_index: int) -> tuple[float, float, list[np.ndarray]]:
    """(first key time, last key time, every sampler's key times) of one animation."""
    anim = doc.items("animations")[anim_index]
    times = [doc.accessor(s["input"]).reshape(-1).astype(np.float64) for s in anim.get("samplers", [])]
    if not times or not any(len(k) for k in times):
        raise InvalidInput("animation has no keyframes", code="invalid_gltf", field="motion")
    bad = [k for k, t in enumerate(times) if not np.all(np.isfinite(t))]
    if bad:
        raise _non_finite(doc, anim_index, f"key times of sampler(s) {bad[:5]}")
    return float(min(k.min() for k in times if len(k))), float(max(k.max() for k in times if len(k))), times


def read_gltf_clip(
    doc: GltfDocument, clip: str | int | None = None, fps: float | None = None, asset: RiggedAsset | None = None
) -> MotionClip:
    """Sample one animation of a rigged glTF into a MotionClip on its skin skeleton.

    clip: name or index (None → first). fps: sampling rate (None → the keys' own rate).
    Returns a MotionClip whose skeleton has `orientations` (bind joint frames) and rest_is_standing=True.
    """
    index = select_clip(doc, clip)
    asset = asset or read_rigged_asset(doc)
    skel, joint_nodes, bind = _ordered(asset)
    t0, t1, key_times = clip_time_range(doc, index)
    fps = float(fps or _estimate_fps(key_times))
    n = int(np.floor((t1 - t0) * fps + 1e-6)) + 1
    if n > MAX_CLIP_FRAMES:
        raise InvalidInput(f"clip would have {n} frames at {fps:g} fps, over {MAX_CLIP_FRAMES}", code="too_many_frames", field="motion")
    times = t0 + np.arange(n) / fps
    world = sample_node_worlds(doc, index, times, joint_nodes)  # (T, J, 4, 4)
    rot = rotation_from_covariance(world[..., :3, :3])
    pos = world[..., :3, 3]
    parents = skel.parents
    par = np.maximum(parents, 0)
    local_rot = np.where((parents < 0)[None, :, None, None], rot, np.swapaxes(rot[:, par], -1, -2) @ rot)
    delta = np.where((parents < 0)[None, :, None], pos, pos - pos[:, par])
    local_tr = np.where(
        (parents < 0)[None, :, None], pos, np.einsum("tjba,tjb->tja", rot[:, par], delta)
    )
    rest = bind_placement(doc, asset) @ bind
    source = Skeleton(rest[:, :3, 3], parents, skel.names, skel.kinds,
                      Rotation.from_matrix(rotation_from_covariance(rest[:, :3, :3])).as_quat())
    quats = Rotation.from_matrix(local_rot.reshape(-1, 3, 3)).as_quat().reshape(n, skel.num_joints, 4)
    anim = JointAnimation(list(skel.names), fps, quats, local_tr, clip_names(doc)[index])
    return MotionClip(source, anim, rest_is_standing=True, source_format="gltf", unit_scale=1.0, unit="file")

"""Retarget a source MotionClip onto a target Skeleton.

Method (world-space delta transfer):
1. Map target joints to source joints (`map_joints`: names, else chain structure, or where the bones lie for
   two skeletons of one body; user overrides win; a helper root at the file's origin is left out and stays
   unmapped and still, and no helper is ever a foot) and
   find the quarter turn about +Y that makes the source face the way the target faces. Of several target
   joints on one chain mapped to one source joint, only the one nearest it bends (`one_pivot_per_source_joint`;
   for one body, the target's root keeps its source joint too).
2. Rest alignment: for each mapped target joint, the rotation A_j that turns its rest bone directions (to
   its nearest mapped descendants) onto the source's rest bone directions. This is what lets a T-pose
   source drive an A-pose target: at the source's rest, the target takes the source's pose. A branching
   joint (a hip) whose bones no single rotation brings near the source's is placed differently, not posed
   differently, and keeps its own rest (forcing such a joint to align would twist the whole body under it).
   A clip whose rest is the rigged mesh's own bind pose (`MotionClip.shares_bind_pose`) needs no alignment
   at all: both skeletons sit in one body in one pose, so every A_j is the identity and root motion is not
   rescaled (hip heights differ only by where each skeleton put its joints).
3. Per frame, the source joint's world delta rotation D_s = R_world(t) · R_rest⁻¹ drives the target:
   D_t = D_s · A_j; unmapped target joints ride rigidly with their parent. Target locals follow from
   D_t · R_bind (R_bind = the target's bind orientation, identity for world-aligned skeletons).
4. Root motion: the source root's displacement scaled by the hip-height ratio (in place if asked; for one body,
   the displacement of the point where our root sits, carried by the source joint it follows, as that joint
   turns about its own place, not ours), then a
   per-frame vertical correction that keeps the target's lowest contact joint as high above the target's
   ground as the source's is above its own (feet stay on the floor, jumps keep their height). For one body,
   the source's contact joints are those the target's contact joints map to (IK rigs hang the feet off a
   floor root, outside the subtree that carries the root motion).
5. Bones both skeletons share (a joint and its parent mapped to a source joint and its parent) also take the
   offsets the clip animates on them (`bone_offsets`: a popping head, an IK foot, a second character's root);
   every other bone stays rigid.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp
from scipy.spatial.transform import Rotation

from simcore.errors import InvalidInput
from simcore.motion.body_map import fill_by_region, flesh_shares, region_mapping
from simcore.motion.bone_offsets import bone_offsets
from simcore.motion.chain_match import chain_mapping, normalised_rest, quarter_turn
from simcore.motion.joint_map import name_mapping, skeleton_slots
from simcore.motion.timing import resample
from simcore.motion.types import JointAnimation, MotionClip
from simcore.options import MotionOptions
from simcore.skeleton import kinematics
from simcore.skeleton.mixamo import BODY_JOINTS
from simcore.skeleton.origin_root import body_tree
from simcore.skeleton.types import JointKind, Skeleton, is_at_or_below, tree_depths

MIN_BODY_SLOTS = 8  # shared Mixamo body slots needed to trust name matching over structure
CONTACT_BAND = 0.05  # joints within this fraction of the height above the lowest one touch the floor
# A branching joint whose best rest rotation still leaves one of its bones this far (radians) from the source's
# is placed differently from the source's joint, not posed differently: it keeps its own rest (no alignment).
BRANCH_MISFIT = np.pi / 4
GROUND_PERCENTILE = 5.0  # of the source's per-frame lowest contact height: its floor, robust to dips


@dataclass
class RetargetResult:
    """The target animation and how it was obtained (for report.json)."""

    animation: JointAnimation
    mapping: dict[str, str]  # target joint name → source joint name
    method: str  # "names", "chains", "regions" (+ "+overrides")
    unmapped_target: list[str]
    unmapped_source: list[str]
    root_scale: float  # target / source hip height, applied to root motion
    facing_turns: int  # quarter turns about +Y applied to the source
    contact_joints: list[str] = field(default_factory=list)


def _name_turns(source: Skeleton, target: Skeleton, mapping: dict[int, int]) -> int:
    """Quarter turn about +Y that best aligns the mapped joints' normalised rest positions (XZ plane)."""
    if not mapping:
        return 0
    t_idx = np.fromiter(mapping.keys(), np.int64)
    s_idx = np.fromiter(mapping.values(), np.int64)
    ps, pt = normalised_rest(source)[s_idx], normalised_rest(target)[t_idx]
    errs = [np.sum(((ps @ quarter_turn(k).T) - pt)[:, [0, 2]] ** 2) for k in range(4)]
    return int(np.argmin(errs))


def map_joints(source: Skeleton, target: Skeleton, overrides: dict[str, str] | None = None,
               same_body: bool = False, shares: np.ndarray | None = None) -> tuple[dict[int, int], str, int]:
    """(target index → source index, method, facing quarter turns).

    overrides: source joint name → target joint name; unknown names raise InvalidInput(field="motion.joint_map").
    same_body: both skeletons were built in one mesh in one pose and frame: no quarter turn is looked for;
    without shared names every target joint takes the source joint whose bones lie nearest its own
    (`region_mapping`, method "regions"), with names the joints they leave unmapped do (`fill_by_region`);
    shares: (Jt, Js) `body_map.flesh_shares` of the two skins on the one mesh, for those mappings.
    """
    by_names = name_mapping(source, target)
    t_slots = skeleton_slots(target)
    shared = {t_slots[t] for t in by_names if t_slots[t] in BODY_JOINTS or t_slots[t] in ("spine", "neck")}
    if "Hips" in shared and len(shared) >= MIN_BODY_SLOTS:
        mapping, method = by_names, "names"
        turns = 0 if same_body else _name_turns(source, target, by_names)
    else:
        mapping, turns = chain_mapping(source, target, 0 if same_body else None)
        method = "chains"
    if same_body and method == "chains":  # no names to go by: bones in one body pair up by where they lie
        mapping, method = region_mapping(source, target, shares), "regions"
    elif same_body:
        mapping = fill_by_region(source, target, mapping, shares)
    mapping = one_pivot_per_source_joint(source, target, mapping, turns, same_body)
    if overrides:
        s_index = {n: j for j, n in enumerate(source.names)}
        t_index = {n: j for j, n in enumerate(target.names)}
        for s_name, t_name in overrides.items():
            if s_name not in s_index:
                raise InvalidInput(f"joint_map source joint {s_name!r} is not in the motion's skeleton",
                                   code="unknown_joint", field="motion.joint_map")
            if t_name not in t_index:
                raise InvalidInput(f"joint_map target joint {t_name!r} is not in the character's skeleton",
                                   code="unknown_joint", field="motion.joint_map")
            mapping[t_index[t_name]] = s_index[s_name]
        method += "+overrides"
    return mapping, method, turns


def one_pivot_per_source_joint(source: Skeleton, target: Skeleton, mapping: dict[int, int], turns: int,
                               same_body: bool = False) -> dict[int, int]:
    """The mapping without the chain links that would bend at the wrong place.

    When several target joints on one parent chain map to the same source joint (a target with more spine or
    clavicle joints than the source), each would turn by the source joint's rotation, so the chain would bend
    at the shallowest of them instead of where the source bends. Only the one nearest the source joint (rest
    positions as they are for `same_body` skeletons, else normalised with the source turned to face like the
    target) keeps the mapping; the group's ancestors
    above it that are plain chain links (one child) are unmapped and ride with their parents. Branching joints
    (a hip) keep their mapping: their other branches need the rotation. So does the target's root for `same_body`
    skeletons: it has no parent to ride with, and it is carried rigidly by the source joint it follows (root
    motion moves it as that joint moves its place), so it cannot bend the chain at the wrong place.
    """
    groups: dict[int, list[int]] = {}
    for t, s in mapping.items():
        groups.setdefault(s, []).append(t)
    shared = {s: ts for s, ts in groups.items() if len(ts) > 1}
    if not shared:
        return mapping
    if same_body:
        ps, pt = source.positions, target.positions
    else:
        ps, pt = normalised_rest(source) @ quarter_turn(turns).T, normalised_rest(target)
    children = target.children()
    out = dict(mapping)
    for s, ts in shared.items():
        keep = min(ts, key=lambda t: float(np.linalg.norm(pt[t] - ps[s])))
        for t in ts:
            carried = same_body and target.parents[t] < 0  # a root of one body: root motion carries it
            if len(children[t]) == 1 and keep != t and not carried and is_at_or_below(target.parents, keep, t):
                del out[t]
    return out


def rotation_between(u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """(3, 3) rotation taking directions u (N, 3) onto v (N, 3) in the least-squares sense (Kabsch on unit
    vectors, weighted by the target bone lengths); the minimal rotation when they are (nearly) collinear."""
    w = np.linalg.norm(u, axis=1)
    un = u / np.maximum(w, 1e-12)[:, None]
    vn = v / np.maximum(np.linalg.norm(v, axis=1), 1e-12)[:, None]
    h = (un * w[:, None]).T @ vn
    uu, s, vt = np.linalg.svd(h)
    if len(u) > 1 and s[1] > 1e-3 * s[0]:
        d = np.sign(np.linalg.det(vt.T @ uu.T)) or 1.0
        return vt.T @ np.diag([1.0, 1.0, d]) @ uu.T
    a, b = (un * w[:, None]).sum(0), (vn * w[:, None]).sum(0)
    a, b = a / max(np.linalg.norm(a), 1e-12), b / max(np.linalg.norm(b), 1e-12)
    axis = np.cross(a, b)
    sin, cos = np.linalg.norm(axis), float(np.dot(a, b))
    if sin < 1e-9:
        if cos > 0:
            return np.eye(3)
        perp = np.cross(a, [1.0, 0.0, 0.0] if abs(a[0]) < 0.9 else [0.0, 1.0, 0.0])
        return Rotation.from_rotvec(perp / np.linalg.norm(perp) * np.pi).as_matrix()
    return Rotation.from_rotvec(axis / sin * np.arctan2(sin, cos)).as_matrix()


def _rest_alignment(source: Skeleton, s_rest: np.ndarray, target: Skeleton, mapping: dict[int, int]) -> list[np.ndarray | None]:
    """A_j per target joint (None: unmapped or no bone to align, inherit the parent's)."""
    children_t, children_s = target.children(), source.children()
    out: list[np.ndarray | None] = [None] * target.num_joints
    for j, s in mapping.items():
        u, v, stack = [], [], list(children_t[j])
        while stack:  # nearest mapped descendants whose source lies below s
            c = stack.pop()
            sc = mapping.get(c)
            if sc is not None and sc != s and is_at_or_below(source.parents, sc, s):
                u.append(target.positions[c] - target.positions[j])
                v.append(s_rest[sc] - s_rest[s])
            elif sc is None or sc == s:
                stack.extend(children_t[c])
        if not u and children_t[j] and children_s[s]:
            u = [target.positions[children_t[j]].mean(0) - target.positions[j]]
            v = [s_rest[children_s[s]].mean(0) - s_rest[s]]
        u_arr, v_arr = np.asarray(u, dtype=np.float64).reshape(-1, 3), np.asarray(v, dtype=np.float64).reshape(-1, 3)
        keep = (np.linalg.norm(u_arr, axis=1) > 1e-9) & (np.linalg.norm(v_arr, axis=1) > 1e-9)
        if keep.any():
            rotation = rotation_between(u_arr[keep], v_arr[keep])
            out[j] = rotation
            if keep.sum() > 1 and _misfit(rotation, u_arr[keep], v_arr[keep]) > BRANCH_MISFIT:
                out[j] = None  # the bones fan out differently: joints placed differently, not posed differently
    return out


def _misfit(rot: np.ndarray, u: np.ndarray, v: np.ndarray) -> float:
    """Largest angle (radians) between rotated directions u (N, 3) and v (N, 3)."""
    a = u @ rot.T
    a /= np.linalg.norm(a, axis=1, keepdims=True)
    b = v / np.linalg.norm(v, axis=1, keepdims=True)
    return float(np.arccos(np.clip((a * b).sum(axis=1), -1.0, 1.0)).max())


def _contacts(positions: np.ndarray, candidates: np.ndarray) -> np.ndarray:
    """Indices among `candidates` whose rest height is within the contact band above the lowest one."""
    y = positions[candidates, 1]
    height = float(np.ptp(positions[:, 1])) or 1.0
    return candidates[y <= y.min() + CONTACT_BAND * height]


def _subtree(parents: np.ndarray, root: int) -> np.ndarray:
    """(J,) bool: root and its descendants (parents precede children)."""
    inside = np.zeros(len(parents), bool)
    inside[root] = True
    for j in range(root + 1, len(parents)):
        if parents[j] >= 0 and inside[parents[j]]:
            inside[j] = True
    return inside


def _hip_height(positions: np.ndarray, root: int, contacts: np.ndarray) -> float:
    return float(positions[root, 1] - positions[contacts, 1].min())


def _translating_root(source: Skeleton, anim: JointAnimation) -> int:
    """The source joint that carries root motion: the shallowest one whose local translation changes
    during the clip (glTF rigs often keep a static root above an animated hip), else the root."""
    rest_local = kinematics.rest_local_matrices(source)[:, :3, 3]
    size = float(np.ptp(source.positions, axis=0).max()) or 1.0
    moves = np.abs(anim.translations - rest_local[None]).max(axis=(0, 2)) > 1e-3 * size
    moves |= np.ptp(anim.translations, axis=0).max(axis=1) > 1e-3 * size
    if not moves.any():
        return 0
    depth = tree_depths(source.parents)
    subtree = np.array([_subtree(source.parents, j).sum() for j in range(source.num_joints)])
    candidates = np.flatnonzero(moves)
    return int(min(candidates, key=lambda j: (depth[j], -subtree[j])))


def _motion_root(source: Skeleton, anim: JointAnimation, mapping: dict[int, int], depth: np.ndarray) -> int:
    """Target joint that takes the root motion: the one mapped to the source's translating joint (or to the
    nearest ancestor of it that is mapped), else the shallowest mapped joint."""
    s = _translating_root(source, anim)
    inverse: dict[int, list[int]] = {}
    for t, sj in mapping.items():
        inverse.setdefault(sj, []).append(t)
    while s >= 0:
        if s in inverse:
            return int(min(inverse[s], key=lambda j: depth[j]))
        s = int(source.parents[s])
    mapped = np.fromiter(mapping.keys(), np.int64)
    return int(mapped[np.argmin(depth[mapped])])


def retarget(clip: MotionClip, target: Skeleton, options: MotionOptions | None = None,
             target_weights: sp.spmatrix | None = None) -> RetargetResult:
    """Transfer `clip` onto `target` (see the module docstring). Returns the target JointAnimation + report.
    target_weights: (V, Jt) the target's skin on the mesh whose own skin the clip carries (`bind_weights`)."""
    options = options or MotionOptions()
    source = clip.skeleton
    anim = resample(clip.animation, options.fps, options.start, options.end)
    same_body = clip.shares_bind_pose
    shares = None
    if same_body and clip.bind_weights is not None and target_weights is not None:
        shares = flesh_shares(target_weights, clip.bind_weights)
    body, skipped = body_tree(target)  # a helper root at the file's origin stays unmapped and still
    mapping, method, turns = map_joints(source, body, options.joint_map, same_body=same_body,
                                        shares=None if shares is None else shares[skipped:])
    mapping = {t + skipped: s for t, s in mapping.items()}
    if not mapping:
        raise InvalidInput("no joint of the motion could be matched to the character's skeleton",
                           code="no_joint_map", field="motion.joint_map")
    face = quarter_turn(turns)

    # Source world transforms, turned to face like the target.
    world_s = kinematics.global_transforms(source, kinematics.compose(anim.rotations, anim.translations))
    rot_s = face @ world_s[..., :3, :3]
    pos_s = world_s[..., :3, 3] @ face.T
    bind_s = kinematics.bind_matrices(source)
    rest_rot_s = face @ bind_s[:, :3, :3]
    rest_s = bind_s[:, :3, 3] @ face.T
    delta_s = rot_s @ np.swapaxes(rest_rot_s, -1, -2)[None]  # (T, Js, 3, 3)

    t_count, j_count = anim.num_frames, target.num_joints
    parents = target.parents
    # One body in one pose: bones that point differently are placed differently; turning them would bend the body.
    align = [None] * j_count if same_body else _rest_alignment(source, rest_s, target, mapping)
    bind_t = kinematics.bind_matrices(target)[:, :3, :3]
    delta_t = np.empty((t_count, j_count, 3, 3))
    inherited: list[np.ndarray] = [np.eye(3)] * j_count  # alignment in force at each joint
    for j in range(j_count):
        p = int(parents[j])
        own = align[j]
        a = own if own is not None else (inherited[p] if p >= 0 else np.eye(3))
        inherited[j] = a
        if j in mapping:
            delta_t[:, j] = delta_s[:, mapping[j]] @ a
        else:
            delta_t[:, j] = delta_t[:, p] if p >= 0 else np.eye(3)

    motion_root = _motion_root(source, anim, mapping, tree_depths(parents))
    source_root = mapping[motion_root]
    moving = _subtree(parents, motion_root)
    deforming = np.flatnonzero([kind != JointKind.HELPER for kind in target.kinds])  # a helper on the floor is no foot
    contacts_t = deforming[_contacts(target.positions[deforming], np.flatnonzero(moving[deforming]))]
    contacts_s = _contacts(rest_s, np.flatnonzero(_subtree(source.parents, source_root)))
    touching = sorted({mapping[j] for j in contacts_t.tolist() if j in mapping})
    if same_body and touching:  # one body: the source joints at our feet touch its floor (feet may hang off an IK root)
        contacts_s = np.asarray(touching, np.int64)
    hs, ht = _hip_height(rest_s, source_root, contacts_s), _hip_height(target.positions, motion_root, contacts_t)
    if same_body:
        scale = 1.0  # hip heights differ only by where each skeleton put its joints
    elif hs > 1e-6 and ht > 1e-6:
        scale = ht / hs
    else:
        scale = float(np.ptp(target.positions, axis=0).max() / max(np.ptp(rest_s, axis=0).max(), 1e-9))
    # Positions with the bones rigid but for the offsets the clip animates on bones both skeletons share, then
    # root motion and ground contact on the motion root's subtree.
    offsets = bone_offsets(source, rest_s, pos_s, delta_s, target, mapping, scale)
    carried = np.flatnonzero(np.abs(offsets).max(axis=(0, 2)) > 0)
    pos_t = np.empty((t_count, j_count, 3))
    for j in range(j_count):
        p = int(parents[j])
        rigid = target.positions[j] if p < 0 else pos_t[:, p] + delta_t[:, p] @ (target.positions[j] - target.positions[p])
        pos_t[:, j] = rigid + offsets[:, j]
    anchor = rest_s[source_root] if clip.rest_is_standing else pos_s[0, source_root]
    desired = target.positions[motion_root] + scale * (pos_s[:, source_root] - anchor)
    if same_body:  # one body: our root moves as the point where it sits moves on the source joint it follows
        lever = target.positions[motion_root] - rest_s[source_root]
        desired += np.einsum("tab,b->ta", delta_s[:, source_root], lever) - lever
    if options.in_place:
        desired[:, [0, 2]] = target.positions[motion_root, [0, 2]]
    shift = desired - pos_t[:, motion_root]
    low_s = pos_s[:, contacts_s, 1].min(axis=1)
    # A floating BVH rest says nothing about the floor: take the height the feet are usually down at.
    ground_s = rest_s[contacts_s, 1].min() if clip.rest_is_standing else np.percentile(low_s, GROUND_PERCENTILE)
    ground_t = target.positions[contacts_t, 1].min()
    low_t = (pos_t[:, contacts_t, 1] + shift[:, None, 1]).min(axis=1)
    shift[:, 1] += ground_t + scale * (low_s - ground_s) - low_t
    pos_t[:, moving] += shift[:, None, :]

    # Local transforms.
    world_rot = delta_t @ bind_t[None]
    par = np.maximum(parents, 0)
    is_root = (parents < 0)[None, :, None, None]
    local_rot = np.where(is_root, world_rot, np.swapaxes(world_rot[:, par], -1, -2) @ world_rot)
    rest_local = kinematics.rest_local_matrices(target)[:, :3, 3]
    local_tr = np.broadcast_to(rest_local, (t_count, j_count, 3)).copy()
    for j in {motion_root, *carried.tolist()}:
        p = int(parents[j])
        local_tr[:, j] = pos_t[:, j] if p < 0 else np.einsum("tba,tb->ta", world_rot[:, p], pos_t[:, j] - pos_t[:, p])
    quats = Rotation.from_matrix(local_rot.reshape(-1, 3, 3)).as_quat().reshape(t_count, j_count, 4)
    out = JointAnimation(list(target.names), anim.fps, quats, local_tr, anim.name, bool(options.loop))
    mapped_source = set(mapping.values())
    return RetargetResult(
        out,
        {target.names[t]: source.names[s] for t, s in sorted(mapping.items())},
        method,
        [n for j, n in enumerate(target.names) if j not in mapping],
        [n for j, n in enumerate(source.names) if j not in mapped_source],
        float(scale),
        turns,
        [target.names[j] for j in contacts_t],
    )


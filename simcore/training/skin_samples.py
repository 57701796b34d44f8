"""Training samples for the learned skinning model: a rigged character, augmented, turned into model inputs
and targets.

Augmentations (UniRig's): the character re-posed by one of its own clips' frames or by random bone
rotations (vertices skinned with the artist's weights, joints moved with their bones, so the posed shape is a
new character with the same weights), a random turn about the up axis and a random scale, mid-edge
subdivision (a denser mesh with interpolated weights) and quadric decimation (a coarser mesh, re-triangulated,
weights carried from the nearest original vertices) so the model cannot key on vertex density or order. Every
sample keeps at most `vertices` randomly chosen vertices (features are computed on the whole mesh first).

A sample's targets: the artist weights on each vertex's candidate joints, the mass that falls outside them,
and for the deformation loss P random poses as each candidate joint's transform of the vertex (P, V, K, 3)
with the artist-skinned positions (P, V, 3).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
from scipy.spatial.transform import Rotation

from simcore.io.gltf_rig import root_holds_weight, weightless_joints
from simcore.metrics.skinning import protocol_skin_matrices, unit_cube_frame
from simcore.skeleton.kinematics import global_transforms, random_pose_locals, skinning_matrices
from simcore.skeleton.types import Skeleton, parents_first_order
from simcore.skinning.lbs import linear_blend
from simcore.skinning.pair_features import SkinInputs, skin_inputs
from simcore.skinning.proxy import simplified, transfer

LOSS_POSES = 2
DECIMATE_MIN = 1000  # vertices a mesh needs before a variant may be decimated
DECIMATE_SHARE = (0.3, 0.7)  # share of the vertices a decimated variant keeps, drawn uniformly


@dataclass
class Character:
    """A rigged character at bind pose: vertices (V, 3), faces (F, 3), skeleton, weights (V, J) CSR rows summing to 1,
    optional clip skinning matrices (T, J, 4, 4) in the same space."""

    name: str
    category: str
    vertices: np.ndarray
    faces: np.ndarray
    skeleton: Skeleton
    weights: sp.csr_matrix
    clips: np.ndarray | None = None


def normalised(character: Character) -> Character:
    """The character in its unit cube (centred, longest side 1) with joints parents-first and weight rows
    normalised (vertices without weight dropped from nothing: they keep an empty row)."""
    centre, side = unit_cube_frame(character.vertices)
    order = parents_first_order(character.skeleton.parents)
    skeleton = character.skeleton.reordered(order)
    skeleton = Skeleton((skeleton.positions - centre) / side, skeleton.parents, skeleton.names)
    w = sp.csr_matrix(character.weights)[:, order]
    sums = np.asarray(w.sum(axis=1)).ravel()
    w = sp.diags(np.where(sums > 0, 1.0 / np.maximum(sums, 1e-12), 0.0)) @ w
    clips = None
    if character.clips is not None:
        to_cube = np.diag([1.0 / side] * 3 + [1.0])
        to_cube[:3, 3] = -centre / side
        clips = (to_cube @ character.clips @ np.linalg.inv(to_cube))[:, order]
    return Character(character.name, character.category, (character.vertices - centre) / side, character.faces, skeleton,
                     sp.csr_matrix(w), clips)


def reposed(character: Character, skin: np.ndarray) -> Character:
    """The character posed by skinning matrices (J, 4, 4): vertices by LBS with its weights, joints with their bones."""
    vertices = linear_blend(character.vertices, character.weights, skin)
    heads = np.einsum("jab,jb->ja", skin[:, :3, :3], character.skeleton.positions) + skin[:, :3, 3]
    skeleton = Skeleton(heads, character.skeleton.parents, character.skeleton.names)
    return Character(character.name, character.category, vertices, character.faces, skeleton, character.weights)


def rerooted(character: Character) -> Character:
    """The (normalised) character with its armature root taken out, or unchanged when its root is a body joint.

    Most artist rigs hang the body from a root that holds no weight; rigs without one (a Mixamo Hips root, a
    toy rig's first bone, our predicted skeletons) bend the mesh with their root. Here the root's child whose
    subtree holds the most weight becomes the root, takes the old root's little weight, and adopts its siblings,
    so the model sees weighted roots too and must tell the two kinds apart from the geometry, not the root flag.
    Repeated until the root holds weight.
    """
    parents = character.skeleton.parents
    column = np.asarray(character.weights.sum(axis=0)).ravel()
    kids = np.flatnonzero(parents == 0)
    if (parents < 0).sum() != 1 or not len(kids) or root_holds_weight(character.weights):
        return character
    subtree = column.copy()
    for j in range(len(parents) - 1, 0, -1):  # parents first: children's totals are complete before their parent's
        subtree[parents[j]] += subtree[j]
    top = int(kids[np.argmax(subtree[kids])])
    adopted = np.where(parents == 0, top, parents)  # the root's children hang from `top`, the old root under it too
    adopted[top], adopted[0] = -1, top
    s = character.skeleton
    order = np.r_[top, np.delete(np.arange(len(parents)), top)]  # `top` first, the rest as they were (parents first)
    tree, kept = Skeleton(s.positions, adopted, s.names).reordered(order).without(order == 0)
    weights = sp.csr_matrix(character.weights, copy=True).tolil()
    weights[:, top] = weights[:, top] + weights[:, 0]
    columns = order[kept]
    clips = None if character.clips is None else character.clips[:, columns]
    out = Character(character.name, character.category, character.vertices, character.faces, tree,
                    sp.csr_matrix(weights.tocsr()[:, columns]), clips)
    return rerooted(out)  # the new root may be an unweighted control too


def random_pose(character: Character, rng: np.random.Generator, degrees: float) -> np.ndarray:
    """(J, 4, 4) skinning matrices of random bone rotations (components uniform in ±degrees/√3)."""
    local = random_pose_locals(character.skeleton, rng, degrees)
    return skinning_matrices(character.skeleton, global_transforms(character.skeleton, local))


def turned(character: Character, rng: np.random.Generator) -> Character:
    """The character turned about +Y by a random angle and scaled by a random factor in [0.5, 2]."""
    m = Rotation.from_euler("y", rng.uniform(0, 2 * np.pi)).as_matrix() * rng.uniform(0.5, 2.0)
    skeleton = Skeleton(character.skeleton.positions @ m.T, character.skeleton.parents, character.skeleton.names)
    return Character(character.name, character.category, character.vertices @ m.T, character.faces, skeleton, character.weights)


def subdivided(character: Character) -> Character:
    """Mid-edge subdivision (each triangle into 4); a new vertex takes the mean weights of its edge's ends."""
    f = character.faces
    edges = np.sort(np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]]), axis=1)
    unique, inverse = np.unique(edges, axis=0, return_inverse=True)
    n = len(character.vertices)
    mid = (n + inverse.reshape(3, -1)).T  # (F, 3) new vertex on edges 01, 12, 20
    faces = np.concatenate([
        np.column_stack([f[:, 0], mid[:, 0], mid[:, 2]]), np.column_stack([mid[:, 0], f[:, 1], mid[:, 1]]),
        np.column_stack([mid[:, 2], mid[:, 1], f[:, 2]]), mid,
    ])
    average = sp.csr_matrix((np.full(2 * len(unique), 0.5), (np.repeat(np.arange(len(unique)), 2), unique.ravel())),
                            shape=(len(unique), n))
    vertices = np.concatenate([character.vertices, average @ character.vertices])
    weights = sp.vstack([character.weights, average @ character.weights]).tocsr()
    return Character(character.name, character.category, vertices, faces, character.skeleton, weights)


def decimated(character: Character, rng: np.random.Generator) -> Character:
    """Quadric decimation (`proxy.simplified`) to a random share (DECIMATE_SHARE) of the vertices; each new vertex
    takes the weights of its nearest original vertex (`proxy.transfer`), as sharp as the artist's."""
    share = rng.uniform(*DECIMATE_SHARE)
    vertices, faces = simplified(character.vertices, character.faces, int(share * len(character.vertices)))
    weights = transfer(character.weights.tocsr(), character.vertices, vertices, character.weights.shape[1], neighbours=1)
    return Character(character.name, character.category, vertices, faces, character.skeleton, weights, character.clips)


@dataclass
class SkinSample:
    """Model inputs for a subset of a character's vertices, with targets (see the module docstring)."""

    inputs: SkinInputs
    target: np.ndarray  # (V, K) float32 artist weight of each candidate joint
    outside: np.ndarray  # (V,) float32 artist weight on joints that are not candidates
    moved: np.ndarray  # (P, V, K, 3) float32 vertex moved by each candidate joint in each loss pose
    posed: np.ndarray  # (P, V, 3) float32 vertex skinned with the artist weights in each loss pose
    category: str

    def arrays(self) -> dict[str, np.ndarray]:
        """Flat name → array mapping for np.savez."""
        i = self.inputs
        return {"candidates": i.candidates, "pair": i.pair.astype(np.float16), "bone": i.bone, "point": i.point,
                "prior": i.prior, "target": self.target, "outside": self.outside, "moved": self.moved.astype(np.float16),
                "posed": self.posed.astype(np.float16), "category": np.array(self.category)}

    @staticmethod
    def from_arrays(data: dict[str, np.ndarray]) -> SkinSample:
        inputs = SkinInputs(data["candidates"], data["pair"].astype(np.float32), data["bone"], data["point"], data["prior"])
        return SkinSample(inputs, data["target"], data["outside"], data["moved"].astype(np.float32),
                          data["posed"].astype(np.float32), str(data["category"]))


def make_sample(character: Character, rng: np.random.Generator, vertices: int, *, helpers: bool = False) -> SkinSample:
    """Inputs on the whole (unit-cube) character, then targets for at most `vertices` random vertices. With
    `helpers`, the joints its weights never use are helpers (JointKind.HELPER: no bone of their own), as a job
    keeping an uploaded rig skins it."""
    c = normalised(character)
    skeleton = c.skeleton.with_helpers(weightless_joints(c.weights)) if helpers else c.skeleton
    inputs = skin_inputs(c.vertices, c.faces, skeleton)
    keep = np.sort(rng.choice(len(c.vertices), size=min(vertices, len(c.vertices)), replace=False))
    cand = inputs.candidates[keep]
    dense = c.weights[keep].toarray()
    target = np.take_along_axis(dense, cand, axis=1)
    skin = protocol_skin_matrices(c.skeleton, poses=LOSS_POSES, seed=int(rng.integers(2**31)))  # (P, J, 4, 4)
    v = c.vertices[keep]
    per = skin[:, cand]  # (P, V, K, 4, 4)
    moved = np.einsum("pvkab,vb->pvka", per[..., :3, :3], v) + per[..., :3, 3]
    posed = linear_blend(v, sp.csr_matrix(dense), skin)
    sub = SkinInputs(cand, inputs.pair[keep], inputs.bone, inputs.point[keep], inputs.prior[keep])
    return SkinSample(sub, target.astype(np.float32), (1.0 - target.sum(axis=1)).clip(0, 1).astype(np.float32),
                      moved.astype(np.float32), posed.astype(np.float32), c.category)


def variants(character: Character, rng: np.random.Generator, count: int, pose_degrees: float, *, turn: bool = True,
             reroot: float = 0.0, decimate: float = 0.0) -> list[Character]:
    """`count` augmented copies: the bind pose first, then clip frames (when it has clips) and random poses in
    turn, every other one subdivided when the mesh is small; each turned and scaled at random unless `turn` is
    False (the skeleton model turns its own, less: its inputs keep the upload's facing). With `reroot` > 0, each
    copy after the first loses its armature root (`rerooted`) with that chance; with `decimate` > 0, each copy
    after the first that is not subdivided is decimated (`decimated`) with that chance when it has DECIMATE_MIN
    vertices or more."""
    normal = normalised(character)
    out = []
    for k in range(count):
        base = rerooted(normal) if reroot > 0 and k > 0 and rng.uniform() < reroot else normal
        c = base
        if k > 0:
            if base.clips is not None and len(base.clips) and k % 2 == 1:
                c = reposed(base, base.clips[int(rng.integers(len(base.clips)))])
            else:
                c = reposed(base, random_pose(base, rng, pose_degrees))
        if k % 2 == 0 and k > 0 and len(c.vertices) < 20_000:
            c = subdivided(c)
        elif k > 0 and decimate > 0 and len(c.vertices) >= DECIMATE_MIN and rng.uniform() < decimate:
            c = decimated(c, rng)
        out.append(turned(c, rng) if turn else c)
    return out

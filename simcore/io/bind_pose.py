"""Where a skinned file's bind pose sits in its scene, and every node's world transform at that pose.

A glTF file keeps two poses of a skinned character: the bind pose its vertices are stored (and were weighted)
in, and the pose its nodes' TRS leave the skeleton in, which is what a viewer shows with no animation playing.
Many files are saved posed (an idle or A pose over a T-pose bind). Rigging works on the bind pose: it is the
pose the mesh was modelled in, the one the file's own clips and inverse bind matrices are relative to.
"""

from __future__ import annotations

import numpy as np

from simcore.io.gltf_document import GltfDocument
from simcore.io.gltf_rig import RiggedAsset, carrying_joint


def bind_placement(doc: GltfDocument, asset: RiggedAsset, rest: np.ndarray | None = None) -> np.ndarray:
    """(4, 4) world-from-bind-space matrix: the root joint's rest world times its inverse bind matrix.

    glTF ignores the skinned mesh node's transform (world = joint world · IBM · v), so this is where the
    bind pose appears at the nodes' rest pose; it may include a unit scale or a Z-up→Y-up rotation.
    rest: the nodes' rest world matrices when the caller has them (`GltfDocument.world_matrices`).
    """
    rest = doc.world_matrices() if rest is None else rest
    root = int(np.flatnonzero(asset.skeleton.parents < 0)[0])
    return rest[asset.joint_nodes[root]] @ np.linalg.inv(asset.bind_matrices[root])


def bind_pose_worlds(doc: GltfDocument, asset: RiggedAsset) -> np.ndarray:
    """(N, 4, 4) world transform of every node with the rig at its bind pose, placed where `bind_placement`
    puts it: each joint at placement · its bind matrix, so every joint's skin matrix is the placement and the
    skinned vertices land at their stored positions; a node under a joint (a prop in a hand, a joint-to-joint
    helper) keeps its rest-pose offset from the joint that carries it, as `read_rigged_asset` places such props;
    every other node its rest world."""
    rest = doc.world_matrices()
    out = rest.copy()
    out[asset.joint_nodes] = bind_placement(doc, asset, rest) @ asset.bind_matrices
    parents, slots = doc.node_parents(), {int(n): k for k, n in enumerate(asset.joint_nodes)}
    for node in range(len(rest)):
        slot = carrying_joint(parents, slots, node)
        if slot is not None and node not in slots:
            anchor = int(asset.joint_nodes[slot])
            out[node] = out[anchor] @ np.linalg.inv(rest[anchor]) @ rest[node]
    return out

"""The inverse-skinning baseline: LBS with jointly optimised weights and bone transforms (PhysRig's LBS rows).

M bones pivot at the same joints as the physics fit's driving points (the predicted skeleton's joints, or its
virtual joints); weights are a softmax over bones per vertex, initialised from the same coarse skinning
weights as the drivers (PhysRig's LBS-2 row: Pinocchio-like weights, then joint optimisation) or from
distance; each frame has a rotation (axis-angle about the joint) and a translation per bone (initialised
from the neighbourhood displacement, as the physics velocities are).
Adam on everything with the same squared-chamfer loss; torch on CPU.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

NEIGHBOURS = 16


def rodrigues(r):  # noqa: ANN001, ANN201 - torch in, torch out
    """(..., 3) axis-angle → (..., 3, 3) rotation matrices (torch)."""
    import torch

    theta = torch.sqrt((r * r).sum(-1, keepdim=True) + 1e-12)
    k = r / theta
    zero = torch.zeros_like(k[..., 0])
    kx = torch.stack([zero, -k[..., 2], k[..., 1], k[..., 2], zero, -k[..., 0], -k[..., 1], k[..., 0], zero], -1)
    kx = kx.reshape(*k.shape[:-1], 3, 3)
    eye = torch.eye(3, dtype=r.dtype).expand_as(kx)
    s, c = torch.sin(theta)[..., None], torch.cos(theta)[..., None]
    return eye + s * kx + (1 - c) * (kx @ kx)


def _chamfer_sq(a, b):
    import torch

    d = torch.cdist(a, b) ** 2
    return d.min(dim=1).values.mean() + d.min(dim=0).values.mean()


def fit_lbs(targets: np.ndarray, centres: np.ndarray, steps: int, scale: float, lr: float = 0.01,
            seed: int = 0, init_weights: np.ndarray | None = None, frozen_logits: np.ndarray | None = None,
            first: int = 0, init_motion: tuple[np.ndarray, np.ndarray] | None = None) -> tuple[np.ndarray, np.ndarray]:
    """LBS reconstruction of targets (T, V, 3) from its frame 0 with bones pivoting at centres (M, 3).

    steps: Adam iterations (the budget); scale: length unit of the loss (the physics fit's dx);
    init_weights: (V, M) coarse skinning weights to start from (default: a distance falloff);
    frozen_logits: (V, M) weight logits kept fixed (the test part of the train/test protocol), only the
    per-frame transforms are fitted, on frames > `first`;
    init_motion: per-frame bone motions from frame 0 (rotations (T, M, 3, 3), translations (T, M, 3): x ↦ R x + t)
    to start the transforms from (the physics fit's driving-point anchors come from the same motions); default:
    no rotation and the mean displacement of the vertices nearest each bone's joint.
    Returns (T, V, 3) float64 frames and the (V, M) weight logits.
    """
    import torch

    torch.manual_seed(seed)
    tgt = torch.as_tensor(np.asarray(targets, np.float64))
    rest = tgt[0]
    c = torch.as_tensor(np.asarray(centres, np.float64))
    if frozen_logits is not None:
        logits = torch.as_tensor(np.asarray(frozen_logits, np.float64))
    elif init_weights is not None:
        logits = torch.log(torch.as_tensor(np.asarray(init_weights, np.float64)) + 1e-4).requires_grad_(True)
    else:
        d2 = torch.cdist(rest, c) ** 2
        spread = float(cKDTree(centres).query(centres, k=2)[0][:, 1].mean()) if len(centres) > 1 else 1.0
        logits = (-d2 / (2 * spread**2)).clone().requires_grad_(True)
    _, near = cKDTree(np.asarray(targets[0])).query(centres, k=min(NEIGHBOURS, targets.shape[1]))
    shift = (np.asarray(targets)[1:, near] - np.asarray(targets)[0, near][None]).mean(axis=2)  # (T-1, M, 3)
    rot0 = np.zeros_like(shift)
    if init_motion is not None:  # about joint c: R x + t = R (x − c) + c + (R c + t − c)
        from scipy.spatial.transform import Rotation

        r, t = (np.asarray(m, np.float64)[1:] for m in init_motion)
        shift = np.einsum("tmab,mb->tma", r, centres) + t - np.asarray(centres)[None]
        rot0 = Rotation.from_matrix(r.reshape(-1, 3, 3)).as_rotvec().reshape(shift.shape)
    trans = torch.as_tensor(shift).clone().requires_grad_(True)
    rot = torch.as_tensor(rot0).clone().requires_grad_(True)
    opt = torch.optim.Adam([trans, rot] + ([logits] if frozen_logits is None else []), lr=lr)

    def pose():  # noqa: ANN202 - (T-1, V, 3) tensor
        w = torch.softmax(logits, dim=1)  # (V, M)
        R = rodrigues(rot)  # (T-1, M, 3, 3)
        local = rest[None, :, None, :] - c[None, None]  # (1, V, M, 3)
        moved = torch.einsum("tmab,tvmb->tvma", R, local.expand(len(R), -1, -1, -1)) + c[None, None] + trans[:, None]
        return torch.einsum("vm,tvma->tva", w, moved)

    for _ in range(steps):
        opt.zero_grad()
        frames = pose()
        loss = sum(_chamfer_sq(frames[f], tgt[f + 1]) for f in range(first, len(frames))) / scale**2
        loss.backward()
        opt.step()
    with torch.no_grad():
        return torch.cat([rest[None], pose()]).numpy(), logits.detach().numpy().copy()

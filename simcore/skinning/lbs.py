"""Linear blend skinning."""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp


def linear_blend(vertices: np.ndarray, weights: sp.spmatrix | np.ndarray, skin_matrices: np.ndarray) -> np.ndarray:
    """Deform bind-pose vertices.

    vertices: (V, 3) float; weights: (V, J) sparse or dense, rows summing to 1;
    skin_matrices: (J, 4, 4) or (T, J, 4, 4) world(pose) @ inverse(world(bind)).
    Returns (V, 3) or (T, V, 3) float64.
    """
    w = sp.csr_matrix(weights)
    single = skin_matrices.ndim == 3
    mats = skin_matrices[None] if single else skin_matrices
    t, j = mats.shape[:2]
    # Blend the 3x4 matrices per vertex (V, T*12) then apply: one sparse product for all frames.
    blended = w @ mats[:, :, :3, :].transpose(1, 0, 2, 3).reshape(j, t * 12)
    blended = np.asarray(blended).reshape(len(vertices), t, 3, 4).transpose(1, 0, 2, 3)
    out = np.einsum("tvab,vb->tva", blended[..., :3], vertices) + blended[..., 3]
    return out[0] if single else out

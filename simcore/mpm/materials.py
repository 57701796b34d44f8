"""Material prototypes (PhysRig §3.2): Gaussian ellipsoids with their own E and ν, blended per particle.

A particle's weight over prototypes is softmax_p(−d_p(x)) with the Mahalanobis distance
d_p(x) = (x − C_p)ᵀ Q_p (x − C_p), Q_p = V_pᵀ Λ_p V_p (eq. 11; the paper writes softmax(d) but means that
nearer prototypes weigh more, hence the minus sign). Particle E and ν are the weighted sums; Lamé
parameters follow eq. 6. Per-bone-region stiffness multipliers scale E through the skinning weights.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from simcore.errors import InvalidInput


@dataclass(frozen=True)
class Material:
    """Young's modulus E (Pa), Poisson's ratio nu, density (kg/m³)."""

    E: float
    nu: float
    density: float


# Soft-tissue orders of magnitude (E of human soft tissue spans ~1e3-1e6 Pa); nu near-incompressible but
# below 0.45 so that λ stays a small multiple of μ and the stiffness time-step bound stays affordable.
PRESETS: dict[str, Material] = {
    "fat": Material(1.5e4, 0.42, 920.0),
    "flesh": Material(4.0e4, 0.40, 1000.0),
    "muscle": Material(1.2e5, 0.40, 1060.0),
    "rubber": Material(4.0e5, 0.42, 1100.0),
    "stiff": Material(2.0e6, 0.35, 1100.0),
}


@dataclass
class Prototypes:
    """P Gaussian ellipsoid material prototypes.

    centres: (P, 3) float64 metres; rotations: (P, 3, 3) float64 (V_p, rows = ellipsoid axes);
    inv_sq_radii: (P, 3) float64 diagonal of Λ_p (1 / radius² per axis, 1/m²);
    E: (P,) float64 Pa; nu: (P,) float64.
    """

    centres: np.ndarray
    rotations: np.ndarray
    inv_sq_radii: np.ndarray
    E: np.ndarray
    nu: np.ndarray

    @property
    def count(self) -> int:
        return int(self.centres.shape[0])


def lame(E: np.ndarray | float, nu: np.ndarray | float) -> tuple[np.ndarray, np.ndarray]:
    """Eq. 6: (μ, λ) in Pa from Young's modulus E (Pa) and Poisson's ratio ν, elementwise."""
    E, nu = np.asarray(E, dtype=np.float64), np.asarray(nu, dtype=np.float64)
    return E / (2.0 * (1.0 + nu)), E * nu / ((1.0 + nu) * (1.0 - 2.0 * nu))


def farthest_points(points: np.ndarray, count: int, seed: int = 0) -> np.ndarray:
    """(count,) int64 indices of a farthest-point sample of points (N, 3), starting from a seeded random point."""
    pts = np.asarray(points, dtype=np.float64)
    count = min(int(count), len(pts))
    rng = np.random.default_rng(seed)
    chosen = np.empty(count, np.int64)
    chosen[0] = rng.integers(len(pts))
    dist = np.linalg.norm(pts - pts[chosen[0]], axis=1)
    for i in range(1, count):
        chosen[i] = int(np.argmax(dist))
        dist = np.minimum(dist, np.linalg.norm(pts - pts[chosen[i]], axis=1))
    return chosen


def seed_prototypes(points: np.ndarray, count: int, material: Material, volume: float, seed: int = 0) -> Prototypes:
    """Prototypes spread uniformly through the volume (farthest-point sample of the particles), spherical, with
    radius the edge of a cube holding volume / count, all starting from `material`.

    points: (N, 3) float particle rest positions; volume: solid volume in m³.
    """
    centres = np.asarray(points, dtype=np.float64)[farthest_points(points, count, seed)]
    p = len(centres)
    radius = max((volume / max(p, 1)) ** (1.0 / 3.0), 1e-6)
    return Prototypes(
        centres,
        np.tile(np.eye(3), (p, 1, 1)),
        np.full((p, 3), 1.0 / radius**2),
        np.full(p, material.E),
        np.full(p, material.nu),
    )


def prototype_weights(points: np.ndarray, protos: Prototypes) -> np.ndarray:
    """(N, P) float64 eq. 11 softmax over prototypes of the negative Mahalanobis distance; rows sum to 1."""
    diff = np.asarray(points, dtype=np.float64)[:, None, :] - protos.centres[None]  # (N, P, 3)
    local = np.einsum("pab,npb->npa", protos.rotations, diff)
    d = np.einsum("npa,pa->np", local**2, protos.inv_sq_radii)
    logits = -d - (-d).max(axis=1, keepdims=True)  # shift for a stable exp
    w = np.exp(logits)
    return w / w.sum(axis=1, keepdims=True)


def region_stiffness(weights: sp.spmatrix | np.ndarray, joint_names: list[str], multipliers: dict[str, float]) -> np.ndarray:
    """(N,) float64 per-particle E multiplier: Σ_j w_pj m_j with m_j = multipliers.get(name, 1).

    weights: (N, J) skinning weights of the particles (rows sum to 1); unknown joint names are an error.
    """
    unknown = sorted(set(multipliers) - set(joint_names))
    if unknown:
        raise InvalidInput(f"bone_stiffness names joints not in the skeleton: {unknown[:5]}",
                           code="unknown_joint", field="refine.bone_stiffness")
    bad = [k for k, m in multipliers.items() if not (np.isfinite(m) and 0.01 <= m <= 100.0)]
    if bad:
        raise InvalidInput(f"bone_stiffness multipliers must lie in [0.01, 100]: {bad[:5]}",
                           code="invalid_stiffness", field="refine.bone_stiffness")
    m = np.array([multipliers.get(name, 1.0) for name in joint_names], dtype=np.float64)
    return np.asarray(weights @ m, dtype=np.float64).reshape(-1)


def particle_lame(weights: np.ndarray, protos: Prototypes, stiffness: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """(μ, λ) per particle, each (N,) float32 Pa, from prototype weights (N, P) and an optional (N,) E multiplier."""
    E = weights @ protos.E
    nu = weights @ protos.nu
    if stiffness is not None:
        E = E * stiffness
    mu, lam = lame(E, nu)
    return mu.astype(np.float32), lam.astype(np.float32)


def max_wave_speed(protos: Prototypes, density: float, stiffness: np.ndarray | None = None) -> float:
    """Largest P-wave speed sqrt((λ + 2μ) / ρ) in m/s over prototypes (times the largest multiplier)."""
    mu, lam = lame(protos.E, protos.nu)
    scale = 1.0 if stiffness is None or not len(stiffness) else float(np.max(stiffness))
    return float(np.sqrt(np.max(lam + 2.0 * mu) * scale / density))

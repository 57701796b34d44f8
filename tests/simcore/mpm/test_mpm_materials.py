import numpy as np
import pytest
import scipy.sparse as sp

from simcore.errors import InvalidInput
from simcore.mpm.materials import PRESETS, lame, particle_lame, prototype_weights, region_stiffness, seed_prototypes


def test_prototype_softmax_rows_sum_to_one_and_prefer_the_nearest_prototype():
    rng = np.random.default_rng(0)
    points = rng.uniform(-1, 1, (500, 3))
    protos = seed_prototypes(points, 25, PRESETS["flesh"], volume=8.0, seed=0)
    w = prototype_weights(points, protos)
    assert w.shape == (500, 25)
    np.testing.assert_allclose(w.sum(axis=1), 1.0, rtol=1e-12)
    assert np.all(w >= 0)
    nearest = np.argmin(np.linalg.norm(points[:, None] - protos.centres[None], axis=2), axis=1)
    assert np.mean(np.argmax(w, axis=1) == nearest) == 1.0  # spherical, equal radii: Mahalanobis order = Euclidean


def test_particle_material_interpolates_prototype_moduli():
    points = np.array([[0.0, 0, 0], [1.0, 0, 0], [0.5, 0, 0]])
    protos = seed_prototypes(points[:2], 2, PRESETS["flesh"], volume=0.01, seed=0)
    protos.E[:] = [1e4, 1e6]
    w = prototype_weights(points, protos)
    mu, lam = particle_lame(w, protos)
    e_mid = w[2] @ protos.E
    np.testing.assert_allclose(mu[2], lame(e_mid, 0.4)[0], rtol=1e-6)
    assert mu.min() >= lame(1e4, 0.4)[0] * 0.999 and mu.max() <= lame(1e6, 0.4)[0] * 1.001


def test_bone_stiffness_scales_through_skinning_weights_and_rejects_unknown_joints():
    w = sp.csr_matrix(np.array([[1.0, 0.0], [0.5, 0.5], [0.0, 1.0]]))
    np.testing.assert_allclose(region_stiffness(w, ["a", "b"], {"b": 3.0}), [1.0, 2.0, 3.0])
    with pytest.raises(InvalidInput) as err:
        region_stiffness(w, ["a", "b"], {"c": 2.0})
    assert err.value.field == "refine.bone_stiffness"

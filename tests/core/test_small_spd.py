# SPDX-License-Identifier: GPL-3.0-or-later
"""lapig_core.common.small_spd: batched Cholesky solves of small SPD systems, against LAPACK's."""
import numpy as np
import pytest

from lapig.lapig_core.common.small_spd import cholesky, spd_inverse, spd_solve


def _spd(count, k, seed=0, ridge=1e-3):
    rng = np.random.default_rng(seed)
    a = rng.normal(size=(count, k + 3, k))
    g = np.swapaxes(a, -1, -2) @ a
    return g + ridge * np.trace(g, axis1=-2, axis2=-1)[:, None, None] * np.eye(k), rng


@pytest.mark.parametrize("k", [1, 2, 3, 4])
def test_solve_matches_lapack(k):
    g, rng = _spd(500, k)
    b = rng.normal(size=(500, k, 3))
    assert np.allclose(spd_solve(g, b), np.linalg.solve(g, b), rtol=1e-9, atol=1e-10)


def test_inverse_and_factor():
    g, _ = _spd(200, 4, seed=1)
    low = cholesky(g)
    assert np.allclose(low @ np.swapaxes(low, -1, -2), g)
    assert np.allclose(np.triu(low[0], 1), 0.0)
    assert np.allclose(spd_inverse(g) @ g, np.eye(4), atol=1e-9)


def test_ill_conditioned_normal_matrix_of_a_dead_pixel_stays_finite_with_the_ridge():
    """A pixel the projector never changes: its design's colour columns are all zero, the ridge keeps it SPD."""
    x = np.zeros((1, 10, 4))
    x[..., 3] = 1.0
    g = np.swapaxes(x, -1, -2) @ x
    g[..., range(4), range(4)] += 1e-6 * np.trace(g, axis1=-2, axis2=-1)[..., None] + 1e-12
    b = spd_solve(g, np.swapaxes(x, -1, -2) @ np.full((1, 10, 3), 0.25))
    assert np.isfinite(b).all() and np.allclose(b[0, 3], 0.25, atol=1e-4)


def test_a_matrix_that_is_not_positive_definite_gives_nan_for_that_pixel_only():
    g = np.stack([np.array([[1.0, 2.0], [2.0, 1.0]]), np.eye(2)])  # the first has eigenvalues 3 and -1
    out = spd_solve(g, np.ones((2, 2, 1)))
    assert np.isnan(out[0]).all()
    assert np.allclose(out[1], 1.0)

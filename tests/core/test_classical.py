# SPDX-License-Identifier: GPL-3.0-or-later
"""Classical per-pixel baseline: recovery on synthetic ground truth, compensation, robustness."""
import numpy as np
import pytest

from lapig.lapig_core.photometric.classical import ClassicalModel

GC, GP = 2.2, 1.8
H, W = 32, 40


def _truth(seed=0, h=H, w=W):
    """Texture-like albedo times a diagonal-dominant channel mixing, plus ambient offset."""
    rng = np.random.default_rng(seed)
    yy, xx = np.mgrid[0:h, 0:w]
    stripes = 0.5 + 0.3 * np.sin(xx / 3.0)[..., None] * np.array([1.0, 0.6, 0.2])
    albedo = np.clip(stripes + 0.2 * rng.random((h, w, 3)), 0.2, 1.0)
    mix = np.array([[0.80, 0.10, 0.05], [0.08, 0.75, 0.10], [0.03, 0.12, 0.70]])
    m = albedo[..., :, None] * mix * (0.9 + 0.2 * rng.random((h, w, 3, 3)))
    o = 0.02 + 0.04 * rng.random((h, w, 3))
    return ClassicalModel(GC, GP, m, o)


def _patterns(n, seed, lo=0.0, hi=1.0, h=H, w=W):
    rng = np.random.default_rng(seed)
    return (lo + (hi - lo) * rng.random((n, h, w, 3))).astype(np.float32)


def _psnr(a, b):
    return 10 * np.log10(1.0 / np.mean((np.asarray(a, np.float64) - b) ** 2))


@pytest.fixture(scope="module")
def truth():
    return _truth()


@pytest.fixture(scope="module")
def fitted(truth):
    prj = _patterns(40, seed=1)
    return ClassicalModel.fit(prj, truth.simulate(prj))


def test_fit_recovers_gammas_and_predicts_held_out(truth, fitted):
    assert abs(fitted.gamma_c - GC) <= 0.1 and abs(fitted.gamma_p - GP) <= 0.1
    assert fitted.residual < 1e-3
    held_out = _patterns(10, seed=2)
    assert _psnr(fitted.simulate(held_out), truth.simulate(held_out)) > 40
    assert fitted.fit_seconds > 0


def test_fit_with_capture_noise(truth):
    rng = np.random.default_rng(3)
    prj = _patterns(40, seed=4)
    cam = np.clip(truth.simulate(prj) + 0.005 * rng.standard_normal(prj.shape), 0, 1)
    model = ClassicalModel.fit(prj, cam.astype(np.float32))
    assert abs(model.gamma_c - GC) <= 0.1 and abs(model.gamma_p - GP) <= 0.1
    assert 0.003 < model.residual < 0.008  # about the noise level
    held_out = _patterns(10, seed=5)
    assert _psnr(model.simulate(held_out), truth.simulate(held_out)) > 45


def test_fixed_gammas_skip_search(truth):
    prj = _patterns(16, seed=6)
    model = ClassicalModel.fit(prj, truth.simulate(prj), gammas=(GC, GP))
    assert (model.gamma_c, model.gamma_p) == (GC, GP)
    # float32 captures limit the precision of a 16-sample fit
    np.testing.assert_allclose(model.M, truth.M, atol=2e-4)
    np.testing.assert_allclose(model.o, truth.o, atol=2e-4)


def test_compensate_inverts_simulate_in_reachable_range(fitted):
    prj = _patterns(4, seed=7, lo=0.05, hi=0.95)
    back = fitted.compensate(fitted.simulate(prj))
    assert back.dtype == np.float32 and back.shape == prj.shape
    assert np.abs(back - prj).max() < 2e-3
    single = fitted.compensate(fitted.simulate(prj[0]))
    assert single.shape == prj[0].shape


def test_compensate_clips_unreachable_targets(fitted):
    white = np.ones((H, W, 3), np.float32)  # brighter than the projector can reach
    black = np.zeros((H, W, 3), np.float32)  # darker than the ambient offset
    for target in (white, black):
        out = fitted.compensate(target)
        assert np.isfinite(out).all() and out.min() >= 0 and out.max() <= 1
    assert np.all(fitted.compensate(black) == 0)
    assert np.all(fitted.compensate(white).max(axis=-1) == 1)


def test_reachable_marks_targets_inside_the_projector_range(fitted):
    inside = fitted.simulate(_patterns(3, seed=9, lo=0.1, hi=0.9))
    assert inside.shape[:3] == (3, H, W) and fitted.reachable(inside).all()
    white, black = np.ones((H, W, 3), np.float32), np.zeros((H, W, 3), np.float32)
    assert not fitted.reachable(white).any() and not fitted.reachable(black).any()
    half = np.where(np.arange(W)[None, :, None] < W // 2, inside[0], white)
    assert fitted.reachable(half).shape == (H, W)
    np.testing.assert_array_equal(fitted.reachable(half).all(axis=0), np.arange(W) < W // 2)


def test_dead_and_saturated_pixels_give_no_nan(truth):
    prj = _patterns(12, seed=8)
    cam = truth.simulate(prj)
    cam[:, :6, :] = 0.0  # outside the object: no signal at all
    cam[:, 6:10, :5] = 0.3  # I+ == I-: constant capture
    cam[:, -3:, -3:] = 1.0  # always saturated
    model = ClassicalModel.fit(prj, cam)
    assert np.isfinite(model.M).all() and np.isfinite(model.o).all()
    assert np.isfinite(model.residual)
    sim = model.simulate(_patterns(3, seed=9))
    comp = model.compensate(_patterns(3, seed=10))
    assert np.isfinite(sim).all() and np.isfinite(comp).all()
    assert sim.min() >= 0 and sim.max() <= 1 and comp.min() >= 0 and comp.max() <= 1
    np.testing.assert_allclose(sim[:, :6], 0.0, atol=1e-4)  # the mean capture there
    np.testing.assert_allclose(sim[:, 6:10, :5], 0.3, atol=2e-3)
    np.testing.assert_allclose(sim[:, -3:, -3:], 1.0, atol=1e-4)
    assert np.all(comp[:, :6] == 0) and np.all(comp[:, 6:10, :5] == 0)
    # the lit part still fits well
    assert _psnr(model.simulate(prj)[:, 12:-4], cam[:, 12:-4]) > 40


def test_too_few_images_and_bad_shapes():
    prj = _patterns(3, seed=11)
    with pytest.raises(ValueError, match="at least 4"):
        ClassicalModel.fit(prj, prj)
    with pytest.raises(ValueError):
        ClassicalModel.fit(_patterns(5, seed=12), _patterns(5, seed=12)[:, :-1])
    with pytest.raises(ValueError):
        ClassicalModel.fit(_patterns(5, seed=12)[..., :2], _patterns(5, seed=12)[..., :2])


def test_uint8_input(truth):
    prj = _patterns(10, seed=13)
    prj8 = np.round(prj * 255).astype(np.uint8)
    cam8 = np.round(truth.simulate(prj8.astype(np.float32) / 255) * 255).astype(np.uint8)
    model = ClassicalModel.fit(prj8, cam8, gammas=(GC, GP))
    assert model.residual < 0.003  # 8-bit quantisation only
    assert model.simulate(prj8).dtype == np.float32


def test_save_load_round_trip(tmp_path, fitted):
    path = tmp_path / "classical_model"  # no .npz suffix: must be written where asked
    fitted.save(path)
    assert path.exists()
    loaded = ClassicalModel.load(path)
    assert (loaded.gamma_c, loaded.gamma_p) == (fitted.gamma_c, fitted.gamma_p)
    assert loaded.residual == fitted.residual
    np.testing.assert_array_equal(loaded.M, fitted.M)
    np.testing.assert_array_equal(loaded.o, fitted.o)
    prj = _patterns(2, seed=14)
    np.testing.assert_array_equal(loaded.simulate(prj), fitted.simulate(prj))

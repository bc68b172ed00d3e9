# SPDX-License-Identifier: GPL-3.0-or-later
"""Several projectors (issue 36): blend weights and alpha maps, the black level of overlaps, coverage."""
import numpy as np
import pytest

from lapig.tools.fakes import fake_rig
from lapig.lapig_core.multi.black_level import black_uplift, model_black_uplift, projector_blacks
from lapig.lapig_core.multi.blend import BlendSettings, alpha_maps, blend_weights, encode_alpha
from lapig.lapig_core.multi.camera_map import CameraMap
from lapig.lapig_core.multi.coverage import coverage
from lapig.lapig_core.multi.joint_model import JointModel
from test_multi_fit import away_from_edges, interior

CAMERA = (160, 120)


def _side_by_side():
    rig = fake_rig.side_by_side_rig(camera_size=CAMERA, projector_size=(200, 150))
    maps = [rig.camera_map(k) for k in range(rig.count)]
    return rig, maps, [p.incidence for p in rig.projectors]


def test_blend_weights_sum_to_one_where_any_projector_reaches():
    rig, maps, incidence = _side_by_side()
    weights = blend_weights(maps, incidence)
    reached = np.stack([m.valid for m in maps])
    total = weights.sum(axis=0)
    assert np.abs(total[reached.any(axis=0)] - 1).max() < 0.02
    assert np.all(weights[~reached] == 0) and np.all(weights >= 0)
    only = reached[0] & ~reached[1]
    assert np.allclose(weights[0][only], 1.0)


def test_blend_weights_have_no_steps():
    settings = BlendSettings()
    rig, maps, incidence = _side_by_side()
    weights = blend_weights(maps, incidence, settings)
    ramp_px = settings.ramp * max(CAMERA)
    both = np.stack([m.valid for m in maps]).any(axis=0)
    steps = []
    for axis in (0, 1):
        diff = np.abs(np.diff(weights, axis=axis + 1))
        pair = np.logical_and(np.take(both, range(both.shape[axis] - 1), axis),
                              np.take(both, range(1, both.shape[axis]), axis))
        steps.append(diff[:, pair].max())
    # the smoothstep's steepest slope is 1.5 / ramp_px; incidence and density add a little
    assert max(steps) < 2.0 / ramp_px, (max(steps), 2.0 / ramp_px)


def test_blend_weights_favour_the_projector_with_better_incidence():
    size = (80, 60)
    h = fake_rig.homography_onto(size, CAMERA, [(0.05, 0.05), (0.95, 0.05), (0.95, 0.95), (0.05, 0.95)])
    inc = np.full(CAMERA[::-1], 1.0, np.float32), np.full(CAMERA[::-1], 0.4, np.float32)
    rig = fake_rig.FakeRig([fake_rig.FakeProjector(size, h, incidence=i) for i in inc], CAMERA)
    maps = [rig.camera_map(k) for k in range(2)]  # the same frame on the same pixels: only incidence differs
    weights = blend_weights(maps, [p.incidence for p in rig.projectors])
    reached = maps[0].valid
    np.testing.assert_allclose(weights[0][reached], 1 / 1.4, atol=1e-3)
    # and in the side-by-side rig, each weighs more on its square-on side of the overlap
    _, maps, incidence = _side_by_side()
    weights = blend_weights(maps, incidence, BlendSettings(ramp=0.0))
    overlap = maps[0].valid & maps[1].valid
    cols = np.flatnonzero(overlap.any(axis=0))
    left, right = overlap.copy(), overlap.copy()
    left[:, cols[len(cols) // 2]:] = False
    right[:, :cols[len(cols) // 2]] = False
    assert weights[0][left].mean() > 0.52 and weights[1][right].mean() > 0.52
    across = np.array([weights[0][:, c][overlap[:, c]].mean() for c in cols])
    assert np.all(np.diff(across) < 0)  # the left projector's share falls as its light grazes more


def test_pixel_density_weighs_a_finer_projector_more():
    """Two projectors over the same area, one with twice the pixels each way: 4x the density."""
    quad = [(0.05, 0.05), (0.95, 0.05), (0.95, 0.95), (0.05, 0.95)]
    coarse = fake_rig.FakeProjector((60, 45), fake_rig.homography_onto((60, 45), CAMERA, quad))
    fine = fake_rig.FakeProjector((120, 90), fake_rig.homography_onto((120, 90), CAMERA, quad))
    rig = fake_rig.FakeRig([coarse, fine], CAMERA)
    maps = [rig.camera_map(k) for k in range(2)]
    weights = blend_weights(maps, settings=BlendSettings(ramp=0.0, density_power=0.5))
    inside = interior(maps[0].valid & maps[1].valid, 3)
    np.testing.assert_allclose(weights[1][inside], 2 / 3, atol=0.01)  # sqrt(4) : 1


def test_alpha_maps_carry_the_weights_into_each_projector_frame():
    rig, maps, incidence = _side_by_side()
    weights = blend_weights(maps, incidence)
    alphas = alpha_maps(maps, weights)
    for m, w, alpha, proj in zip(maps, weights, alphas, rig.projectors):
        assert alpha.shape == (proj.size[1], proj.size[0])
        assert alpha.min() >= 0 and alpha.max() <= 1
        back = m.sample(alpha)
        inside = interior(m.valid, 2)
        assert np.abs(back - w)[inside].max() < 0.03
        encoded = encode_alpha(alpha, proj.gamma)
        np.testing.assert_allclose(np.power(encoded, proj.gamma), alpha, atol=1e-5)
        assert np.all(encoded >= alpha - 1e-6)  # gamma > 1: the signal's factor is above the light's


# ------------------------------------------------------------------ black level
def _twin_rig(count):
    """`count` identical projectors (same gain, contrast, no incidence) over overlapping areas."""
    quads = [[(0.03, 0.06), (0.63, 0.03), (0.61, 0.96), (0.02, 0.93)],
             [(0.37, 0.04), (0.97, 0.07), (0.98, 0.94), (0.39, 0.97)],
             [(0.22, 0.35), (0.78, 0.38), (0.80, 0.97), (0.20, 0.95)]][:count]
    size = (80, 60)
    return fake_rig.FakeRig([fake_rig.FakeProjector(size, fake_rig.homography_onto(size, (64, 48), q), gain=0.5,
                                                    contrast=500.0) for q in quads], (64, 48), noise=0.001)


@pytest.mark.parametrize("count", [2, 3])
def test_black_uplift_is_the_number_of_overlapping_projectors(count):
    rig = _twin_rig(count)
    shown = [fake_rig.smooth_frames(p.size, 16, seed=20 + k) for k, p in enumerate(rig.projectors)]
    captures, black = rig.capture_alone(shown)
    model = JointModel.fit([rig.camera_map(k) for k in range(count)], shown, captures, black)
    report = model_black_uplift(model, [500.0] * count)
    assert report.uplift == pytest.approx(2.0, rel=0.05)
    assert report.single_contrast == pytest.approx(500, rel=0.05)
    assert report.overlap_contrast == pytest.approx(250, rel=0.05)
    assert report.contrast_cost == pytest.approx(0.5, abs=0.03)
    assert "2.0x" in report.sentence() and "500:1" in report.sentence()
    if count == 3:
        assert report.by_count[3] == pytest.approx(3.0, rel=0.05)
    # the model's black map is the fake's own black light
    truth = sum(rig.true_black(k) for k in range(count))
    inside = away_from_edges(model)
    np.testing.assert_allclose(projector_blacks(model, [500.0] * count).sum(axis=0)[inside], truth[inside], rtol=0.06, atol=2e-6)


def test_black_uplift_follows_the_blend_and_the_contrasts():
    """Uplift is black over the blended white: with a 0.8/0.2 blend of equal projectors it is still 2
    (white stays one projector's); with contrasts 1000 and 250 the overlap's black is 1/1000 + 1/250."""
    reached = np.zeros((2, 4, 6), bool)
    reached[0, :, :4] = reached[1, :, 2:] = True
    whites = np.ones((2, 4, 6, 3)) * reached[..., None]
    weights = np.where(reached.all(axis=0), np.array([0.8, 0.2])[:, None, None], reached.astype(float))
    same = black_uplift(whites / 500, whites, reached, weights)
    assert same.uplift == pytest.approx(2.0) and same.contrast_cost == pytest.approx(0.5)
    mixed = black_uplift(whites * np.array([1 / 1000, 1 / 250])[:, None, None, None], whites, reached)
    assert mixed.overlap_black == pytest.approx(1 / 1000 + 1 / 250)
    assert mixed.single_contrast == pytest.approx(1 / np.median([1 / 1000] * 8 + [1 / 250] * 8))
    none = black_uplift(whites[:1] / 500, whites[:1], reached[:1])
    assert "no brighter" in none.sentence()


# ------------------------------------------------------------------ coverage
def test_coverage_shares_of_the_object():
    h, w = 10, 20
    yy, xx = np.mgrid[0:h, 0:w].astype(np.float32)
    left = CameraMap(xx, yy, xx < 10, (w, h))  # the left half
    right = CameraMap(xx, yy, xx >= 5, (w, h))  # the right three quarters
    obj = np.ones((h, w), bool)
    obj[:, -2:] = False  # the object stops 2 columns short of the frame
    cov = coverage([left, right], obj)
    assert cov.object_pixels == 180
    assert cov.reached == pytest.approx(1.0)
    assert cov.per_projector == pytest.approx((100 / 180, 130 / 180))
    assert cov.overlap == pytest.approx(50 / 180)
    assert cov.lines(["Left", "Right"]) == ["All projectors: 100% of the object (28% by two or more)",
                                            "Left: 56%", "Right: 72%"]
    assert coverage([left], obj).reached == pytest.approx(100 / 180)
    with pytest.raises(ValueError, match="empty"):
        coverage([left], np.zeros((h, w), bool))

# SPDX-License-Identifier: GPL-3.0-or-later
"""Several projectors (issue 36): the box QP, the joint compensation, its reach, K = 1 against box_solve, K = 3."""
import itertools
import time

import cv2
import numpy as np
import pytest

from lapig.tools.fakes import fake_rig
from lapig.lapig_core.multi.blend import blend_weights
from lapig.lapig_core.multi.box_qp import box_quadratic
from lapig.lapig_core.multi.joint_model import JointModel
from lapig.lapig_core.multi.joint_solve import joint_compensate, joint_drives, reach
from lapig.lapig_core.photometric.box_solve import (box_compensate, box_compensate_linear, box_least_squares,
                                                    response_weights)
from lapig.lapig_core.photometric.classical import ClassicalModel
from test_multi_fit import away_from_edges, fitted

LEVEL = 1.0 / 255


def _cost(h, g, x):
    return 0.5 * np.einsum("pi,pij,pj->p", x, h, x) - np.einsum("pi,pi->p", g, x)


def _brute_force(h, g):
    """The box optimum by enumerating every active set (3^n): each candidate clipped, the cheapest kept."""
    p, n = g.shape
    best, best_cost = np.zeros((p, n)), np.full(p, np.inf)
    for pattern in itertools.product((0, 1, 2), repeat=n):
        pattern = np.array(pattern)
        free = pattern == 0
        x = np.broadcast_to((pattern == 2).astype(float), (p, n)).copy()
        if free.any():
            rhs = g[:, free] - np.einsum("pij,pj->pi", h[:, free][:, :, ~free], x[:, ~free])
            x[:, free] = np.clip(np.linalg.solve(h[:, free][:, :, free], rhs[..., None])[..., 0], 0, 1)
        cost = _cost(h, g, x)
        better = cost < best_cost
        best[better], best_cost[better] = x[better], cost[better]
    return best, best_cost


def test_box_quadratic_finds_the_box_optimum_of_six_unknowns():
    rng = np.random.default_rng(0)
    a = rng.normal(size=(300, 4, 6)) * rng.uniform(0.05, 1.0, size=(300, 1, 6))
    h = np.swapaxes(a, 1, 2) @ a + 1e-3 * np.eye(6)
    g = np.einsum("pki,pk->pi", a, rng.normal(0.5, 1.0, size=(300, 4)))
    x = box_quadratic(h, g)
    assert x.min() >= 0 and x.max() <= 1
    _, best = _brute_force(h, g)
    assert np.all(_cost(h, g, x) <= best + 1e-9 * (1 + np.abs(best)))
    assert ((x > 1e-9) & (x < 1 - 1e-9)).any() and ((x == 0) | (x == 1)).any()  # both kinds were exercised


def test_box_quadratic_holds_frozen_unknowns_at_zero():
    rng = np.random.default_rng(1)
    a = rng.normal(size=(50, 3, 6))
    h = np.swapaxes(a, 1, 2) @ a + 1e-3 * np.eye(6)
    g = np.abs(rng.normal(size=(50, 6)))
    frozen = np.zeros((50, 6), bool)
    frozen[:, 3:] = True
    x = box_quadratic(h, g, frozen)
    assert np.all(x[:, 3:] == 0)
    np.testing.assert_allclose(x[:, :3], box_quadratic(h[:, :3, :3], g[:, :3]), atol=1e-9)


def test_box_quadratic_with_three_unknowns_is_box_solves_least_squares():
    rng = np.random.default_rng(2)
    a = rng.normal(0.3, 0.3, size=(2000, 3, 3))
    r = rng.normal(0.4, 0.5, size=(2000, 3))
    h, g = np.swapaxes(a, 1, 2) @ a, np.einsum("pki,pk->pi", a, r)
    x, enumerated = box_quadratic(h, g), box_least_squares(a, r)
    np.testing.assert_allclose(x, enumerated, atol=1e-4)  # equal up to the ill-conditioned pixels' rounding
    assert np.all(_cost(h, g, x) <= _cost(h, g, enumerated) + 1e-12)


# ------------------------------------------------------------------ joint compensation
def _reachable_target(model, seed=0, lo=0.05, hi=0.95):
    """A capture the model can show: f_c(o + sum_k M_k q_k) for smooth drives q_k in [lo, hi]."""
    h, w = model.shape
    q = np.stack([lo + (hi - lo) * fake_rig.smooth_frames((w, h), 3, seed=seed + k)[2] for k in range(model.count)])
    return model.predict_linear(q * model.reached[..., None])


def test_reach_is_the_sum_of_the_reaching_projectors_ranges():
    _, _, model = fitted("two")
    black, white = reach(model)
    np.testing.assert_allclose(black, np.power(np.clip(model.o, 0, 1), 1 / model.gamma_c), atol=1e-6)
    overlap = model.reached.all(axis=0)
    alone = [np.power(np.clip(model.o + model.M[k].sum(-1), 0, 1), 1 / model.gamma_c) for k in range(2)]
    assert np.all(white[overlap] > np.maximum(alone[0], alone[1])[overlap] + 0.02)
    only_left = model.reached[0] & ~model.reached[1]
    np.testing.assert_allclose(white[only_left], alone[0][only_left], atol=1e-6)


@pytest.mark.parametrize("kind", ["two", "three"])
def test_joint_compensation_shows_a_reachable_target_within_one_level(kind):
    rig, _, model = fitted(kind)
    target = _reachable_target(model, seed=4)
    weights = blend_weights(model.maps, [p.incidence for p in rig.projectors])
    result = joint_compensate(model, target, weights)
    reached = model.reached.any(axis=0)
    assert np.abs(result.predicted - target)[reached].max() < LEVEL
    # the box holds, for the drives and for each projector's encoded image
    assert result.drives.min() >= 0 and result.drives.max() <= 1
    assert all(f.min() >= 0 and f.max() <= 1 for f in result.frames)
    assert [f.shape for f in result.frames] == [(p.size[1], p.size[0], 3) for p in rig.projectors]
    assert np.all(result.drives[~model.reached] == 0)  # a projector drives nothing where it does not reach


def test_overlap_shows_what_neither_projector_shows_alone():
    """A bright target in the overlap, where each projector grazes: each alone (box_solve on its own
    model) falls short; together they show it."""
    rig, _, model = fitted("two")
    target = model.predict_linear(np.full((2,) + model.shape + (3,), 0.9, np.float32) * model.reached[..., None])
    weights = blend_weights(model.maps, [p.incidence for p in rig.projectors])
    joint = np.abs(joint_compensate(model, target, weights).predicted - target).max(axis=-1)
    alone = [np.abs(model.single(k).simulate(box_compensate(model.single(k), target)) - target).max(axis=-1)
             for k in range(2)]
    overlap = model.reached.all(axis=0)
    short = overlap & (alone[0] > 3 * LEVEL) & (alone[1] > 3 * LEVEL)
    assert short.sum() > 0.8 * overlap.sum()
    assert joint[short].max() < LEVEL
    assert joint[short].mean() < 0.1 * min(alone[0][short].mean(), alone[1][short].mean())


def test_the_split_follows_the_blend_where_it_can():
    """Where the blend's split can show the target, each projector's drive is its weight times one level."""
    rig, _, model = fitted("two")
    q = np.full((2,) + model.shape + (3,), 0.3, np.float32) * model.reached[..., None]
    target = model.predict_linear(q)
    weights = blend_weights(model.maps, [p.incidence for p in rig.projectors])
    drives = joint_drives(model, target, weights)
    overlap = model.reached.all(axis=0) & (weights.min(axis=0) > 0.1)
    ratio = drives[0][overlap] / np.maximum(drives[1][overlap], 1e-6)
    expected = (weights[0][overlap] / weights[1][overlap])[:, None]
    assert np.median(np.abs(ratio / expected - 1)) < 0.02


def test_projector_images_show_the_target_on_the_rig():
    """End to end: the encoded projector images, each resampled into its own frame, captured by the fake.
    The projectors are finer than the camera, about 5 projector pixels between camera pixels."""
    rig, _, model = fitted("two", noise=0.0, projector_size=(192, 144))
    target = _reachable_target(model, seed=7, lo=0.15, hi=0.85)
    result = joint_compensate(model, target, blend_weights(model.maps, [p.incidence for p in rig.projectors]))
    seen = rig.capture(result.frames) / 255.0
    inside = away_from_edges(model, 2)
    err = np.abs(seen - target)[inside]
    assert err.mean() < 1.5 * LEVEL, err.mean() * 255
    assert np.percentile(err, 99) < 5 * LEVEL, np.percentile(err, 99) * 255


def test_one_projector_is_box_solve():
    rng = np.random.default_rng(3)
    h, w = 24, 32
    mix = np.array([[0.80, 0.10, 0.05], [0.08, 0.75, 0.10], [0.03, 0.12, 0.70]])
    m = (0.3 + 0.7 * rng.random((h, w, 3)))[..., None] * mix * (0.9 + 0.2 * rng.random((h, w, 3, 3)))
    classical = ClassicalModel(2.2, 1.8, m, 0.02 + 0.04 * rng.random((h, w, 3)))
    target = rng.random((h, w, 3)).astype(np.float32)  # many out of reach: the active sets matter
    joint = JointModel.from_classical(classical)
    drives = joint_drives(joint, target)
    y = np.power(target.astype(np.float64), 2.2)[None]
    expected = box_compensate_linear(classical, y, response_weights(y, 2.2))[0]
    assert (~classical.reachable(target)).mean() > 0.3
    np.testing.assert_allclose(drives[0], expected, atol=1e-3)
    frame = joint_compensate(joint, target).frames[0]
    np.testing.assert_allclose(frame, box_compensate(classical, target), atol=1e-3)


def test_first_look_speed_two_projectors_800x600(capsys):
    """Fit and solve at a real size; the time is printed, not asserted."""
    rig = fake_rig.side_by_side_rig(camera_size=(640, 480), projector_size=(800, 600), noise=0.002)
    shown = [fake_rig.smooth_frames(p.size, 8, seed=k) for k, p in enumerate(rig.projectors)]
    captures, black = rig.capture_alone(shown)
    maps = [rig.camera_map(k) for k in range(rig.count)]
    t0 = time.perf_counter()
    model = JointModel.fit(maps, shown, captures, black)
    t1 = time.perf_counter()
    weights = blend_weights(maps, [p.incidence for p in rig.projectors])
    result = joint_compensate(model, _reachable_target(model), weights)
    t2 = time.perf_counter()
    with capsys.disabled():
        print(f"\n[multi] 2 projectors 800x600, camera 640x480, 8 frames each: fit {t1 - t0:.2f} s, "
              f"blend + solve + frames {t2 - t1:.2f} s, total {t2 - t0:.2f} s")
    assert result.frames[0].shape == (600, 800, 3)

# SPDX-License-Identifier: GPL-3.0-or-later
"""Several projectors (issue 36): the fake rig, camera maps, and the joint model's fit against the fake's truth."""
import functools

import cv2
import numpy as np
import pytest

from lapig.lapig_core.capture.structured_light import DecodeResult
from lapig.tools.fakes import fake_rig
from lapig.lapig_core.multi.camera_map import CameraMap
from lapig.lapig_core.multi.joint_model import JointModel
from lapig.lapig_core.multi.push_pull import push_pull


@functools.lru_cache(maxsize=None)
def fitted(kind: str = "two", frames: int = 16, noise: float = 0.002, **rig_options):
    """(rig, frames shown, joint model fitted on the rig's captures of each projector alone and of black)."""
    make = {"two": fake_rig.side_by_side_rig, "three": fake_rig.three_projector_rig}[kind]
    rig = make(noise=noise, **rig_options)
    shown = [fake_rig.smooth_frames(p.size, frames, seed=10 + k) for k, p in enumerate(rig.projectors)]
    captures, black = rig.capture_alone(shown)
    together = [fake_rig.smooth_frames(p.size, 1, seed=99 + k, cells=(3, 2))[0] * 0.8
                for k, p in enumerate(rig.projectors)]
    maps = [rig.camera_map(k) for k in range(rig.count)]
    model = JointModel.fit(maps, shown, captures, black, together=(together, rig.capture(together)))
    return rig, shown, model


def interior(mask: np.ndarray, px: int = 1) -> np.ndarray:
    """The mask less `px` pixels at its edges (where a frame's edge lights a camera pixel in part)."""
    return cv2.erode(mask.astype(np.uint8), np.ones((2 * px + 1, 2 * px + 1), np.uint8)).astype(bool)


def away_from_edges(model, px: int = 1) -> np.ndarray:
    """Reached pixels at least `px` from every projector's reach edge: a frame's last pixel lights a band
    just past its valid mask, which no model of the valid pixels can say."""
    out = model.reached.any(axis=0)
    kernel = np.ones((2 * px + 1, 2 * px + 1), np.uint8)
    for valid in model.reached.astype(np.uint8):
        out &= ~(cv2.dilate(valid, kernel).astype(bool) & ~cv2.erode(valid, kernel).astype(bool))
    return out


@pytest.mark.parametrize("kind", ["two", "three"])
def test_joint_fit_recovers_each_projectors_mixing_and_the_shared_offset(kind):
    rig, _, model = fitted(kind)
    assert model.count == rig.count
    assert abs(model.gamma_c - rig.camera_gamma) < 0.1
    for k, proj in enumerate(rig.projectors):
        assert abs(model.gamma_p[k] - proj.gamma) < 0.12
        inside = interior(rig.camera_map(k).valid)
        truth = rig.true_m(k)
        err = np.abs(model.M[k] - truth)[inside]
        scale = np.abs(truth[inside]).sum(axis=-1).mean()  # a typical row sum, ~0.3
        assert np.median(err) < 0.01 * scale, (k, np.median(err), scale)
        assert np.percentile(err, 99) < 0.08 * scale, (k, np.percentile(err, 99), scale)
        assert np.all(model.M[k][~rig.camera_map(k).valid] == 0)  # nothing where it does not reach
    reached = model.reached.any(axis=0)
    assert np.median(np.abs(model.o - rig.true_offset())[reached]) < 1e-3
    assert model.residual < 0.004  # the noise (0.002) and 8-bit steps
    assert model.together_rms < 0.006  # the light of separately fitted projectors adds up


def test_a_projector_lighting_past_its_valid_mask_does_not_bend_the_others():
    """The right projector's frame edge lights camera pixels its mask leaves out: its captures must not
    enter the shared offset there, or the left projector's M is wrong along that column."""
    rig, _, model = fitted("two", noise=0.0)
    band = cv2.dilate(rig.camera_map(1).valid.astype(np.uint8), np.ones((3, 3), np.uint8)).astype(bool) & \
        ~rig.camera_map(1).valid & interior(rig.camera_map(0).valid)
    assert band.sum() > 20
    err = np.abs(model.M[0] - rig.true_m(0))[band]
    assert err.max() < 0.01


def test_predict_matches_the_rig_for_any_frames():
    rig, _, model = fitted("two")
    frames = [fake_rig.smooth_frames(p.size, 3, seed=5 + k)[2] for k, p in enumerate(rig.projectors)]
    frames[1] = None  # black
    err = model.predict(frames) - rig.capture(frames) / 255.0
    assert np.sqrt(np.mean(err[away_from_edges(model)] ** 2)) < 0.006


def test_joint_model_saves_and_loads(tmp_path):
    _, _, model = fitted("two")
    model.save(tmp_path / "joint.npz")
    back = JointModel.load(tmp_path / "joint.npz")
    assert back.gamma_p == model.gamma_p and back.gamma_c == model.gamma_c
    np.testing.assert_array_equal(back.M, model.M)
    np.testing.assert_array_equal(back.maps[1].valid, model.maps[1].valid)
    assert back.maps[0].projector_size == model.maps[0].projector_size


def test_fit_refuses_mismatched_sets():
    rig, shown, model = fitted("two")
    captures, black = rig.capture_alone(shown)
    with pytest.raises(ValueError, match="one map"):
        JointModel.fit(model.maps, shown[:1], captures, black)
    with pytest.raises(ValueError, match="one frame per capture"):
        JointModel.fit(model.maps, [shown[0][:3], shown[1]], captures, black)


# ------------------------------------------------------------------ camera maps
def test_camera_map_density_is_the_homographys_jacobian():
    rig = fake_rig.side_by_side_rig()
    cmap = rig.camera_map(0)
    inv = np.linalg.inv(rig.projectors[0].homography)
    h, w = cmap.camera_shape
    yy, xx = np.mgrid[0:h, 0:w].astype(np.float64)
    eps = 1e-3
    def at(dx, dy):
        pts = np.stack([xx + dx, yy + dy], -1).reshape(-1, 1, 2)
        return cv2.perspectiveTransform(pts, inv).reshape(h, w, 2)
    jx, jy = (at(eps, 0) - at(-eps, 0)) / (2 * eps), (at(0, eps) - at(0, -eps)) / (2 * eps)
    exact = np.abs(jx[..., 0] * jy[..., 1] - jy[..., 0] * jx[..., 1])
    got = cmap.density()
    assert np.allclose(got[cmap.valid], exact[cmap.valid], rtol=0.02)
    assert np.all(got[~cmap.valid] == 0)


@pytest.mark.parametrize("size", [(100, 75), (400, 300)])  # coarser, then 5x finer than the camera
def test_camera_map_sends_camera_values_back_into_the_projector_frame(size):
    rig = fake_rig.side_by_side_rig(camera_size=(128, 96), projector_size=size)
    cmap = rig.camera_map(1)
    image = fake_rig.smooth_frames(size, 3, seed=3)[2]
    there = cmap.to_projector(cmap.sample(image))
    on = interior(cmap.footprint(), 3 * size[0] // 100)
    assert on.mean() > 0.4
    assert np.abs(there - image)[on].max() < 0.02  # the projector pixels between camera pixels filled too
    assert np.all(there[~cmap.footprint()] == 0)  # black off the object
    extended = cmap.to_projector(cmap.sample(image), outside=None)
    assert np.all(extended[~cmap.footprint()] > 0)  # or the nearest values, extended


def test_a_bleed_carries_the_edge_values_past_the_footprint_and_black_beyond():
    rig = fake_rig.side_by_side_rig(camera_size=(128, 96), projector_size=(400, 300))
    cmap = rig.camera_map(1)
    image = fake_rig.smooth_frames((400, 300), 3, seed=3)[2]
    values = cmap.sample(image)
    bleed = cmap.bleed_pixels()
    assert bleed == 8  # 2 % of 400
    plain, bled = cmap.to_projector(values), cmap.to_projector(values, bleed=bleed)
    foot = cmap.footprint()
    assert np.array_equal(plain[foot], bled[foot])  # the footprint itself is the same image
    ring = cv2.dilate(foot.astype(np.uint8), np.ones((2 * bleed + 1,) * 2, np.uint8)).astype(bool) & ~foot
    assert ring.any() and np.all(plain[ring] == 0)
    extended = cmap.to_projector(values, outside=None)
    assert np.allclose(bled[ring], extended[ring])  # the nearest values, extended
    far = ~cv2.dilate(foot.astype(np.uint8), np.ones((2 * bleed + 3,) * 2, np.uint8)).astype(bool)
    assert far.any() and np.all(bled[far] == 0)  # black beyond the bleed


def test_camera_map_averages_where_several_camera_pixels_land_on_one_projector_pixel():
    yy, xx = np.mgrid[0:40, 0:40].astype(np.float32)
    inside = (xx <= 36) & (yy <= 36)  # their 4 projector neighbours on the frame
    cmap = CameraMap(xx / 4, yy / 4, inside, (10, 10))  # 4x4 camera pixels per projector pixel
    values = np.random.default_rng(0).random((40, 40)).astype(np.float32)
    _, weight = cmap.splat(values)
    assert np.isclose(weight.sum(), inside.sum())  # every camera pixel counted once
    out = cmap.to_projector(values)
    around = _bilinear_weights(xx / 4, yy / 4, 5, 5) * inside
    assert np.isclose(out[5, 5], np.average(values, weights=around), atol=1e-5)


def _bilinear_weights(u, v, px, py):
    return np.clip(1 - np.abs(u - px), 0, None) * np.clip(1 - np.abs(v - py), 0, None)


def test_camera_map_from_decoded_gray_code():
    rig = fake_rig.side_by_side_rig()
    exact = rig.camera_map(0)
    decoded = DecodeResult(np.round(exact.map_x).astype(np.int32), np.round(exact.map_y).astype(np.int32),
                           exact.valid.copy())
    cmap = CameraMap.from_decoded(decoded, exact.projector_size, sigma=1.0)
    inside = interior(exact.valid, 2)
    assert np.abs(cmap.map_x - exact.map_x)[inside].mean() < 0.3  # sub-pixel on average
    np.testing.assert_array_equal(cmap.valid, exact.valid)


def test_push_pull_keeps_the_known_and_fills_the_holes_smoothly():
    yy, xx = np.mgrid[0:33, 0:47].astype(np.float32)
    ramp = (xx + yy) / 80.0
    known = np.random.default_rng(1).random((33, 47)) < 0.2
    filled = push_pull(np.where(known, ramp, np.nan), known)
    assert np.array_equal(filled[known], ramp[known])
    assert np.isfinite(filled).all()
    assert np.abs(filled - ramp).max() < 0.06
    assert np.all(push_pull(np.zeros((5, 6, 3)), np.zeros((5, 6))) == 0)


def test_fit_takes_8bit_and_float_captures_alike():
    rig, shown, model = fitted("two")
    captures, black = rig.capture_alone(shown)
    maps = model.maps
    gammas = (model.gamma_c, model.gamma_p)
    as_uint8 = JointModel.fit(maps, shown, captures, black, gammas=gammas)
    mixed = JointModel.fit(maps, shown, [c / 255.0 for c in captures], black, gammas=gammas)
    np.testing.assert_allclose(mixed.M, as_uint8.M, atol=1e-5)
    np.testing.assert_allclose(mixed.o, as_uint8.o, atol=1e-6)

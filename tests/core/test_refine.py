# SPDX-License-Identifier: GPL-3.0-or-later
"""Closed-loop refinement and the box-constrained classical solve, on a numpy rig whose light the
per-pixel model does not fully explain (a blurred bounce term), with capture noise."""
import math

import cv2
import numpy as np
import pytest

from lapig.lapig_core.photometric.box_solve import box_compensate, box_least_squares
from lapig.lapig_core.photometric.classical import ClassicalModel
from lapig.lapig_core.refine.check import RegistrationCheckError, registration_problem
from lapig.lapig_core.common.psnr import masked_psnr
from lapig.lapig_core.refine.loop import Refinement, RefineError, RefineSettings, run

H, W = 32, 40
GC, GP = 2.2, 2.0


class Rig:
    """Per-pixel light plus a bounce term (the frame's light blurred wide, 12 % of it): what a
    per-pixel model cannot hold. Noise per capture, a new draw every time."""

    def __init__(self, noise=0.004, bounce=0.12, seed=0, shift=(0, 0)):
        rng = np.random.default_rng(seed)
        yy, xx = np.mgrid[0:H, 0:W]
        albedo = np.clip(0.55 + 0.3 * np.sin(xx / 4.0)[..., None] * np.array([1.0, 0.5, -0.4])
                         + 0.1 * rng.random((H, W, 3)), 0.15, 0.95)
        mix = np.array([[0.85, 0.10, 0.03], [0.07, 0.80, 0.09], [0.02, 0.10, 0.75]])
        self.m = albedo[..., :, None] * mix
        self.o = 0.015 + 0.01 * rng.random((H, W, 3))
        self.noise, self.bounce, self.shift = noise, bounce, shift
        self.rng = np.random.default_rng(seed + 1)
        self.captured = 0

    def light(self, prj):
        x = np.power(np.clip(prj, 0, 1), GP)
        direct = np.einsum("hwij,nhwj->nhwi", self.m, x)
        glow = np.stack([cv2.GaussianBlur(d.astype(np.float32), (0, 0), 6) for d in direct])
        return direct + self.bounce * glow + self.o

    def capture(self, prj):
        prj = np.asarray(prj, np.float64)
        y = self.light(prj)
        c = np.power(np.clip(y, 0, 1), 1 / GC) + self.noise * self.rng.standard_normal(y.shape)
        c = np.roll(c, self.shift, axis=(1, 2))
        self.captured += len(prj)
        return np.clip(c, 0, 1).astype(np.float32)

    def capture_repeated(self, images, repeats):
        return self.capture(np.repeat(images, repeats, axis=0))


@pytest.fixture(scope="module")
def rig_and_model():
    rig = Rig()
    prj = np.random.default_rng(5).random((40, H, W, 3)).astype(np.float32)
    model = ClassicalModel.fit(prj, rig.capture(prj))
    return rig, model


def _targets(rig, n=3, seed=9):
    """Desired captures inside the surface's range: captures of random smooth images."""
    rng = np.random.default_rng(seed)
    coarse = rng.random((n, 4, 5, 3)).astype(np.float32)
    images = np.stack([cv2.resize(c, (W, H), interpolation=cv2.INTER_CUBIC) for c in coarse]).clip(0.05, 0.95)
    quiet = Rig(noise=0.0)
    return quiet.capture(images), quiet.capture(np.zeros_like(images))[0], quiet.capture(np.ones_like(images))[0]


def test_box_least_squares_is_the_exact_box_optimum():
    # scipy is a reference here only (the torch-free tier's venv has none)
    lsq_linear = pytest.importorskip("scipy.optimize").lsq_linear
    rng = np.random.default_rng(0)
    a = rng.normal(size=(200, 3, 3)) + 2 * np.eye(3)
    r = rng.normal(size=(200, 3)) * 2  # many out of the box
    x = box_least_squares(a, r)
    assert ((x >= 0) & (x <= 1)).all()
    for i in range(0, 200, 7):
        ref = lsq_linear(a[i], r[i], bounds=(0, 1), method="bvls").x
        cost = lambda v: np.sum((a[i] @ v - r[i]) ** 2)  # noqa: E731
        assert cost(x[i]) <= cost(ref) + 1e-9


def test_box_solve_beats_the_clip_where_the_target_is_out_of_reach(rig_and_model):
    rig, model = rig_and_model
    targets, black, white = _targets(rig)
    hard = np.clip(targets * 1.35, 0, 1)  # a brighter look: much of it out of the surface's reach
    clipped, boxed = model.compensate(hard), box_compensate(model, hard)
    assert boxed.shape == hard.shape and boxed.min() >= 0 and boxed.max() <= 1
    valid = np.ones((H, W), bool)
    err = lambda p: masked_psnr(model.simulate(p), hard, valid)  # noqa: E731
    assert err(boxed) > err(clipped) + 0.3
    reach = model.reachable(targets).all(axis=0)  # where nothing clips, both are the same inverse
    assert np.abs(box_compensate(model, targets)[:, reach] - model.compensate(targets)[:, reach]).max() < 2e-2


def test_refinement_closes_most_of_the_gap_to_the_noise_floor(rig_and_model):
    rig, model = rig_and_model
    targets, black, white = _targets(rig)
    valid = np.ones((H, W), bool)
    ref = Refinement(model, targets, black, white, valid, box_compensate(model, targets),
                     RefineSettings(iterations=8))
    rec = run(ref, rig.capture_repeated)
    assert rec.refined_psnr > rec.open_loop_psnr + 4, rec.to_dict()  # the bounce light the model missed
    assert rec.refined_psnr > rec.noise_floor_psnr - 1.5, rec.to_dict()
    assert 1 <= rec.iterations <= 8 and rec.captures >= 2 * len(targets) + rec.iterations * len(targets)
    # measured on fresh captures, not the ones the loop chose by
    fresh = masked_psnr(rig.capture(ref.images), ref.target, valid)
    assert fresh > rec.open_loop_psnr + 4
    assert 0 <= ref.images.min() and ref.images.max() <= 1


def test_refinement_stops_when_a_step_gains_too_little():
    rig = Rig(bounce=0.0, noise=0.004)  # the model explains this rig: little to gain after one step
    prj = np.random.default_rng(5).random((40, H, W, 3)).astype(np.float32)
    model = ClassicalModel.fit(prj, rig.capture(prj))
    targets, black, white = _targets(rig)
    ref = Refinement(model, targets, black, white, np.ones((H, W), bool), box_compensate(model, targets),
                     RefineSettings(iterations=20))
    rec = run(ref, rig.capture_repeated)
    assert rec.stopped.startswith("gain below") and rec.iterations < 20
    assert rec.history[-1] - rec.history[-2] < 0.05
    assert rec.refined_psnr == max(rec.history)  # the kept image is the best captured one


def test_refinement_averages_captures_once_noise_dominates():
    rig = Rig(bounce=0.12, noise=0.02)  # very noisy camera
    prj = np.random.default_rng(5).random((40, H, W, 3)).astype(np.float32)
    model = ClassicalModel.fit(prj, Rig(noise=0.004).capture(prj))
    targets, black, white = _targets(rig)
    ref = Refinement(model, targets, black, white, np.ones((H, W), bool), box_compensate(model, targets),
                     RefineSettings(iterations=6, stop_gain_db=-10))  # never stop early: watch the repeats
    rec = run(ref, rig.capture_repeated)
    assert rec.repeats[0] == 2 and max(rec.repeats[1:]) > 1
    quiet = Rig(bounce=0.12, noise=0.0005)
    ref2 = Refinement(model, targets, black, white, np.ones((H, W), bool), box_compensate(model, targets),
                      RefineSettings(iterations=2, stop_gain_db=-10))
    rec2 = run(ref2, quiet.capture_repeated)
    assert rec2.repeats[1:] == [1, 1]  # a quiet camera with a large error left: one capture is enough


def test_refinement_refuses_a_moved_object(rig_and_model):
    _, model = rig_and_model
    moved = Rig(shift=(0, 3))
    targets, black, white = _targets(moved)
    ref = Refinement(model, targets, black, white, np.ones((H, W), bool), box_compensate(model, targets))
    with pytest.raises(RegistrationCheckError, match="moved"):
        run(ref, moved.capture_repeated)


def test_registration_check_passes_in_place_and_names_a_changed_rig(rig_and_model):
    rig, model = rig_and_model
    targets, *_ = _targets(rig)
    images = box_compensate(model, targets)
    valid = np.ones((H, W), bool)
    assert registration_problem(rig.capture(images), model.simulate(images), valid) == ""
    dark = rig.capture(images) * 0.3  # the room's light changed, the object lost its texture
    assert "no longer looks" in registration_problem(dark, model.simulate(images), valid)


def test_bad_settings_and_shapes_are_refused(rig_and_model):
    _, model = rig_and_model
    t = np.zeros((1, H, W, 3), np.float32)
    with pytest.raises(RefineError, match="iterations"):
        Refinement(model, t, t[0], t[0] + 1, np.ones((H, W), bool), t, RefineSettings(iterations=0))
    with pytest.raises(RefineError, match="generate again"):
        Refinement(model, np.zeros((1, 8, 8, 3)), t[0], t[0], np.ones((H, W), bool), np.zeros((1, 8, 8, 3)))
    with pytest.raises(RefineError, match="no pixel"):
        Refinement(model, t, t[0], t[0] + 1, np.zeros((H, W), bool), t)
    ref = Refinement(model, t, t[0], t[0] + 1, np.ones((H, W), bool), t)
    with pytest.raises(RefineError, match="expected 2 captures"):
        ref.take(np.zeros((1, H, W, 3)))


def test_cancel_keeps_the_best_image_so_far(rig_and_model):
    rig, model = rig_and_model
    targets, black, white = _targets(rig)
    ref = Refinement(model, targets, black, white, np.ones((H, W), bool), box_compensate(model, targets),
                     RefineSettings(iterations=8))
    calls = []
    rec = run(ref, rig.capture_repeated, cancel=lambda: len(calls) >= 2 or calls.append(1) and False)
    assert rec.stopped == "cancelled" and len(rec.history) == 2
    assert rec.refined_psnr == max(rec.history) and math.isfinite(rec.noise_floor_psnr)


def test_native_mode_refines_the_native_images_and_keeps_their_detail(rig_and_model):
    """The native image (twice the size, with detail of its own) is what is projected: the rig sees it
    averaged onto the working frame; the loop corrects it there and resamples each step onto it."""
    rig, model = rig_and_model
    targets, black, white = _targets(rig)
    start = box_compensate(model, targets) * 0.8 ** (1 / GP)  # a weak open loop
    fine = np.random.default_rng(3).normal(0, 0.02, (len(targets), 2 * H, 2 * W, 3))
    native = np.clip(np.repeat(np.repeat(start, 2, 1), 2, 2) + fine, 0, 1).astype(np.float32)

    def capture(images, repeats):  # the rig's view of a native image: its light averaged per working pixel
        light = np.power(np.asarray(images, np.float64), GP)
        working = light.reshape(len(images), H, 2, W, 2, 3).mean(axis=(2, 4)) ** (1 / GP)
        return rig.capture_repeated(working, repeats)

    ref = Refinement(model, targets, black, white, np.ones((H, W), bool), None, RefineSettings(iterations=5),
                     native_start=native)
    rec = run(ref, capture)
    assert ref.images.shape == native.shape and ref.working_images.shape == targets.shape
    assert rec.refined_psnr > rec.open_loop_psnr + 4, rec.to_dict()
    detail = lambda im: im - np.repeat(np.repeat(im.reshape(len(im), H, 2, W, 2, 3).mean(axis=(2, 4)), 2, 1), 2, 2)  # noqa: E731
    kept = np.corrcoef(detail(ref.images).ravel(), detail(native).ravel())[0, 1]
    assert kept > 0.9  # the native detail is still there
    with pytest.raises(RefineError, match="native images"):
        Refinement(model, targets, black, white, np.ones((H, W), bool), None, native_start=native[:1])

# SPDX-License-Identifier: GPL-3.0-or-later
"""Closed-loop refinement of several projectors together (issue 36): a model fitted on a perturbed rig,
refined on the true one through FakeRigDevice."""
import cv2
import numpy as np
import pytest

from lapig.tools.fakes import fake_rig
from lapig.lapig_core.multi.joint_model import JointModel
from lapig.lapig_core.multi.joint_solve import joint_compensate, reach
from lapig.lapig_core.refine.joint import JointRefinement, device_capture, refine_gain_db_multi, run
from lapig.lapig_core.refine.check import RegistrationCheckError
from lapig.lapig_core.refine.loop import RefineError, RefineSettings


def _fit(rig) -> JointModel:
    shown = [fake_rig.smooth_frames(p.size, 16, seed=10 + k) for k, p in enumerate(rig.projectors)]
    captures, black = rig.capture_alone(shown)
    return JointModel.fit([rig.camera_map(k) for k in range(rig.count)], shown, captures, black)


def perturbed(make=fake_rig.side_by_side_rig):
    """(the true rig, a joint model fitted on the rig as it was not: other gains and gammas)."""
    true, wrong = make(noise=0.002), make(noise=0.002)
    for p, gain, gamma in zip(wrong.projectors, (1.2, 0.85, 1.1), (0.2, -0.15, 0.1)):
        p.gain *= gain
        p.gamma += gamma
    return true, _fit(wrong)


def look(model, seed=5) -> np.ndarray:
    """A smooth colour target within the model's joint reach (10..90 % of it)."""
    h, w = model.shape
    pattern = cv2.resize(np.random.default_rng(seed).random((6, 8, 3)).astype(np.float32), (w, h),
                         interpolation=cv2.INTER_CUBIC).clip(0, 1)
    lo, hi = reach(model)
    return (lo + (hi - lo) * (0.1 + 0.8 * pattern)).astype(np.float32)


@pytest.mark.parametrize("make", [fake_rig.side_by_side_rig, fake_rig.three_projector_rig])
def test_refinement_of_all_projectors_corrects_a_wrong_model(make):
    true, model = perturbed(make)
    device = fake_rig.FakeRigDevice(true)
    record, refinement = refine_gain_db_multi(model, device, look(model), true.object_mask)
    gain = record.refined_psnr - record.open_loop_psnr
    assert gain > 6.0, record.to_dict()
    assert record.refined_psnr > record.noise_floor_psnr - 5.0, record.to_dict()  # near what the camera can tell
    assert device.captured == record.captures  # one capture per round: every projector shows at once
    assert record.history[0] == record.open_loop_psnr and max(record.history) == record.refined_psnr
    # the kept images are what the rig shows best: captured again they are near the refined figure
    from lapig.lapig_core.common.psnr import masked_psnr

    again = true.capture(refinement.images).astype(np.float32) / 255
    assert masked_psnr(again, refinement.target, refinement.valid) > record.refined_psnr - 1.0
    assert [im.shape for im in refinement.images] == [(p.size[1], p.size[0], 3) for p in true.projectors]


def test_an_exact_model_stops_on_the_gain_rule_and_is_not_made_worse():
    rig = fake_rig.side_by_side_rig(noise=0.002)
    model = _fit(rig)
    record, _ = refine_gain_db_multi(model, fake_rig.FakeRigDevice(rig), look(model), rig.object_mask,
                                     RefineSettings(iterations=20))
    assert record.stopped == "gain below 0.05 dB" and record.iterations < 20
    assert record.refined_psnr >= record.open_loop_psnr


def test_a_bumped_camera_is_refused_on_the_first_capture():
    texture = cv2.GaussianBlur(np.random.default_rng(3).random((48, 64, 3)).astype(np.float32), (0, 0), 1.0)
    rig = fake_rig.side_by_side_rig(noise=0.002, albedo=0.3 + 0.65 * (texture - texture.min()) / np.ptp(texture))
    model = _fit(rig)
    refinement = JointRefinement(model, look(model), rig.object_mask, joint_compensate(model, look(model)).frames)
    capture = device_capture(fake_rig.FakeRigDevice(rig))
    with pytest.raises(RegistrationCheckError, match="moved"):
        run(refinement, lambda images, repeats: np.roll(capture(images, repeats), 2, axis=2))


def test_wrong_inputs_are_one_line_each():
    rig, model = perturbed()
    start = joint_compensate(model, look(model)).frames
    with pytest.raises(RefineError, match="one start image per projector"):
        JointRefinement(model, look(model), rig.object_mask, start[:1])
    with pytest.raises(RefineError, match="generate again"):
        JointRefinement(model, look(model)[:10], rig.object_mask, start)
    with pytest.raises(RefineError, match="nothing to refine"):
        JointRefinement(model, look(model), np.zeros(model.shape, bool), start)


def test_a_sharp_look_on_a_dark_stack_is_refined_and_the_back_projection_helps():
    """Blocks with hard edges on two stacked projectors: each step's change, resampled into the projector frames,
    is blurred; the back-projection corrects it and the refinement ends nearer the look."""
    true, model = perturbed(lambda noise: fake_rig.stacked_rig(2, (64, 48), (160, 120), noise=noise))
    lo, hi = reach(model)
    blocks = cv2.resize(np.random.default_rng(7).random((12, 16, 3)).astype(np.float32), (64, 48),
                        interpolation=cv2.INTER_NEAREST)
    target = lo + (hi - lo) * (0.1 + 0.8 * blocks)
    start = joint_compensate(model, target).frames
    refined = {}
    for back in (0, 3):
        refinement = JointRefinement(model, target, true.object_mask, start, back_projection=back)
        refined[back] = run(refinement, device_capture(fake_rig.FakeRigDevice(true)))
    assert refined[3].refined_psnr - refined[3].open_loop_psnr > 8.0, refined[3].to_dict()
    assert refined[3].refined_psnr > refined[0].refined_psnr + 0.4, (refined[0].to_dict(), refined[3].to_dict())

# SPDX-License-Identifier: GPL-3.0-or-later
"""PSA on the joint reach of several projectors (issue 36): the virtual projector's differentiable modules, PSA
through stylize_joint on a dark stacked rig, and a stack of two against one."""
import numpy as np
import pytest

from lapig.lapig_core.common.psnr import masked_psnr
from lapig.tools.fakes import fake_rig
from lapig.lapig_core.multi.joint_solve import reach

pytestmark = pytest.mark.torch

PROMPT = "Make it a stained glass artwork"


def _white(rig):
    return rig.capture([np.ones(p.size[::-1] + (3,), np.float32) for p in rig.projectors]).astype(np.float32) / 255


@pytest.fixture(scope="module")
def dark_stack():
    """Two projectors stacked on a dark textured object (projectors finer than the camera, as a real rig's are)."""
    rig = fake_rig.stacked_rig(2, camera_size=(64, 48), projector_size=(160, 120))
    return rig, rig.subset([0])


@pytest.fixture(scope="module")
def stacked_against_one(dark_stack):
    """(figures, looks) of the default PSA on the dark stack of two and on its first projector alone."""
    from lapig.tools.bench.stack_gain import stack_psa_gain

    rig, one = dark_stack
    looks = {}
    figures = stack_psa_gain(rig.true_model(), one.true_model(), _white(rig), PROMPT, working_size=64,
                             object_mask=rig.object_mask, single_surface=_white(one), looks=looks)
    return figures, looks


def test_the_virtual_projector_has_the_joint_reach_and_inverts_itself(dark_stack):
    import torch

    from lapig.lapig_core.multi.joint_psa import joint_surface_models

    rig, _ = dark_stack
    model = rig.true_model()
    models = joint_surface_models(model)
    lo, hi = reach(model)
    as_image = lambda t: t[0].permute(1, 2, 0).numpy()  # noqa: E731
    np.testing.assert_allclose(as_image(models.i_min), lo, atol=1e-6)
    np.testing.assert_allclose(as_image(models.i_max), hi, atol=1e-6)
    on = models.on_object[0, 0].numpy() > 0.5
    assert on.sum() == model.reached.any(axis=0).sum()
    # a target inside the reach: compensated and simulated, it comes back; the raw drive stays in [0, 1]
    target = torch.from_numpy(np.ascontiguousarray((0.3 * lo + 0.7 * hi).transpose(2, 0, 1)))[None]
    comp, raw = models.compensate(target, return_raw=True)
    back = models.simulate(comp)
    assert np.abs(as_image(back - target))[on].max() < 2e-3
    assert as_image(raw)[on].min() >= 0 and as_image(raw)[on].max() <= 1
    # a target above the reach saturates the drive (L_cs sees it) and is clamped by the simulator
    bright = torch.minimum(torch.from_numpy(np.ascontiguousarray(hi.transpose(2, 0, 1)))[None] + 0.1,
                           torch.tensor(1.0))
    _, raw = models.compensate(bright, return_raw=True)
    assert as_image(raw)[on].max() > 1.0
    # differentiable: PSA's losses reach the target
    target = target.clone().requires_grad_(True)
    from lapig.lapig_core.psa.adaptation import psa_losses

    parts = psa_losses(target * 1.5, models)
    (parts["pc"] + parts["cs"] + parts["ps"]).backward()
    assert target.grad is not None and float(target.grad.abs().sum()) > 0


def test_psa_on_the_joint_reach_beats_the_look_as_it_is_and_keeps_it(dark_stack, stacked_against_one):
    """stylize_joint with PSA (the default), as stack_psa_gain ran it on the stack."""
    from lapig.lapig_core.multi.joint_psa import simulated_psnr

    rig, _ = dark_stack
    model = rig.true_model()
    surface = _white(rig)
    look = stacked_against_one[1]["stacked"]
    assert look.without is not None and look.psa["warm_start_steps"] > 0
    assert len(look.frames) == len(look.without.frames) == 2 and look.frames[0].shape == (120, 160, 3)
    mask = rig.object_mask & model.reached.any(axis=0)
    with_psa, without = simulated_psnr(model, look, mask), simulated_psnr(model, look.without, mask)
    assert with_psa > without + 5.0, (with_psa, without)
    assert look.reach_share > look.without.reach_share + 0.15
    # the rig itself shows what the model predicts: the gain is real, not the model's
    shown = rig.capture(look.frames).astype(np.float32) / 255
    assert masked_psnr(shown, look.target, mask) > with_psa - 1.0
    off = ~model.reached.any(axis=0)
    # nothing can change what no projector reaches: there the target keeps the surface, PSA or not
    np.testing.assert_array_equal(look.target[off], look.without.target[off])
    assert np.abs(look.target[off] - surface[off]).max() <= 3 / 255  # (the white capture is a new noise draw)


def test_a_stack_of_two_shows_more_of_the_look_than_one(stacked_against_one):
    d = stacked_against_one[0].to_dict()
    # without PSA the stack's wider reach shows the look better; after PSA it keeps more of the asked look
    assert d["stacked_nopsa_psnr"] > d["single_nopsa_psnr"] + 1.5, d
    assert d["stack_look_gain_db"] > 1.0, d
    assert d["psa_gain_db_stacked"] > 3.0 and d["psa_gain_db_single"] > 3.0, d
    # each rig's PSA look is shown about as well as the other's (PSA adapts each to its own reach)
    assert d["stack_psa_gain_db"] > -1.0, d


def test_when_the_look_is_kept_the_stack_shows_it_better_than_one(dark_stack):
    """adaptation 0 (keep my look): PSA leaves each look nearer the prompt's, and the stack's wider reach shows it
    better; at the default 0.5 each rig's PSA adapts the look to its own reach (about equal PSNRs, above)."""
    from lapig.tools.bench.stack_gain import stack_psa_gain
    from lapig.lapig_core.psa.adaptation import PSASettings

    rig, one = dark_stack
    figures = stack_psa_gain(rig.true_model(), one.true_model(), _white(rig), PROMPT, working_size=64,
                             object_mask=rig.object_mask, single_surface=_white(one),
                             settings=PSASettings(adaptation=0.0))
    assert figures.stack_psa_gain_db > 1.5, figures.to_dict()

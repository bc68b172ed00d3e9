# SPDX-License-Identifier: GPL-3.0-or-later
"""The motion presets: the look itself at t = 0, periodic, smooth, differentiable."""
import pytest

torch = pytest.importorskip("torch")  # the producer is torch's: the torch-free tier skips this file

from lapig.lapig_core.show.model import Motion
from lapig.lapig_core.show.motion import PRESETS, apply_motion


def _image():
    torch.manual_seed(0)
    y = torch.linspace(0, 1, 48)[None, None, :, None]
    x = torch.linspace(0, 1, 64)[None, None, None, :]
    return (0.2 + 0.6 * torch.rand(1, 3, 1, 1) * (0.5 + 0.5 * torch.sin(12 * x + 5 * y))).clamp(0, 1)


@pytest.mark.parametrize("preset", sorted(PRESETS))
def test_preset_is_the_look_at_rest_periodic_and_smooth(preset):
    image = _image()
    motion = Motion(preset, amount=1.0, period_s=2.0)
    assert torch.allclose(apply_motion(image, motion, 0.0), image, atol=2e-3)
    quarter = apply_motion(image, motion, 0.5)
    assert (quarter - image).abs().mean() > 5e-3  # it moves
    assert torch.allclose(apply_motion(image, motion, 2.0), apply_motion(image, motion, 0.0), atol=1e-5)
    assert torch.allclose(apply_motion(image, motion, 2.7), apply_motion(image, motion, 0.7), atol=1e-5)
    # smooth: 1/60 of the period moves far less than a quarter of it
    step = (apply_motion(image, motion, 0.5 + 2 / 60) - quarter).abs().mean()
    assert step < 0.25 * (quarter - image).abs().mean()


@pytest.mark.parametrize("preset", sorted(PRESETS))
def test_preset_is_differentiable(preset):
    image = _image().requires_grad_(True)
    apply_motion(image, Motion(preset, 0.7, 3.0), 0.8).mean().backward()
    assert image.grad is not None and torch.isfinite(image.grad).all() and image.grad.abs().sum() > 0


def test_pulse_and_rise_never_brighten_and_colour_cycle_keeps_greys():
    image = _image()
    for t in (0.3, 1.0, 1.7):
        for preset in ("pulse", "rise"):
            assert (apply_motion(image, Motion(preset, 1.0, 2.0), t) <= image + 1e-5).all()
    grey = torch.full((1, 3, 8, 8), 0.4)
    assert torch.allclose(apply_motion(grey, Motion("colour_cycle", 1.0, 2.0), 0.5), grey, atol=1e-4)

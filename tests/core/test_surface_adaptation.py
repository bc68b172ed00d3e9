# SPDX-License-Identifier: GPL-3.0-or-later
"""Issue 13 at 32-64 px: structure retention (style at any brightness), the tone field, reachability
and the clamp bound, and PSA's adaptation setting."""
import math

import numpy as np
import pytest

torch = pytest.importorskip("torch")

from lapig.lapig_core.common import metrics
from lapig.lapig_core.common.surfaces import make_surface
from lapig.lapig_core.lgst.base import LGSTBackend
from lapig.lapig_core.photometric.checkpoints import new_model
from lapig.lapig_core.photometric.surface_models import SurfaceModels
from lapig.lapig_core.psa import adaptation as psa
from lapig.lapig_core.psa import reach
from lapig.lapig_core.psa.tone_field import AdaptedLook, ToneField

pytestmark = pytest.mark.torch
SIZE = 48


def _image(name="wood", seed=1):
    img = make_surface(name, size=SIZE, seed=seed)
    return torch.from_numpy(np.asarray(img, np.float32)).permute(2, 0, 1)[None].double()


def test_darkened_look_keeps_structure_while_ssim_drops():
    x = _image()
    dark = x * 0.3
    assert metrics.ssim(dark, x) < 0.5
    assert metrics.structure_retention(dark, x) > 0.95
    tinted = x * torch.tensor([1.0, 0.6, 0.4], dtype=x.dtype).view(1, 3, 1, 1)
    assert metrics.structure_retention(tinted, x) > 0.85


@pytest.mark.parametrize("spoil", ["scramble", "flat", "dark scramble"])
def test_a_spoilt_look_loses_structure(spoil):
    x = _image("wood")
    idx = torch.randperm(SIZE * SIZE, generator=torch.Generator().manual_seed(0))
    scrambled = x.flatten(2)[:, :, idx].view_as(x)
    y = {"scramble": scrambled, "flat": x.mean((2, 3), keepdim=True).expand_as(x).clone(),
         "dark scramble": scrambled * 0.2}[spoil]
    assert metrics.structure_retention(y, x) < 0.3


def test_structure_retention_is_differentiable_and_one_for_itself():
    x = _image().float()
    y = (x * 0.5).requires_grad_(True)
    value = metrics.structure_retention_torch(y, x)
    value.backward()
    assert y.grad is not None and torch.isfinite(y.grad).all()
    assert metrics.structure_retention(x, x) == pytest.approx(1.0, abs=1e-6)
    with pytest.raises(ValueError, match="RGB"):
        metrics.structure_retention(x[:, :1], x[:, :1])


def test_tone_field_starts_at_identity_and_follows_the_surface_range():
    i_max = _image("black_dots").float()
    i_min = torch.full_like(i_max, 0.02)
    field = ToneField(i_min, i_max, grid=4)
    look = torch.full_like(i_max, 0.6)
    assert all(float(p.detach().abs().max()) == 0.0 for p in field.parameters())  # every parameter 0
    assert torch.allclose(field.apply(look), look)
    with torch.no_grad():
        field.beta.fill_(0.5)  # follow the range: dark where the surface is dark
    out = field.apply(look)
    dark = (i_max - i_min).mean(1) < 0.1
    assert out[0, :, dark[0]].mean() < 0.3 < out[0, :, ~dark[0]].mean()
    # low-resolution gain at another size: bicubically smooth, same mean tone
    with torch.no_grad():
        field.beta.zero_()
        field.gain.fill_(math.log(0.5))
    assert float(field.apply(look).mean()) == pytest.approx(0.3, abs=1e-4)
    big = torch.full((1, 3, 96, 96), 0.6)
    assert float(field.apply(big).mean()) == pytest.approx(0.3, abs=1e-4)


def test_tone_field_is_optimised_by_gradient():
    i_max = torch.full((1, 3, 32, 32), 0.3)
    field = ToneField(torch.zeros_like(i_max), i_max, grid=3)
    look = torch.full_like(i_max, 0.8)
    opt = torch.optim.Adam(field.parameters(), lr=0.1)
    for _ in range(30):  # pull a bright look into a dark surface's range
        loss = ((field.apply(look) - i_max) ** 2).mean()
        opt.zero_grad()
        loss.backward()
        opt.step()
    assert float(((field.apply(look) - i_max) ** 2).mean()) < 0.01
    assert field.summary()["mean_gain_rgb"][0] < 0.8


def test_reachability_and_clamp_bound():
    i_min, i_max = torch.full((1, 3, 8, 8), 0.1), torch.full((1, 3, 8, 8), 0.5)
    inside = torch.full_like(i_min, 0.3)
    assert reach.reachability(inside, i_min, i_max) == 1.0
    assert reach.clamp_bound_psnr(inside, i_min, i_max) == math.inf
    half = inside.clone()
    half[..., :4, :] = 0.9  # half the pixels 0.4 above I+
    assert reach.reachability(half, i_min, i_max) == 0.5
    assert reach.clamp_bound_psnr(half, i_min, i_max) == pytest.approx(10 * math.log10(1 / (0.5 * 0.16)), abs=1e-6)
    mask = np.zeros((8, 8), bool)
    mask[4:] = True  # on the object: only the reachable half
    assert reach.reachability(half, i_min, i_max, mask) == 1.0
    # numpy channel-last images too
    assert reach.reachability(half[0].permute(1, 2, 0).numpy(), i_min[0].permute(1, 2, 0).numpy(),
                              i_max[0].permute(1, 2, 0).numpy()) == 0.5


def test_surface_truth_says_when_a_look_is_out_of_reach():
    i_min, i_max = torch.full((1, 3, 8, 8), 0.01), torch.full((1, 3, 8, 8), 0.08)
    bright, darker = torch.full_like(i_min, 0.7), torch.full_like(i_min, 0.06)
    truth = reach.surface_truth(bright, darker, i_min, i_max)
    assert truth["before_psa"]["reachability"] == 0.0 and truth["after_psa"]["reachability"] == 1.0
    assert "too dark for a bright look" in truth["message"] and "darker" in truth["message"]
    assert "100% after adaptation" in truth["message"]
    assert reach.surface_truth(darker, darker, i_min, i_max)["message"] == ""
    assert "turn on surface adaptation" in reach.surface_truth(bright, None, i_min, i_max)["message"]


class BrightBackend(LGSTBackend):
    """A bright textured look with a learnable gain (its theta)."""

    name = "bright-test"

    def prepare(self, surface, prompt, seed=0, mix=None):
        self.surface, self.prompt = surface, prompt
        self.look = torch.rand(1, 3, 32, 32, generator=torch.Generator().manual_seed(seed + 1)) * 0.5 + 0.3
        self.gain = torch.ones(1, 3, 1, 1, requires_grad=True)

    def parameters(self):
        return [self.gain]

    def forward(self):
        return (self.look * self.gain).clamp(0, 1)

    def describe(self):
        return {"backend": self.name, "prompt": self.prompt, "styles": []}


def _models():
    torch.manual_seed(0)
    s = torch.rand(1, 3, 32, 32) * 0.1 + 0.02  # a dark surface
    return SurfaceModels(new_model("CompenNeSt", 1), new_model("PCNet", 2), s, s * 0.2, s * 1.5)


def _bright_backend(models):
    b = BrightBackend()
    b.prepare(models.s, "bright")
    return b


def test_adaptation_settings_map_the_artist_control():
    keep, default, free = (psa.PSASettings(adaptation=a) for a in (0.0, 0.5, 1.0))
    assert keep.style_mix()[:2] == (1.0, 0.0) and default.style_mix()[:2] == (0.0, 1.0)
    assert keep.style_mix()[2] > default.style_mix()[2] > free.style_mix()[2] > 0  # never free of style
    assert keep.stop_ratio > default.stop_ratio > free.stop_ratio
    assert psa.PSASettings(adaptation=0.5, stop_ratio=0.9).stop_ratio == 0.9
    with pytest.raises(ValueError, match="adaptation"):
        psa.PSASettings(adaptation=2.0)


def test_psa_with_the_field_darkens_a_bright_look_on_a_dark_surface():
    models = _models()
    settings = psa.PSASettings(max_iterations=20, stop_ratio=0.0, lr=0.0)  # only the field may move
    result = psa.run_psa(_bright_backend(models), models, settings)
    assert isinstance(result.look, AdaptedLook) and "tone_field" in result.state
    before = reach.reachability(result.initial_target, models.i_min, models.i_max)
    after = reach.reachability(result.target, models.i_min, models.i_max)
    assert float(result.target.mean()) < float(result.initial_target.mean())
    assert after > before
    # the best state renders the same look again, and at another size
    look = result.look
    look.load_state(result.state)
    with torch.no_grad():
        assert torch.allclose(look.forward(), result.target, atol=1e-6)
    no_field = psa.run_psa(_bright_backend(models), models, psa.PSASettings(max_iterations=3, tone_field=False))
    assert not isinstance(no_field.look, AdaptedLook)


def test_warm_start_darkens_where_the_surface_is_dark_keeps_strokes_and_hue():
    """The field-only warm start (no network) makes the large move on its own: the look falls into
    the surface's reach, its pattern and its colour ratios stay, and light the surface can show is
    not given up."""
    torch.manual_seed(0)
    s = torch.full((1, 3, 32, 32), 0.03)
    s[..., :, 16:] = 0.6  # the right half can show a bright look, the left half cannot
    models = SurfaceModels(new_model("CompenNeSt", 1), new_model("PCNet", 2), s, s * 0.1, s)
    look = psa.adapted_look(_bright_backend(models), models)
    with torch.no_grad():
        anchor = look.forward()
    settings = psa.PSASettings()
    before = float(psa.proxy_psa_loss(anchor, models, settings))
    steps = psa.warm_start_field(look, anchor, models, settings)
    with torch.no_grad():
        adapted = look.forward()
    assert steps == settings.warm_start_steps
    assert float(psa.proxy_psa_loss(adapted, models, settings)) < 0.2 * before
    left, right = adapted[..., :16].mean(), adapted[..., 16:].mean()
    assert float(left) < 0.5 * float(anchor[..., :16].mean())  # dark where the surface is dark
    assert float(right) > 2 * float(left)  # and not where it can show the light
    assert metrics.structure_retention(adapted, anchor) > 0.7
    ratio = lambda x: x.mean(dim=(0, 2, 3)) / x.mean()  # noqa: E731  (hue: the channels' ratios)
    assert torch.allclose(ratio(adapted), ratio(anchor), atol=0.1)


def test_structure_retention_counts_a_look_darkened_to_nothing_as_lost():
    x = _image("wood")
    assert metrics.structure_retention(x * 1e-4, x) < 0.3  # invisible strokes are not kept strokes
    assert metrics.structure_retention(x * 0.3, x) > 0.95

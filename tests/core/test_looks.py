"""The look library (lapig_core.lgst.looks): every look in [0,1], differentiable in its parameters and
its input, the same in the picture at two resolutions; palettes and moods do what they say."""
import pytest

torch = pytest.importorskip("torch")

from lapig_core.lgst.looks import BY_NAME, LOOKS, MEDIA, palette_stage  # noqa: E402
from lapig_core.lgst.looks.ops import luminance  # noqa: E402

pytestmark = pytest.mark.torch


def _scene(size=48, seed=0):
    g = torch.Generator().manual_seed(seed)
    y, x = torch.meshgrid(torch.linspace(0, 1, size), torch.linspace(0, 1, size), indexing="ij")
    img = torch.stack([x, y, 1 - x * y]) * 0.6 + 0.2
    img[:, size // 4: size // 2, size // 4: size // 2] = torch.tensor([0.9, 0.2, 0.1]).view(3, 1, 1)  # a shape
    return (img + 0.05 * torch.rand(3, size, size, generator=g)).clamp(0, 1)[None]


@pytest.mark.parametrize("look", LOOKS, ids=[look.name for look in LOOKS])
def test_every_look_is_in_range_and_differentiable(look):
    stage = look.make([(0.1, 0.2, 0.7), (1.0, 0.84, 0.0)] if look.uses_colours else None)
    x = _scene(40).requires_grad_(True)
    for key in stage.params:
        stage.params[key] = stage.params[key].clone().requires_grad_(True)
    y = stage(x, x.detach())
    assert y.shape == x.shape and float(y.min()) >= 0.0 and float(y.max()) <= 1.0
    assert torch.isfinite(y).all()
    ((y - 0.3) ** 2).mean().backward()
    moved = [k for k, p in stage.params.items() if p.grad is not None and float(p.grad.abs().sum()) > 0]
    assert moved, f"{look.name}: no parameter gets a gradient"
    assert x.grad is not None and float(x.grad.abs().sum()) > 0  # PSA's gradient reaches the medium under it
    assert look.description.endswith(".") and look.tags


def test_looks_change_the_image_and_are_the_same_at_two_resolutions():
    small, big = _scene(48), torch.nn.functional.interpolate(_scene(48), size=(96, 96), mode="bilinear")
    for look in MEDIA:
        with torch.no_grad():
            a = look.make(None)(small, small)
            b = look.make(None)(big, big)
        assert float((a - small).abs().mean()) > 0.01, look.name
        pooled = torch.nn.functional.adaptive_avg_pool2d
        assert float((pooled(a, 8) - pooled(b, 8)).abs().mean()) < 0.08, look.name


def test_named_palette_puts_the_colours_in_the_image():
    x = _scene(48)
    blue, gold = (0.0, 0.0, 0.7), (1.0, 0.84, 0.0)
    with torch.no_grad():
        y = palette_stage([gold, blue])(x, x)
    pix = y.flatten(2)[0].t()
    for c in (blue, gold):
        d = (pix - torch.tensor(c)).norm(dim=1)
        assert float((d < 0.2).float().mean()) > 0.05  # a good share of pixels is that colour


def test_moods_move_the_lightness_their_way():
    x = _scene(48)
    lum = float(luminance(x).mean())
    with torch.no_grad():
        for name, sign in (("night", -1), ("dark_moody", -1), ("bright_sunny", 1), ("dusk", -1)):
            y = BY_NAME[name].make(None)(x, x)
            assert sign * (float(luminance(y).mean()) - lum) > 0.03, name
        night = BY_NAME["night"].make(None)(x, x)
        assert float(night[:, 2].mean()) > float(night[:, 0].mean())  # moonlight is blue

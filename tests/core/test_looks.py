"""The look library (lapig_core.lgst.looks): every look in [0,1], differentiable in its parameters and
its input, the same in the picture at two resolutions; palettes and moods do what they say."""
import pytest

torch = pytest.importorskip("torch")

from lapig.lapig_core.lgst.looks import BY_NAME, LOOKS, MEDIA, palette_stage  # noqa: E402
from lapig.lapig_core.lgst.looks.ops import luminance  # noqa: E402

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


# -- the named looks of the art lexicon (issue 30) -------------------------------------------------------
def _hue_share(y, lo, hi, chroma=0.3):
    """Share of pixels with an HSV hue in [lo, hi] degrees and at least this chroma."""
    img = y[0].permute(1, 2, 0)
    mx, mn = img.max(-1).values, img.min(-1).values
    c = mx - mn
    r, g, b = img.unbind(-1)
    safe = torch.where(c > 1e-6, c, torch.ones_like(c))
    h = torch.where(mx == r, ((g - b) / safe) % 6, torch.where(mx == g, (b - r) / safe + 2, (r - g) / safe + 4)) * 60
    inside = (h >= lo) & (h <= hi) if lo <= hi else (h >= lo) | (h <= hi)
    return float((inside & (c >= chroma)).float().mean())


NAMED = ("broken_strokes", "pointillist_dots", "colour_fields", "primary_grid", "gold_leaf", "chiaroscuro",
         "stained_glass", "cubist_facets", "poured_lines", "wavy_bands", "miniature", "storybook", "paper_cutouts",
         "ben_day", "pixel_art", "glazed_tiles", "blueprint", "wax_resist", "woven_threads", "deco_sunburst",
         "floating_shapes", "circles_and_lines")


@pytest.mark.parametrize("name", NAMED)
def test_named_looks_take_a_palette_that_psa_moves(name):
    look = BY_NAME[name]
    assert look.uses_colours and look.role == "medium"
    named = [(0.8, 0.1, 0.1), (0.1, 0.2, 0.7), (0.95, 0.9, 0.8)]
    stage = look.make(named)
    x = _scene(48)
    stage.params["colours"] = stage.params["colours"].clone().requires_grad_(True)
    y = stage(x, x)
    ((y - 0.3) ** 2).mean().backward()
    assert float(stage.params["colours"].grad.abs().sum()) > 0  # the palette is theta
    with torch.no_grad():
        plain = look.make(None)(x, x)
    assert float((y.detach() - plain).abs().mean()) > 0.01  # the named colours change the look


def test_primary_grid_is_black_lines_and_blocks_of_primaries():
    x = _scene(96)
    with torch.no_grad():
        y = BY_NAME["primary_grid"].make(None)(x, x)
    dark = float((luminance(y) < 0.15).float().mean())
    primaries = _hue_share(y, 345, 15, 0.5) + _hue_share(y, 40, 65, 0.5) + _hue_share(y, 205, 250, 0.5)
    assert 0.03 < dark < 0.3 and primaries > 0.25
    light = float((luminance(y) > 0.85).float().mean())
    assert light > 0.2  # a white ground


def test_gold_leaf_gilds_and_rothko_fields_hover():
    x = _scene(96)
    with torch.no_grad():
        gold = BY_NAME["gold_leaf"].make(None)(x, x)
        fields = BY_NAME["colour_fields"].make(None)(x, x)
    assert _hue_share(gold, 35, 65, 0.25) > 0.25
    assert _hue_share(fields, 340, 40, 0.3) > 0.7  # maroon, crimson, orange everywhere
    top, bottom = fields[..., 20:40, 30:60].mean((2, 3)), fields[..., 60:80, 30:60].mean((2, 3))
    assert float((top - bottom).abs().sum()) > 0.15  # two different fields


def test_pointillist_dots_are_pure_colours_on_a_light_ground():
    x = _scene(128)
    with torch.no_grad():
        y = BY_NAME["pointillist_dots"].make(None)(x, x)
    families = sum(_hue_share(y, (k * 60 - 30) % 360, (k * 60 + 30) % 360, 0.3) > 0.03 for k in range(6))
    assert families >= 3
    # dots: neighbouring pixels differ much more than in the scene itself
    assert float((y[..., 1:] - y[..., :-1]).abs().mean()) > 2 * float((x[..., 1:] - x[..., :-1]).abs().mean())


def test_a_miniature_has_fine_outlines_and_a_painted_border():
    x = _scene(96)
    stage = BY_NAME["miniature"].make(None)
    with torch.no_grad():
        y = stage(x, x)
        plain = stage.params["border"].fill_(0.0)
        unframed = stage(x, x)
    edge = y[..., :3, :].mean((2, 3))[0]
    assert float((edge - stage.params["frame"]).abs().max()) < 0.25  # the frame colour along the edge
    assert float((unframed[..., :3, :] - y[..., :3, :]).abs().mean()) > 0.05 and float(plain) == 0.0
    assert float((luminance(y) < 0.2).float().mean()) > 0.004  # fine outlines


def _flat(size=96, value=(0.9, 0.85, 0.8)):
    """A pale flat ground (about 90 % of it) with a few darker round spots, like the sakura texture."""
    img = torch.tensor(value).view(1, 3, 1, 1).expand(1, 3, size, size).clone()
    y, x = torch.meshgrid(torch.arange(size), torch.arange(size), indexing="ij")
    for cy, cx in ((0.2, 0.7), (0.5, 0.3), (0.8, 0.6), (0.35, 0.9)):
        spot = ((y - cy * size) ** 2 + (x - cx * size) ** 2).float().sqrt() < size * 0.07
        img[0, :, spot] = torch.tensor((0.9, 0.5, 0.6)).view(3, 1)
    return img


def test_chiaroscuro_is_a_light_from_one_side_not_a_disc_and_not_black():
    x = _flat()
    with torch.no_grad():
        y = luminance(BY_NAME["chiaroscuro"].make(None)(x, x))[0, 0]
    left, right = float(y[:, :24].mean()), float(y[:, -24:].mean())
    assert left > right + 0.25  # lit from the left, the far side in shadow
    # a raking light reaches the image's edge: its lit edge column is lit from top to well below the middle
    assert float(y[:60, 0].min()) > 0.5 * float(y.max())
    assert float(y.mean()) > 0.12  # the shadow keeps a floor: a projector still has something to show


def test_film_noir_blinds_stripe_the_light():
    x = _flat()
    stage = BY_NAME["chiaroscuro"].make([(0.05, 0.05, 0.05), (0.5, 0.5, 0.5), (1.0, 1.0, 1.0)])
    with torch.no_grad():
        plain = luminance(stage(x, x))[0, 0, :, :40]
        stage.params["blinds"].fill_(0.8)
        striped = luminance(stage(x, x))[0, 0, :, :40]
    # along a column in the light the blinds alternate light and dark: fine ups and downs, not a slope
    def wiggle(cols):
        smooth = torch.nn.functional.avg_pool1d(cols.t()[:, None], 9, 1, 4, count_include_pad=False)[:, 0].t()
        return float((cols - smooth)[8:-8].abs().mean())
    assert wiggle(striped[:60]) > 3 * wiggle(plain[:60]) + 0.02


def test_paper_cutouts_float_shapes_on_white_even_over_a_flat_ground():
    x = _flat(128)
    stage = BY_NAME["paper_cutouts"].make(None)
    with torch.no_grad():
        y = stage(x, x)
        stage.params["scatter"].fill_(0.0)
        fewer = stage(x, x)
    lum = luminance(y)[0, 0]
    white, cut = float((lum > 0.9).float().mean()), float((lum < 0.7).float().mean())
    assert white > 0.3 and cut > 0.1
    assert cut > float((luminance(fewer) < 0.7).float().mean()) + 0.05  # the floating shapes are `scatter`'s
    # large sheets, not speckle: along a row a colour runs on for several pixels
    row = (y[0, :, 64, 1:] - y[0, :, 64, :-1]).abs().sum(0) > 0.2
    assert int(row.sum()) < 30


def test_art_deco_has_gold_rays_dark_between_and_chevrons_along_the_foot():
    x = _flat()
    with torch.no_grad():
        y = BY_NAME["deco_sunburst"].make(None)(x, x)
    assert _hue_share(y, 35, 65, 0.25) > 0.2 and float((luminance(y) < 0.18).float().mean()) > 0.15
    foot = luminance(y)[0, 0, -8:, :]
    assert float(foot.max() - foot.min()) > 0.5  # gold and black stripes
    # rays: along an arc around the sun the colour alternates many times
    row = luminance(y)[0, 0, 20, :]
    assert int(((row[1:] > 0.5) != (row[:-1] > 0.5)).sum()) >= 4


def test_suprematist_shapes_float_on_white():
    x = _scene(96)
    with torch.no_grad():
        y = BY_NAME["floating_shapes"].make(None)(x, x)
    lum = luminance(y)
    assert float((lum > 0.75).float().mean()) > 0.4  # the white ground
    assert float((lum < 0.1).float().mean()) > 0.05  # the black square
    assert _hue_share(y, 345, 15, 0.5) > 0.02  # a red bar


def test_kandinsky_circles_are_rings_of_many_colours_crossed_by_black_lines():
    x = _flat(192)
    with torch.no_grad():
        y = BY_NAME["circles_and_lines"].make(None)(x, x)
    # the rings (about a sixth of the image) hold saturated red, yellow, green, blue and violet
    families = sum(_hue_share(y, (k * 60 - 30) % 360, (k * 60 + 30) % 360, 0.3) > 0.01 for k in range(6))
    assert families >= 4
    assert float((luminance(y) < 0.2).float().mean()) > 0.005  # black lines

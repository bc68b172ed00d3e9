"""Colour words in a prompt -> sRGB colours ("in deep blue and gold", "sepia", "pastel pink", "bleu profond").

Names come from colour_names (CSS/X11 plus painters' names plus a few other languages' basic words),
matched longest first (up to four words, or written as one word as CSS does: "darkslategray"). A modifier
before the name (deep, dark, light, pale, pastel, bright, muted, ...; French and Spanish ones after it)
moves the colour in hue-lightness-saturation. Words that are also media or things (charcoal, ink, sand,
honey, ...) count as colours only with a colour context: a modifier, "colour(s)/tones/hues" after them,
or a colour beside them in a list ("rust and teal"). A word written where a colour belongs ("in zaffre
tones") that is no colour name is reported as unmatched, with the closest names.
"""
from __future__ import annotations

import colorsys
import difflib
import re
from dataclasses import dataclass, field

from .colour_names import ALL_COLOURS, FOREIGN_COLOURS, hex_to_rgb

MAX_WORDS = 4
CONTEXT_AFTER = {"colour", "colours", "color", "colors", "tone", "tones", "hue", "hues", "tint", "tints",
                 "palette", "coloured", "colored", "shades", "shade", "farben", "couleurs", "colores"}
LIST_WORDS = {"and", "&", "with", "plus", "et", "und", "y", "e", "или", "or"}
STOPWORDS = {"a", "an", "the", "in", "of", "and", "with", "it", "its", "into", "as", "to", "make", "some",
             "bold", "warm", "cool", "cold", "rich", "many", "few", "all", "bright", "my", "your", "same",
             "other", "natural", "primary", "secondary", "complementary", "earth", "earthy", "vivid", "these"}
# words that name a medium or a thing as often as a colour: colours only in a colour context
AMBIGUOUS = {"charcoal", "ink", "sky", "sand", "ash", "smoke", "fog", "honey", "wine", "slate", "steel", "jet",
             "bone", "brick", "moss", "pine", "coffee", "cherry", "lemon", "lime", "peach", "sage", "mint",
             "cream", "ivory", "amber", "emerald", "jade", "ruby", "sapphire", "rust", "copper", "bronze",
             "brass", "cobalt", "chocolate", "cinnamon", "caramel", "rose", "olive", "salmon", "tomato", "plum",
             "orchid", "wheat", "linen", "snow", "chestnut", "walnut", "mahogany", "pumpkin", "tangerine",
             "apricot", "avocado", "eggplant", "aubergine", "denim", "petrol", "parchment", "platinum", "pewter",
             "pearl", "champagne", "bubblegum", "canary", "sunflower", "saffron", "seashell", "honeydew",
             "thistle", "tan", "gainsboro", "sepia_ink", "blush", "sienna", "umber",
             "cornflower", "peru", "moccasin", "bisque"}
MEDIUM_WORDS = {"charcoal", "ink", "sepia_ink"}  # "drawn in charcoal" is a medium, never a colour
# words of a colour phrase that also say what the light is ("neon pink lights"): left for the medium too
LIGHT_WORDS = {"neon", "electric", "fluorescent", "glowing"}


def _hls_set(rgb, l=None, s=None, l_scale=None, s_scale=None, l_toward=None):
    h, light, sat = colorsys.rgb_to_hls(*rgb)
    if l_scale is not None:
        light *= l_scale
    if l_toward is not None:
        target, amount = l_toward
        light += (target - light) * amount
    if s_scale is not None:
        sat *= s_scale
    if l is not None:
        light = l(light) if callable(l) else l
    if s is not None:
        sat = s(sat) if callable(s) else s
    return colorsys.hls_to_rgb(h, min(max(light, 0.0), 1.0), min(max(sat, 0.0), 1.0))


MODIFIERS = {
    "dark": lambda c: _hls_set(c, l_scale=0.55),
    "deep": lambda c: _hls_set(c, l_scale=0.7, s=lambda s: min(1.0, s * 1.2 + 0.1)),
    "rich": lambda c: _hls_set(c, l_scale=0.85, s=lambda s: min(1.0, s * 1.15)),
    "light": lambda c: _hls_set(c, l_toward=(1.0, 0.45)),
    "pale": lambda c: _hls_set(c, l_toward=(1.0, 0.6), s_scale=0.6),
    "pastel": lambda c: _hls_set(c, l=lambda l: max(l, 0.8), s=lambda s: min(s, 0.65)),
    "bright": lambda c: _hls_set(c, l=lambda l: min(max(l, 0.45), 0.65), s=1.0),
    "vivid": lambda c: _hls_set(c, l=lambda l: min(max(l, 0.4), 0.6), s=1.0),
    "neon": lambda c: _hls_set(c, l=lambda l: min(max(l, 0.5), 0.62), s=1.0),
    "muted": lambda c: _hls_set(c, s_scale=0.45, l_toward=(0.55, 0.3)),
    "dusty": lambda c: _hls_set(c, s_scale=0.4, l_toward=(0.6, 0.3)),
    "soft": lambda c: _hls_set(c, s_scale=0.7, l_toward=(0.8, 0.3)),
}
MODIFIER_WORDS = {  # other languages' modifiers -> the English one; French/Spanish/Italian put them after
    "profond": "deep", "profonde": "deep", "foncé": "dark", "foncée": "dark", "clair": "light", "claire": "light",
    "pâle": "pale", "vif": "vivid", "vive": "vivid", "tief": "deep", "dunkel": "dark", "dunkles": "dark",
    "dunkle": "dark", "dunkler": "dark", "hell": "light", "helles": "light", "blass": "pale",
    "oscuro": "dark", "oscura": "dark", "claro": "light", "clara": "light", "profundo": "deep",
    "intenso": "deep", "pálido": "pale", "scuro": "dark", "chiaro": "light", "intenso_it": "deep",
    "escuro": "dark", "濃い": "deep", "淡い": "pale",
}


@dataclass(frozen=True)
class NamedColour:
    name: str                      # as understood: "deep blue"
    rgb: tuple[float, float, float]
    words: str                     # as written in the prompt

    def to_dict(self) -> dict:
        return {"name": self.name, "rgb": [round(v, 3) for v in self.rgb], "written": self.words,
                "hex": "#" + "".join(f"{round(v * 255):02x}" for v in self.rgb)}


@dataclass
class ColourParse:
    colours: list[NamedColour] = field(default_factory=list)
    unmatched: list[tuple[str, list[str]]] = field(default_factory=list)  # (word, closest names)
    rest: str = ""                  # the prompt without its colour words (for matching the medium)

    def messages(self) -> list[str]:
        out = []
        for word, close in self.unmatched:
            hint = f"; closest names: {', '.join(close)}" if close else ""
            out.append(f"'{word}' is not a colour name I know{hint}")
        return out


_WORD = re.compile(r"[^\W\d_]+(?:'[^\W\d_]+)?", re.UNICODE)
_CJK = re.compile(r"[\u3040-\u30ff\u3400-\u9fff]")
_ONE_WORD = {k.replace(" ", ""): k for k in ALL_COLOURS}  # "darkslategray" -> "dark slate gray"


def _lookup(words: list[str]) -> tuple[str, bool] | None:
    """(English name, written in another language) for a word sequence, or None."""
    text = " ".join(words)
    if text in ALL_COLOURS:
        return text, False
    if "".join(words) in _ONE_WORD:
        return _ONE_WORD["".join(words)], False
    if text in FOREIGN_COLOURS:
        return FOREIGN_COLOURS[text], True
    return None


def _modifier(word: str) -> str | None:
    return word if word in MODIFIERS else MODIFIER_WORDS.get(word)


def closest_names(word: str, n: int = 3) -> list[str]:
    return difflib.get_close_matches(word.lower(), list(ALL_COLOURS), n=n, cutoff=0.6)


def parse_colours(text: str) -> ColourParse:
    """The colours a prompt names, in order, without repeats, and the colour-like words it could not read."""
    tokens = [(m.group(0).lower(), m.start(), m.end()) for m in _WORD.finditer(text or "")]
    words = [t for t, _, _ in tokens]
    found: list[tuple[int, int, NamedColour, bool]] = []  # (first token, end token, colour, ambiguous)
    i = 0
    while i < len(words):
        hit = None
        for n in range(min(MAX_WORDS, len(words) - i), 0, -1):
            got = _lookup(words[i:i + n])
            if got:
                hit = (n, *got)
                break
        if hit is None:
            i += 1
            continue
        n, name, foreign = hit
        start, end = i, i + n
        rgb = hex_to_rgb(ALL_COLOURS[name])
        label = name
        mod = _modifier(words[i - 1]) if i > 0 else None
        if mod and not (i - 1 >= 0 and any(s <= i - 1 < e for s, e, _, _ in found)):
            rgb, label, start = MODIFIERS[mod](rgb), f"{mod} {name}", i - 1
        elif foreign and end < len(words) and words[end] in MODIFIER_WORDS:
            mod = MODIFIER_WORDS[words[end]]  # "bleu profond", "azul oscuro"
            rgb, label, end = MODIFIERS[mod](rgb), f"{mod} {name}", end + 1
        written = text[tokens[start][1]:tokens[end - 1][2]]
        ambiguous = n == 1 and name in AMBIGUOUS and not mod and not foreign
        found.append((start, end, NamedColour(label, tuple(float(v) for v in rgb), written), ambiguous))
        i = end
    # CJK scripts have no spaces: look the names up inside the text
    for key, name in FOREIGN_COLOURS.items():
        if _CJK.match(key) and key in (text or ""):
            rgb = hex_to_rgb(ALL_COLOURS[name])
            found.append((len(words), len(words), NamedColour(name, rgb, key), False))

    def has_context(k: int) -> bool:
        start, end, colour, _ = found[k]
        after = words[end] if end < len(words) else ""
        if after in CONTEXT_AFTER:
            return True
        if words[start] in MEDIUM_WORDS:
            return False
        before = words[start - 1] if start > 0 else ""
        for j in (k - 1, k + 1):  # a colour next to it in a list: "rust and teal", "rust, teal"
            if 0 <= j < len(found):
                gap = words[min(end, found[j][1]):max(start, found[j][0])]
                if len(gap) <= 1 and all(g in LIST_WORDS for g in gap):
                    return True
        return before == "in" and (end >= len(words) or words[end] in LIST_WORDS)

    keep, used = [], set()
    for k, (start, end, colour, ambiguous) in enumerate(found):
        if ambiguous and not has_context(k):
            continue
        keep.append(colour)
        used.update(range(start, end))
    unique, seen = [], set()
    for c in keep:
        if c.name not in seen:
            seen.add(c.name)
            unique.append(c)
    unmatched = []
    for j, w in enumerate(words):
        nxt = words[j + 1] if j + 1 < len(words) else ""
        if (nxt in CONTEXT_AFTER and j not in used and w not in STOPWORDS and w not in CONTEXT_AFTER
                and not _modifier(w) and w not in LIST_WORDS and len(w) > 2):
            unmatched.append((w, closest_names(w)))
    rest = " ".join(w for j, w in enumerate(words)
                    if (j not in used or w in LIGHT_WORDS) and w not in CONTEXT_AFTER)
    for c in keep:
        if _CJK.match(c.words):
            rest = rest.replace(c.words, " ")
    return ColourParse(unique, unmatched, " ".join(rest.split()))


def colour_by_name(name: str) -> NamedColour:
    """One colour by its name (modifiers allowed); ValueError with the closest names if unknown."""
    parsed = parse_colours(f"{name} colour")  # the context makes 'mint' or 'rust' a colour
    if not parsed.colours:
        close = closest_names(name.strip().split()[-1] if name.strip() else "")
        hint = f"; closest names: {', '.join(close)}" if close else ""
        raise ValueError(f"'{name.strip()}' is not a colour name I know{hint}")
    return parsed.colours[0]

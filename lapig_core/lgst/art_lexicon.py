"""The art lexicon: painters, movements, periods, crafts and popular styles -> the look each one maps to.

The entries are data (art_lexicon.toml, read with tomllib; nothing in it is executed): for each name its
palette in colour names, its marks, surface and shapes, a description and tags, and its composition:
a look of the library (looks/) or a mix of the 26 neural styles, a palette mapped over it, and an
optional texture and mood. The prompt plan finds a named entry in three ways, in this order:

- by name: an alias written in the prompt (case and accents ignored; "Monet's" finds "Monet"; other
  languages' names are aliases too: "Jugendstil", "estampe japonaise", "絵本");
- by spelling: a long word or two-word run within a small edit of an alias ("Kandinski", "Mondriaan");
- by meaning: with the multilingual embedder, a run of words whose embedding is very close to an
  entry's name ("impresionismo", "Kubismus"), so names the aliases do not list still resolve.

An entry's "works" are subjects the name is known for ("water lilies" beside Monet): they add their
colours to the entry's palette, they do not replace the entry. Unknown names get the three nearest
entries (`nearest`).
"""
from __future__ import annotations

import difflib
import functools
import re
import tomllib
import unicodedata
from dataclasses import dataclass, field
from pathlib import Path

LEXICON_FILE = Path(__file__).with_name("art_lexicon.toml")
KINDS = ("painter", "movement", "period", "craft", "popular")
GROUPS = ("impressionism", "modernism", "japanese", "miniatures", "crafts", "old_masters", "popular", "world")
# which of two names in one prompt is what the look is about: the most specific
KIND_PRIORITY = {"painter": 0, "period": 1, "movement": 2, "popular": 3, "craft": 4}
DEFAULT_PALETTE_STRENGTH = 0.7
MAX_PALETTE = 7
FUZZY_CUTOFF = 0.84         # difflib ratio for a misspelt name (5 letters or more)
EMBED_CUTOFF = 0.925        # multilingual-e5 similarity of a run of words to an entry's name
EMBED_MARGIN = 0.02         # ... and above the second-best entry by this much


def fold(text: str) -> str:
    """Lower case without accents; CJK kept; apostrophes and dashes unified."""
    text = text.replace("\u2019", "'").replace("\u2010", "-").replace("\u2011", "-")
    decomposed = unicodedata.normalize("NFD", text.lower())
    return unicodedata.normalize("NFC", "".join(c for c in decomposed if unicodedata.category(c) != "Mn"))


@dataclass(frozen=True)
class Entry:
    name: str
    kind: str
    group: str
    family: str
    aliases: tuple[str, ...]
    marks: str
    surface: str
    shapes: str
    palette: tuple[str, ...]
    description: str
    tags: tuple[str, ...]
    look: str | None = None
    styles: tuple[tuple[str, float], ...] = ()
    palette_strength: float = DEFAULT_PALETTE_STRENGTH
    texture: str | None = None
    mood: str | None = None
    works: tuple[tuple[str, tuple[str, ...]], ...] = ()
    cased: tuple[str, ...] = ()
    params: tuple[tuple[str, object], ...] = ()   # start values of the look's parameters for this name

    def line(self, colours: list[str] | None = None) -> str:
        """'Monet (Impressionism): soft broken strokes; lilac, pale blue, sage green, pink'."""
        names = list(colours if colours is not None else self.palette)[:4]
        return f"{self.name} ({self.family}): {self.marks}; {', '.join(names)}"

    def text(self) -> str:
        """The text a word is compared with when looking for the nearest entries."""
        return f"{self.name}. {self.family}. {self.description} Style: {', '.join(self.tags)}."

    def medium(self) -> str:
        return self.look or " + ".join(f"{n} {w:g}" for n, w in self.styles)

    def work_colours(self, subject: str) -> tuple[str, ...]:
        return dict(self.works).get(subject, ())

    def to_dict(self) -> dict:
        return {"name": self.name, "kind": self.kind, "family": self.family, "group": self.group,
                "marks": self.marks, "surface": self.surface, "shapes": self.shapes,
                "palette": list(self.palette), "look": self.look,
                "styles": [[n, w] for n, w in self.styles], "palette_strength": self.palette_strength,
                "texture": self.texture, "mood": self.mood}


_FIELDS = {"name", "kind", "group", "family", "aliases", "marks", "surface", "shapes", "palette", "description",
           "tags", "look", "styles", "palette_strength", "texture", "mood", "works", "cased", "params"}
_REQUIRED = ("name", "kind", "group", "family", "aliases", "marks", "surface", "shapes", "palette",
             "description", "tags")


def _entry(raw: dict, where: str) -> Entry:
    unknown = set(raw) - _FIELDS
    missing = [k for k in _REQUIRED if not raw.get(k)]
    if unknown or missing:
        raise ValueError(f"{where}: " + "; ".join(filter(None, [
            f"unknown fields {sorted(unknown)}" if unknown else "", f"missing {missing}" if missing else ""])))
    if raw["kind"] not in KINDS or raw["group"] not in GROUPS:
        raise ValueError(f"{where}: kind must be one of {KINDS} and group one of {GROUPS}")
    if bool(raw.get("look")) == bool(raw.get("styles")):
        raise ValueError(f"{where}: give either a look or a styles mix")
    strength = float(raw.get("palette_strength", DEFAULT_PALETTE_STRENGTH))
    if not 0.0 <= strength <= 1.0:
        raise ValueError(f"{where}: palette_strength must be in [0, 1]")
    return Entry(
        name=raw["name"], kind=raw["kind"], group=raw["group"], family=raw["family"],
        aliases=tuple(dict.fromkeys([raw["name"], *raw["aliases"]])), marks=raw["marks"], surface=raw["surface"],
        shapes=raw["shapes"], palette=tuple(raw["palette"]), description=raw["description"], tags=tuple(raw["tags"]),
        look=raw.get("look"), styles=tuple((k, float(v)) for k, v in (raw.get("styles") or {}).items()),
        palette_strength=strength, texture=raw.get("texture"), mood=raw.get("mood"),
        works=tuple((fold(k), tuple(v)) for k, v in (raw.get("works") or {}).items()),
        cased=tuple(raw.get("cased") or ()),
        params=tuple((k, tuple(v) if isinstance(v, list) else float(v)) for k, v in (raw.get("params") or {}).items()))


@functools.lru_cache(maxsize=2)
def load(path: str | None = None) -> tuple[Entry, ...]:
    with open(path or LEXICON_FILE, "rb") as f:
        data = tomllib.load(f)
    entries = tuple(_entry(raw, f"art lexicon entry {i + 1} ({raw.get('name', '?')})")
                    for i, raw in enumerate(data.get("entry", [])))
    names = [fold(e.name) for e in entries]
    dup = sorted({n for n in names if names.count(n) > 1})
    if dup:
        raise ValueError(f"art lexicon: names given twice: {dup}")
    return entries


ENTRIES: tuple[Entry, ...] = load()
BY_NAME: dict[str, Entry] = {fold(e.name): e for e in ENTRIES}


def entry(name: str) -> Entry:
    """An entry by its name or any alias (case and accents ignored); KeyError with the nearest names."""
    key = fold(name.strip())
    if key in BY_NAME:
        return BY_NAME[key]
    for e in ENTRIES:
        if key in (fold(a) for a in e.aliases):
            return e
    raise KeyError(f"'{name}' is no entry of the art lexicon; nearest: "
                   + ", ".join(e.name for e in nearest(name, use_embedder=False)))


def problems(entries=None) -> list[str]:
    """What does not resolve: looks, styles, textures, moods and colour names of every entry."""
    from .colours import colour_by_name
    from .looks import BY_NAME as LOOKS
    from .style_catalog import BY_NAME as STYLES

    out = []
    for e in entries or ENTRIES:
        if e.look and (e.look not in LOOKS or LOOKS[e.look].role != "medium"):
            out.append(f"{e.name}: look '{e.look}' is no medium of the look library")
        for s, w in e.styles:
            if s not in STYLES or w <= 0:
                out.append(f"{e.name}: style '{s}' ({w}) is not one of the 26 styles with a positive weight")
        if e.params and e.look in LOOKS:
            stage = LOOKS[e.look].make(None)
            for k, v in e.params:
                if k not in stage.params or stage.params[k].numel() != (len(v) if isinstance(v, tuple) else 1):
                    out.append(f"{e.name}: '{k}' is no parameter of the look {e.look} (or has another size)")
        if e.params and not e.look:
            out.append(f"{e.name}: params need a look")
        if e.texture and (e.texture not in LOOKS or LOOKS[e.texture].role != "texture"):
            out.append(f"{e.name}: texture '{e.texture}' is no texture look")
        if e.mood and (e.mood not in LOOKS or LOOKS[e.mood].role != "mood"):
            out.append(f"{e.name}: mood '{e.mood}' is no mood look")
        for colour in list(e.palette) + [c for _, cs in e.works for c in cs]:
            try:
                colour_by_name(colour)
            except ValueError as exc:
                out.append(f"{e.name}: {exc}")
    return out


# -- finding names in a prompt ---------------------------------------------------------------------------
@dataclass
class NameMatch:
    entry: Entry
    written: str                 # the words as the prompt has them
    how: str                     # "name", "spelling" or "meaning"
    score: float                 # 1 for a name as written; the similarity otherwise
    span: tuple[int, int] = (0, 0)   # in the prompt text (for taking the name out)
    works: list[str] = field(default_factory=list)   # subjects of the entry named beside it


_CJK = re.compile(r"[\u3040-\u30ff\u3400-\u9fff\uac00-\ud7af]")


@functools.lru_cache(maxsize=1)
def _alias_table():
    """[(folded alias, entry, cased)], longest first."""
    rows = []
    for e in ENTRIES:
        for a in e.aliases:
            rows.append((fold(a), e, False))
        for a in e.cased:
            rows.append((a, e, True))
    return sorted(rows, key=lambda r: -len(r[0]))


def _spans(haystack: str, key: str, cjk: bool):
    if cjk:
        start = haystack.find(key)
        while start >= 0:
            yield start, start + len(key)
            start = haystack.find(key, start + 1)
        return
    for m in re.finditer(r"(?<![\w])" + re.escape(key) + r"(?![\w])", haystack):
        yield m.start(), m.end()


def _free(span, taken) -> bool:
    return not any(a < span[1] and span[0] < b for a, b in taken)


def searchable(text: str) -> str:
    """The text the spans of the finders index: the text itself where fold() keeps its length (it does
    for nearly all text), else the folded text."""
    folded = fold(text)
    return text if len(folded) == len(text) else folded


def find_written(text: str) -> list[NameMatch]:
    """Entries whose name or alias is written in the text (longest first; an alias inside a longer one
    found already does not count). Spans index searchable(text)."""
    text = searchable(text)
    folded = fold(text)
    found, taken = [], []
    for key, e, cased in _alias_table():
        hay = text if cased else folded
        for span in _spans(hay, key, bool(_CJK.search(key))):
            if _free(span, taken):
                taken.append(span)
                found.append(NameMatch(e, text[span[0]:span[1]], "name", 1.0, span))
    return found


_WORD = re.compile(r"[^\W\d_][\w'\-]*", re.UNICODE)


def _runs(text: str, taken, max_words: int = 3):
    """(start, end, words) runs of 1..max_words words outside the taken spans."""
    words = [(m.start(), m.end()) for m in _WORD.finditer(text) if _free((m.start(), m.end()), taken)]
    for i in range(len(words)):
        for n in range(1, max_words + 1):
            if i + n > len(words):
                break
            seg = words[i:i + n]
            if any(seg[j + 1][0] - seg[j][1] > 2 for j in range(n - 1)):
                break  # words not next to each other
            yield seg[0][0], seg[-1][1]


def _only_common(run: str, skip_words) -> bool:
    """A run made only of common words (instructions, colours, moods, plain art words): no name."""
    return all(w.strip("'-") in skip_words or len(w) < 3 for w in re.split(r"[\s]+", re.sub(r"'s\b", "", run)))


def blank(text: str, spans) -> str:
    """The text with the spans replaced by spaces (the names taken out)."""
    chars = list(text)
    for a, b in spans:
        chars[a:b] = " " * (b - a)
    return "".join(chars)


@functools.lru_cache(maxsize=1)
def _spelling_table():
    return [(key, e) for key, e, cased in _alias_table() if not cased and len(key) >= 5 and not _CJK.search(key)]


def find_misspelt(text: str, taken, skip_words=frozenset()) -> list[NameMatch]:
    """Words (or two-word runs) within a small edit of an alias of 5 letters or more and of as many
    words ('Kandinski', 'Rembrant', 'Frida Kalo'); runs with a common word are no names."""
    found = []
    for start, end in _runs(text, taken, 2):
        run = fold(text[start:end]).strip("'-")
        run = re.sub(r"'s$", "", run)
        words = run.split()
        if (len(run) < 5 or any(w.strip("'-") in skip_words for w in words)
                or not _free((start, end), taken + [m.span for m in found])):
            continue
        best = None
        for key, e in _spelling_table():
            if abs(len(key) - len(run)) > 1 or len(key.split()) != len(words):
                continue
            r = difflib.SequenceMatcher(None, run, key).ratio()
            if r >= FUZZY_CUTOFF and (best is None or r > best[0]):
                best = (r, e)
        if best:
            found.append(NameMatch(best[1], text[start:end], "spelling", round(best[0], 3), (start, end)))
    return found


@functools.lru_cache(maxsize=2)
def _name_vectors(embedder_name: str):
    from .text_embedder import E5, MINILM, embed_texts

    return embed_texts([e.name for e in ENTRIES], E5 if embedder_name == "e5" else MINILM)


def find_by_meaning(text: str, taken, embedder, skip_words=frozenset()) -> list[NameMatch]:
    """Runs of words whose embedding is very close to one entry's name (e5 only: it reads other
    languages; 'impresionismo' -> Impressionism)."""
    from .text_embedder import embed_texts

    if embedder.name != "e5":
        return []
    runs = [(s, e) for s, e in _runs(text, taken, 3)
            if len(text[s:e]) >= 4 and not _only_common(fold(text[s:e]), skip_words)]
    if not runs:
        return []
    names = _name_vectors(embedder.name)
    vectors = embed_texts([text[s:e] for s, e in runs], embedder)
    sims = vectors @ names.T
    found = []
    for (s, e), row in sorted(zip(runs, sims), key=lambda r: -float(r[1].max())):
        top = row.topk(2)
        score, second = float(top.values[0]), float(top.values[1])
        if score >= EMBED_CUTOFF and score - second >= EMBED_MARGIN and _free((s, e), taken + [m.span for m in found]):
            found.append(NameMatch(ENTRIES[int(top.indices[0])], text[s:e], "meaning", round(score, 3), (s, e)))
    return found


def find_works(text: str, matches: list[NameMatch], taken) -> list[tuple[NameMatch, str, tuple[int, int]]]:
    """Subjects of a found entry written beside it ('water lilies' by Monet): (match, subject, span)."""
    folded = fold(searchable(text))
    out = []
    for m in matches:
        for subject, _ in sorted(m.entry.works, key=lambda w: -len(w[0])):
            for span in _spans(folded, subject, bool(_CJK.search(subject))):
                if _free(span, taken):
                    taken.append(span)
                    m.works.append(subject)
                    out.append((m, subject, span))
    return out


def find_work_alone(text: str) -> list[NameMatch]:
    """A famous subject of two words or more named without its painter ('the great wave')."""
    folded = fold(searchable(text))
    found, taken = [], []
    for e in ENTRIES:
        for subject, _ in e.works:
            if len(subject.split()) < 2:
                continue
            for span in _spans(folded, subject, False):
                if _free(span, taken):
                    taken.append(span)
                    m = NameMatch(e, text[span[0]:span[1]], "work", 1.0, span, [subject])
                    found.append(m)
    return found


def primary(matches: list[NameMatch]) -> NameMatch | None:
    """The name the look is about: the most specific kind (a painter before a movement before a craft),
    then the first written."""
    if not matches:
        return None
    return min(matches, key=lambda m: (KIND_PRIORITY[m.entry.kind], m.span[0]))


def palette_names(match: NameMatch) -> list[str]:
    """The entry's palette with the colours of the works named beside it first ("water lilies" adds
    greens and lilac to Monet's colours)."""
    names = [c for w in match.works for c in match.entry.work_colours(w)] + list(match.entry.palette)
    return list(dict.fromkeys(names))[:MAX_PALETTE]


def nearest(word: str, k: int = 3, use_embedder: bool = True) -> list[Entry]:
    """The k entries nearest an unknown name: by spelling (the best alias), and, with the multilingual
    embedder, by meaning (an unknown painter near the movement the model knows them by)."""
    w = fold(word)
    spelling = [max(difflib.SequenceMatcher(None, w, fold(a)).ratio() for a in e.aliases) for e in ENTRIES]
    scores = list(spelling)
    if use_embedder:
        try:
            from .text_embedder import active, embed_texts

            embedder = active()
            if embedder.name == "e5":
                names = _name_vectors(embedder.name)
                sims = (embed_texts([word], embedder) @ names.T)[0].tolist()
                mean = sum(sims) / len(sims)
                scores = [s + 4.0 * (m - mean) for s, m in zip(spelling, sims)]
        except Exception:  # no text model here: spelling alone
            pass
    order = sorted(range(len(ENTRIES)), key=lambda i: -scores[i])
    return [ENTRIES[i] for i in order[:k]]

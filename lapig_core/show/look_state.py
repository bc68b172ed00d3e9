# SPDX-License-Identifier: GPL-3.0-or-later
"""A keyed look's state: its backend prepared, theta and PSA's tone field as PSA left them.

Results on disk hold images and result.json, not theta. A moving or morphing look needs theta (the morph
interpolates it; a moved look's tone field starts from the keyed one), so a look is made again from what
result.json records (prompt, backend, seed, the style mix and PSA's settings) and adapted once, cached
for the show's run: the chosen way, because it reads every result ever written, needs nothing new from
Generate, and the backends are deterministic for a seed (PSA is seeded too), so the look is the one the
result holds, within PSA's floating-point noise.

PSA once per keyed look costs seconds; a result folder that holds `look_state.npz` (save_look_state: the
tensors as numpy arrays, read with allow_pickle=False so a data file never runs code) skips it. Generate
may write it beside result.json; old results without it stay readable (the re-adaptation above).
"""
from __future__ import annotations

import io
import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import torch

from ..common.atomic import atomic_write_bytes

LOOK_STATE_FILE = "look_state.npz"
FORMAT = 1


@dataclass
class KeyedLook:
    """A look of the show as PSA left it, at the working frame."""

    backend: object  # the prepared LGST backend (bare: no tone field), theta loaded
    state: dict  # {"theta": [tensors], "tone_field": [tensors]}
    base: torch.Tensor  # (1,3,H,W) the backend's look of theta, before the tone field
    name: str = ""  # the backend's name (a morph interpolates theta only within one backend)
    # (1,3,H,W) at the working frame, or None: Refine's last correction of the projector image (refined minus
    # open loop), carried as a per-pixel offset onto every frame of this look
    offset: torch.Tensor | None = None


def look_state_bytes(state: dict) -> bytes:
    """`state` (theta and the tone field: lists of tensors) as the bytes of look_state.npz: Generate writes it
    into the result folder with the rest (export/result_files.write_new_result's files)."""
    arrays = {"format": np.array(FORMAT)}
    for group in ("theta", "tone_field"):
        tensors = state.get(group) or []
        arrays[f"{group}_count"] = np.array(len(tensors))
        for n, t in enumerate(tensors):
            arrays[f"{group}_{n}"] = t.detach().cpu().numpy()
    buffer = io.BytesIO()
    np.savez(buffer, **arrays)
    return buffer.getvalue()


def save_look_state(folder, state: dict) -> Path:
    """Write `state` as folder/look_state.npz, whole or not at all."""
    return atomic_write_bytes(Path(folder) / LOOK_STATE_FILE, look_state_bytes(state))


def load_look_state(folder) -> dict | None:
    """The state saved in `folder`, or None where there is none (an older result)."""
    path = Path(folder) / LOOK_STATE_FILE
    if not path.is_file():
        return None
    with np.load(path, allow_pickle=False) as data:
        if int(data["format"]) != FORMAT:
            return None
        return {group: [torch.from_numpy(np.array(data[f"{group}_{n}"]))
                        for n in range(int(data[f"{group}_count"]))]
                for group in ("theta", "tone_field")}


def read_result_record(folder) -> dict:
    """What result.json says made the look (prompt, backend, seed, style mix, PSA settings)."""
    summary = json.loads((Path(folder) / "result.json").read_text(encoding="utf-8"))
    psa = summary.get("psa", True)  # one projector's: True / False; several projectors': what PSA did, or False
    settings = summary.get("psa_settings") or (psa.get("settings") if isinstance(psa, dict) else None) or {}
    return {"prompt": summary.get("prompt", ""), "backend": summary.get("backend") or "styletransfer",
            "seed": int(summary.get("seed") or 0), "mix": summary.get("style_mix_override"),
            "psa": bool(psa), "psa_settings": settings,
            "dark_outside": bool(summary.get("dark_outside", False)), "fingerprint": summary.get("fingerprint"),
            # a world look's sliders as the artist left them (lapig_core/look_parameters), and what rebuilds it
            "look_parameters": (summary.get("lgst") or {}).get("look_parameters"),
            "look_record": (summary.get("lgst") or {}).get("look_record"),
            "geometry": ((summary.get("lgst") or {}).get("geometry") or {}).get("source")}


def result_geometry(folder, record: dict):
    """What the result's look of the world was shaped by, for making it again: the geometry it kept
    (look_geometry.npz), "capture" where the captured surface stood in (made again from the surface), or None
    (no geometry: an art look, a result of before the geometry was kept)."""
    from ..lgst.world.geometry import GEOMETRY_FILE, load_geometry

    kept = load_geometry(Path(folder) / GEOMETRY_FILE)
    if kept is not None:
        return kept
    return "capture" if record.get("geometry") == "capture" else None


def refine_offset(folder) -> torch.Tensor | None:
    """Refine on the rig's correction of a result: its refined working-frame projector image minus the open-loop
    one, (1,3,H,W); None for a result that was not refined (or whose images cannot be read)."""
    from ..export.result_files import read_result_image, refined_images

    name = refined_images(folder).get("projector_working")
    if not name:
        return None
    try:
        refined, open_loop = read_result_image(folder, name), read_result_image(folder, "projector")
    except (OSError, ValueError):
        return None
    if refined.shape != open_loop.shape:
        return None
    return torch.from_numpy(np.ascontiguousarray(refined - open_loop, dtype=np.float32)).permute(2, 0, 1)[None]


def look_state_files(state) -> dict:
    """The look's theta and tone field where PSA left them, as write_new_result's files (look_state.npz): a show
    makes this very look again from it, not from the prompt and PSA run once more."""
    if not state:
        return {}
    return {LOOK_STATE_FILE: look_state_bytes(state)}

"""A stylization result on disk: the images the add-on previews and exports, and a JSON summary.

The images are 16-bit PNGs: float results kept to 1/65535 (half a level of error at most, and a
16-bit PNG read and written again is unchanged), so the exported projector file, the Blender light
and Render Real Capture all start from the optimiser's values, not from 8-bit copies of them.
Folders written before this hold 8-bit PNGs; they are read as they are (stored_bit_depth tells).

Folder layout (working frame, projector-registered):
  target.png / target_nopsa.png          what the viewer should see, with and without PSA
  projector.png / projector_nopsa.png    the compensated projector images (working frame)
  simulated.png / simulated_nopsa.png    PCNet's prediction of the capture
  rendered.png / rendered_nopsa.png      the Cycles capture of the projection (when rendered)
  compensability.png                     L_ps + L_cs per pixel over the surface, as a heat map
  target_native.png / projector_native.png / rendered_native.png
                                         the chosen look, its projector image and their Cycles
                                         capture at the output size (native by default), when made
  comparison.png                         with and without PSA side by side (8-bit, for people)
  result.json                            prompt, backend, styles, PSA settings, metrics

A new result is written into a scratch folder beside the others and renamed into place when it is
complete, under a name no other result has (write_new_result).
"""
from __future__ import annotations

import datetime
import hashlib
import json
import unicodedata
from pathlib import Path

import numpy as np

from ..common.atomic import atomic_write_bytes
from ..common.imageio import read_image, to_bit_depth, to_float, write_png
from ..common.jsonable import json_default_or_str
from ..common.scratch import ScratchFolder
from ..common.sheets import labelled_grid

IMAGES = ("target", "projector", "simulated", "rendered", "compensability")
NATIVE = "_native"  # suffix of the images at the output size
BIT_DEPTH = 16
COMPARISON = (("target_nopsa", "target without PSA"), ("simulated_nopsa", "simulated without PSA"),
              ("rendered_nopsa", "rendered without PSA"), ("target", "target with PSA"),
              ("simulated", "simulated with PSA"), ("rendered", "rendered with PSA"))


def heat_overlay(surface: np.ndarray, values: np.ndarray, scale: float | None = None) -> np.ndarray:
    """Surface in gray with the problem areas in yellow-to-red on top (values (H, W) >= 0)."""
    v = np.asarray(values, np.float32)
    scale = scale or max(float(np.percentile(v, 99)), 1e-4)
    t = np.clip(v / scale, 0, 1)[..., None]
    gray = np.repeat(np.asarray(surface, np.float32).mean(-1, keepdims=True), 3, -1) * 0.6
    hot = np.concatenate([np.ones_like(t), 1 - t, np.zeros_like(t)], -1)  # yellow -> red
    alpha = np.clip(t * 1.5, 0, 0.85)
    return gray * (1 - alpha) + hot * alpha


def folder_name(prompt: str, when: datetime.datetime) -> str:
    """'20260101_120000_make_it_stained_glass': the words of the prompt in any script, lower case;
    a short hash of the prompt when it has none (emoji only)."""
    text = unicodedata.normalize("NFKC", prompt).lower()
    words = "".join(c if unicodedata.category(c)[0] in "LMN" else " " for c in text).split()
    slug = "_".join(words)[:40].rstrip("_") or "look_" + hashlib.sha256(prompt.encode("utf-8")).hexdigest()[:8]
    return f"{when:%Y%m%d_%H%M%S}_{slug}"


def write_new_result(root, name: str, images: dict, summary: dict, files: dict | None = None) -> Path:
    """Write a result folder as a whole, as <root>/<name> (<name>_2, ... when that is taken): a
    kill or an error leaves no half-written result, and two results never share a folder. files: other
    files of the folder, name -> bytes (Generate's look_state.npz)."""
    scratch = ScratchFolder(root, ".writing_")
    try:
        for file_name, data in (files or {}).items():
            (Path(scratch.path) / file_name).write_bytes(data)
        write_result(scratch.path, images, summary)
    except BaseException:
        scratch.remove()
        raise
    return scratch.move_to_new_folder(name)


def capture_of_result(folder, summary: dict) -> str:
    """The capture folder a result was made from. result.json records its absolute path; a project moved or copied
    (the .blend with its data folder) has the same capture in the result's own data folder (<data>/results/<result>
    beside <data>/<object>/setups/<name>), and that one is taken: the longest tail of the recorded path, of at least
    those three parts, that is a folder there (a copy's own capture, not the original's it was copied from).
    Otherwise the recorded path as it is ('' where none is recorded)."""
    recorded = str(summary.get("capture") or "")
    if not recorded:
        return recorded
    parts = Path(recorded.replace("\\", "/")).parts
    data = Path(folder).resolve().parent.parent
    for start in range(1, len(parts) - 2):
        here = data.joinpath(*parts[start:])
        if here.is_dir():
            return str(here)
    return recorded


def write_result(folder, images: dict, summary: dict, sheet=None) -> Path:
    """Write images into a result folder (new, or adding to one), then its comparison sheet and
    result.json. images: name -> (H, W, 3) in [0,1] (names from IMAGES, with '_nopsa' variants).
    sheet(folder, images, summary) -> (tiles, columns): the sheet of every image the folder now holds, the ones written
    before included (None: one projector's, COMPARISON; a result of several keeps its own unless its caller gives
    one: multi/result_files.write_rendered, look, predicted and rendered in camera space)."""
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    for name, img in images.items():
        write_png(folder / f"{name}.png", img, bit_depth=BIT_DEPTH)
    if sheet is None and "multi" not in summary:
        sheet = _projector_sheet
    tiles, columns = sheet(folder, images, summary) if sheet is not None else ([], 0)
    if tiles:
        write_png(folder / "comparison.png", labelled_grid([t for t, _ in tiles], [lab for _, lab in tiles],
                                                           columns=columns, cell=256, title=summary.get("prompt", "")))
    atomic_write_bytes(folder / "result.json", json.dumps(summary, indent=2, default=json_default_or_str).encode("utf-8"))
    return folder


def _projector_sheet(folder: Path, images: dict, summary: dict) -> tuple[list, int]:
    """One projector's sheet: with and without PSA side by side (target, simulated, rendered where made)."""
    tiles = [(images[n] if n in images else read_result_image(folder, n), lab)
             for n, lab in COMPARISON if (folder / f"{n}.png").is_file()]
    return tiles, 3 if len(tiles) == 6 else 2


def as_stored(img: np.ndarray) -> np.ndarray:
    """An image as read_result_image reads it back once written: the same values, without the file."""
    return to_float(to_bit_depth(img, BIT_DEPTH))


def read_summary(folder) -> dict:
    path = Path(folder) / "result.json"
    if not path.is_file():
        raise FileNotFoundError(f"no stylization result in {folder}: generate one first")
    return json.loads(path.read_text(encoding="utf-8"))


def _image_path(folder, name: str) -> Path:
    path = Path(folder) / f"{name}.png"
    if not path.is_file():
        raise FileNotFoundError(f"the result has no '{name}' image ({path.name}): generate or render it first")
    return path


def read_result_image(folder, name: str) -> np.ndarray:
    """A result image as float32 RGB in [0, 1], from a 16-bit (or an older 8-bit) PNG."""
    return read_image(_image_path(folder, name))


def refined_images(folder, summary: dict | None = None) -> dict:
    """What a refinement on the rig put in place of the result's images ({'projector': its file's name,
    'projector_working': ...}), as result.json names them: written last, so a refinement cut short names
    nothing and the open-loop images stay the result's."""
    try:
        summary = read_summary(folder) if summary is None else summary
    except (OSError, ValueError):
        return {}
    names = (summary.get("refine") or {}).get("images") or {}
    return {k: v for k, v in names.items() if (Path(folder) / f"{v}.png").is_file()}


def output_name(folder, name: str) -> str:
    """The name of the finest version of a result image: the refined one where the result was refined on
    the rig, else '<name>_native' (the output size) where the result has one, else the working frame's."""
    refined = refined_images(folder).get(name) if name == "projector" else None
    if refined:
        return refined
    native = name + NATIVE
    return native if (Path(folder) / f"{native}.png").is_file() else name


def read_output_image(folder, name: str) -> np.ndarray:
    """The finest version of a result image (output_name): what the projector shows and Export writes."""
    return read_result_image(folder, output_name(folder, name))


def stored_bit_depth(folder, name: str) -> int:
    """Bits per channel of a stored result image (8 in folders written before 16-bit results)."""
    with open(_image_path(folder, name), "rb") as f:
        header = f.read(25)  # PNG signature (8), IHDR length and type (8), width, height, bit depth
    if len(header) < 25 or header[:8] != b"\x89PNG\r\n\x1a\n":
        raise OSError(f"{name}.png in {folder} is not a PNG file")
    return header[24]

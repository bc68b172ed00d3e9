# SPDX-License-Identifier: GPL-3.0-or-later
"""The capture set of several projectors on disk, and its loader.

A setup folder (<root>/setups/<name>, as one projector's) holding:

    setup.json            its "multi" entry: the projectors' names and sizes, the training count
    camera_maps.npz       one CameraMap per projector (map_xy, valid, projector_sizes)
    cam_black.png         every projector black
    cam_together.png      every projector white at once: the object as the look sees it
    cam_blend_probe.png   every projector its blend's alpha map at once (blend_probe.py; older sets lack it)
    object_mask.png       where the camera sees the object
    projector_<k>/prj/img_NNNN.png   the frames projector k showed alone (native, 8-bit)
    projector_<k>/cam/img_NNNN.png   their captures
    projector_<k>/blend_probe.png    the alpha map projector k showed for the blend probe
    models/joint_model.npz           the joint classical model, fitted after the capture

One projector's data set (capture/dataset.py) is another layout; `is_multi` tells them apart by setup.json.
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..capture import dataset as ds
from ..common.atomic import atomic_write_npz
from ..common.imageio import read_image
from .camera_map import CameraMap, maps_from_arrays, maps_to_arrays

MULTI_KEY = "multi"
CAMERA_MAPS = "camera_maps.npz"
BLACK = "cam_black.png"
TOGETHER = "cam_together.png"
BLEND_PROBE = "cam_blend_probe.png"
BLEND_PROBE_FRAME = "blend_probe.png"
OBJECT_MASK = "object_mask.png"
MODELS = "models"
JOINT_MODEL = "joint_model.npz"
FIRST_LOOK = "first_look.json"


def projector_dir(setup_dir, k: int) -> Path:
    """Projector k's (0-based) folder: projector_1, projector_2, ..."""
    return Path(setup_dir) / f"projector_{k + 1}"


def joint_model_path(setup_dir) -> Path:
    return Path(setup_dir) / MODELS / JOINT_MODEL


def is_multi(folder) -> bool:
    """Whether a capture folder (a setup folder or its root) holds a capture of several projectors."""
    try:
        return MULTI_KEY in ds.read_setup_json(ds.resolve_setup(folder).setup_json)
    except (ds.DatasetError, OSError):
        return False


def save_camera_maps(path, maps) -> None:
    atomic_write_npz(path, maps_to_arrays(maps), compressed=True)


def load_camera_maps(path) -> list[CameraMap]:
    with np.load(path, allow_pickle=False) as z:
        return maps_from_arrays(z)


@dataclass(eq=False)
class MultiCaptureSet:
    """A loaded capture of K projectors: names and sizes; maps; frames[k] (N,h,w,3) uint8 shown alone and
    captures[k] (N,H,W,3) uint8 of them; black and together (H,W,3) uint8; object_mask (H,W) bool;
    probe_frames (one (h_k,w_k,3) uint8 per projector) and probe (H,W,3) uint8: the blend probe, None in a
    set captured before it."""

    setup_dir: Path
    meta: dict
    names: tuple
    sizes: tuple
    maps: list
    frames: list
    captures: list
    black: np.ndarray
    together: np.ndarray
    object_mask: np.ndarray
    probe_frames: list | None = None
    probe: np.ndarray | None = None

    @property
    def count(self) -> int:
        return len(self.maps)

    def together_frames(self) -> list[np.ndarray]:
        """The frames of the all-together capture: every projector at full white."""
        return [np.full((h, w, 3), 255, np.uint8) for w, h in self.sizes]


def _uint8(path) -> np.ndarray:
    return np.round(read_image(path) * 255).astype(np.uint8)


def load_multi_capture(folder, pairs: bool = True) -> MultiCaptureSet:
    """The capture set of several projectors in `folder` (a setup folder or its root); DatasetError when
    it is not one or is incomplete. pairs=False: without the alone frames and captures (a stylize with a
    saved joint model needs only the maps and the all-together capture)."""
    setup_dir = ds.resolve_setup(folder).setup_dir
    meta = ds.read_setup_json(setup_dir / ds.SETUP_JSON)
    entry = meta.get(MULTI_KEY)
    if not entry:
        raise ds.DatasetError(f"{setup_dir} is a capture of one projector, not of several")
    try:
        names = tuple(p["name"] for p in entry["projectors"])
        sizes = tuple(tuple(int(v) for v in p["size"]) for p in entry["projectors"])
        maps = load_camera_maps(setup_dir / CAMERA_MAPS)
        frames, captures = [], []
        if pairs:
            for k in range(len(names)):
                folder_k = projector_dir(setup_dir, k)
                frames.append(np.stack([_uint8(p) for p in ds.list_images(folder_k / "prj")]))
                captures.append(np.stack([_uint8(p) for p in ds.list_images(folder_k / "cam")]))
        black, together = _uint8(setup_dir / BLACK), _uint8(setup_dir / TOGETHER)
        mask = read_image(setup_dir / OBJECT_MASK)[..., 0] > 0.5
        probe_frames, probe = None, None
        frame_paths = [projector_dir(setup_dir, k) / BLEND_PROBE_FRAME for k in range(len(names))]
        if (setup_dir / BLEND_PROBE).is_file() and all(p.is_file() for p in frame_paths):
            probe_frames, probe = [_uint8(p) for p in frame_paths], _uint8(setup_dir / BLEND_PROBE)
    except (KeyError, TypeError, ValueError, OSError) as exc:
        raise ds.DatasetError(f"the capture of several projectors in {setup_dir} is incomplete: {exc}") from None
    if len(maps) != len(names):
        raise ds.DatasetError(f"{setup_dir} holds {len(maps)} camera maps for {len(names)} projectors")
    return MultiCaptureSet(setup_dir, meta, names, sizes, maps, frames, captures, black, together, mask,
                           probe_frames, probe)

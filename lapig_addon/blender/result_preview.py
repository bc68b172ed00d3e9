"""Show a stylization result on the object and on the projector, reversibly.

The projector light gets the compensated image as the light of the file Export writes (same
placement, same rounding at the scene's export bit depth), so Cycles renders the projection a real
projector would show; the object's material is switched between its original and a result image
cast from the projector (preview.py keeps the original safe).
"""
from __future__ import annotations

import os

import bpy
import numpy as np

from ...lapig_core.optics.projector_model import frame_from_working_image
from ...lapig_core.export.result_files import read_result_image
from . import preview, projector_nodes, storage
from .properties import projector_model

IMAGE_PREFIX = "LAPIG "
MODE_IMAGES = {"TARGET": "target", "SIMULATED": "simulated", "RENDERED": "rendered",
               "COMPENSABILITY": "compensability"}


def frame_image(name: str, pixels: np.ndarray, non_color: bool = True) -> bpy.types.Image:
    """A float image datablock (packed into the .blend when saved) holding a native-size frame."""
    h, w = pixels.shape[:2]
    image = bpy.data.images.get(name)
    if image is not None and tuple(image.size) != (w, h):
        bpy.data.images.remove(image)
        image = None
    if image is None:
        image = bpy.data.images.new(name, w, h, alpha=False, float_buffer=True)
    if non_color:
        image.colorspace_settings.name = "Non-Color"  # raw values: light for Cycles, colours for previews
    rgba = np.ones((h, w, 4), np.float32)
    rgba[..., :3] = pixels[::-1]  # Blender rows go bottom-up
    image.pixels.foreach_set(rgba.ravel())
    image.update()
    return image


def set_projector_image(projector, working_image: np.ndarray, bit_depth: int) -> bpy.types.Image:
    """Put a working-size projector image on the light, as the light it emits when sent as a
    bit_depth file (placement, rounding, gamma, black level)."""
    light = projector_model(projector).frame_light(working_image, bit_depth)
    image = frame_image(IMAGE_PREFIX + "projector image", light)
    projector_nodes.set_projected_image(projector.data, image)
    return image


def show_result_on_projector(scene) -> bpy.types.Image | None:
    """The light emits the scene's result projector image at the export bit depth; None without one."""
    s = scene.lapig
    folder = storage.resolve_result_dir(s.result_dir)
    if not folder or s.projector is None:
        return None
    return set_projector_image(s.projector, read_result_image(folder, "projector"), int(s.export_bit_depth))


def _appearance_image(scene, kind: str) -> bpy.types.Image:
    s = scene.lapig
    model = projector_model(s.projector)
    img = read_result_image(bpy.path.abspath(s.result_dir), kind)
    # appearances are in the same central-square layout as the projector image
    return frame_image(IMAGE_PREFIX + kind, frame_from_working_image(img, model.width, model.height))


def apply_mode(scene, mode: str, report=None) -> bool:
    """Switch the object's look; False (and a report) when the mode cannot be shown yet."""
    s = scene.lapig
    target, projector = s.target, s.projector
    if target is None or projector is None:
        return _fail(report, "Add the projector and camera first")
    try:
        if mode == "ORIGINAL":
            preview.disable_preview(target)
        elif mode == "PROJECTION":
            image = projector_nodes.projected_image(projector.data)
            preview.enable_preview(target, projector, image, appearance=False)
        else:
            if not s.result_dir or not os.path.isdir(bpy.path.abspath(s.result_dir)):
                return _fail(report, "Generate a projector image first")
            preview.enable_preview(target, projector, _appearance_image(scene, MODE_IMAGES[mode]), appearance=True)
    except (OSError, ValueError) as exc:
        return _fail(report, str(exc))
    return True


def _fail(report, message) -> bool:
    if report is not None:
        report({"ERROR"}, message)
    return False

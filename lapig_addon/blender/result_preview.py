"""Show a stylization result on the object and on the projector, reversibly.

The projector light gets the compensated image from result_sinks.ProjectorLightSink; here the object's
material is switched between its original and a result image cast from the projector (preview.py keeps
the original safe). A result of several projectors lives in the camera's frame: its images are cast from the
rig's camera, and Projection casts every projector's image at once.
"""
from __future__ import annotations

import os

import bpy
import numpy as np

from ...lapig_core.common.imageio import read_image, to_float
from ...lapig_core.common.resample import resize_image
from ...lapig_core.optics.projector_model import frame_from_working_image
from ...lapig_core.export.result_files import read_output_image
from ...lapig_core.multi.result_files import problem_areas
from ..services.panel.panel_state import preview_blocker
from ..services.state import JOINT
from . import preview, projector_nodes, scene_state
from .scene_state import projector_model

IMAGE_PREFIX = "LAPIG "
LIGHT_MAPS = {"LUX": "light_lux", "CONTRAST": "light_contrast"}  # blender/light_plan_run writes them
MODE_IMAGES = {"TARGET": "target", "SIMULATED": "simulated", "RENDERED": "rendered",
               "COMPENSABILITY": "compensability"}
# a result of several projectors (lapig_core/multi/result_files): its camera-space images by preview mode
JOINT_IMAGES = {"TARGET": "look", "SIMULATED": "predicted", "RENDERED": "rendered", **LIGHT_MAPS}
JOINT_MISSING = {"RENDERED": "Rendered: press Render Real Capture first"}


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


def _appearance_image(projector, result_dir: str, kind: str) -> bpy.types.Image:
    model = projector_model(projector)
    img = read_output_image(result_dir, kind)
    # appearances cover the whole frame, like the projector image
    return frame_image(IMAGE_PREFIX + kind, frame_from_working_image(img, model.width, model.height))


def _light_map(result_dir: str, name: str) -> np.ndarray:
    """The Light Report's map `name` of a result as drawn (display, sRGB colours; the callers make them linear
    after any resize, so the view transform shows them as drawn)."""
    path = os.path.join(result_dir, name + ".png")
    if not os.path.isfile(path):
        raise ValueError("no light maps for this result yet: press Light Report")
    return to_float(read_image(path))


def _light_map_image(projector, result_dir: str, name: str) -> bpy.types.Image:
    model = projector_model(projector)
    colours = np.power(resize_image(_light_map(result_dir, name), model.width, model.height), 2.2)
    return frame_image(IMAGE_PREFIX + name, colours)


def _joint_image(result_dir: str, mode: str) -> bpy.types.Image:
    """A result of several projectors' camera-space image of `mode` (its look, the joint model's capture, the
    rendered capture, the light maps of its Light Report; Problem areas: where their joint light falls short of
    the look), as an image at the camera's size."""
    if mode == "COMPENSABILITY":
        return frame_image(IMAGE_PREFIX + "camera problem areas", problem_areas(result_dir).astype(np.float32))
    name = JOINT_IMAGES[mode]
    if mode in LIGHT_MAPS:  # camera-space maps: made linear at their own size
        pixels = np.power(_light_map(result_dir, name), 2.2)
    else:
        path = os.path.join(result_dir, name + ".png")
        if not os.path.isfile(path):
            raise ValueError(JOINT_MISSING.get(mode, f"this result has no {name} image"))
        pixels = to_float(read_image(path))
    return frame_image(IMAGE_PREFIX + "camera " + name, np.ascontiguousarray(pixels[..., :3], dtype=np.float32))


def apply_mode(scene, mode: str, report=None) -> bool:
    """Switch the object's look; False (and a report) when the mode cannot be shown yet."""
    state = scene_state.read(scene)
    blocker = preview_blocker(state, mode)
    if blocker:
        return _fail(report, blocker)
    projector, camera, target = scene_state.rig_objects(scene)
    try:
        if mode == "ORIGINAL":
            preview.disable_preview(target)
        elif mode == "PROJECTION":  # every projector's light carries its own image: the surface shows their sum
            preview.enable_casts(target, [(p, projector_nodes.projected_image(p.data))
                                          for p in scene_state.rig_projectors(scene)])
        elif state.rig.strategy == JOINT:  # a joint result lives in the camera's frame: cast from the rig's camera
            preview.enable_preview(target, camera, _joint_image(state.result_dir, mode), appearance=True)
        elif mode in LIGHT_MAPS:  # the Light Report's maps cover the whole projector frame
            image = _light_map_image(projector, state.result_dir, LIGHT_MAPS[mode])
            preview.enable_preview(target, projector, image, appearance=True)
        else:
            image = _appearance_image(projector, state.result_dir, MODE_IMAGES[mode])
            preview.enable_preview(target, projector, image, appearance=True)
    except (OSError, ValueError) as exc:
        return _fail(report, str(exc))
    return True


def _fail(report, message) -> bool:
    if report is not None:
        report({"ERROR"}, message)
    return False

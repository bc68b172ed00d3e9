"""Blender's side of a real rig's live devices (rigs/camera_view, rigs/live_output).

- The camera view: the newest picture of the worker thread's camera goes into the image 'LAPIG camera
  view' a few times per second (a bpy.app.timers function; the grab itself never runs on Blender's
  thread). A camera that fails stops the view, and the report area and the panel say why.
- The live projector window: opened by a job (rigs/live_output.OpenWindowJob: its helper process starts on a
  worker thread) on the real rig's display with the scene's current result (the ProjectorFrame Export
  writes); while it is open every Generate shows its look there too (scene_seams adds it to the sinks). A
  timer watches it, so the panel follows an Esc in the window.
Both stop when another .blend is loaded, and when the add-on is disabled.
"""
from __future__ import annotations

import bpy
import numpy as np
from bpy.app.handlers import persistent

from ..rigs import camera_view, live_output
from ..services.state import JOINT
from . import scene_state
from .operator_boundary import refuse
from .timer_jobs import redraw

IMAGE_NAME = "LAPIG camera view"
CAMERA_PERIOD_S = 0.2  # five pictures a second
WINDOW_PERIOD_S = 0.5

_seen = {"frames": -1, "window_open": False}


def _real_spec(scene, what: str):
    spec = scene_state.real_rig_spec(scene)
    if spec is None:
        raise ValueError(f"{what} needs a real rig: set Rig to Real rig")
    return spec


def report(kind: str, message: str) -> None:
    """A report from a timer, which has no operator of its own: the report area and the Info log say it."""
    try:
        bpy.ops.lapig.report_message(kind=kind, message=message)
    except RuntimeError:  # background mode raises an ERROR report back; the console has it too
        pass
    print(f"LAPIG: {message}")


def rig_in_use(scene) -> str:
    """Why a job in the background may not open the real rig now ('' when it may): opening it would close the
    artist's projector window or camera view (real_rig lets go of them)."""
    if not scene_state.uses_real_rig(scene):
        return ""
    if camera_view_running():
        return "close the camera view"
    if live_output.open_sinks():
        return "close the projector window"
    return ""


# ------------------------------------------------------------------------------------ the camera view

def camera_view_running() -> bool:
    return camera_view.current_view() is not None


def camera_image(size=(64, 48)):
    """The view's image (made black at ``size`` if missing, so an Image Editor can show it at once)."""
    image = bpy.data.images.get(IMAGE_NAME)
    if image is None:
        image = bpy.data.images.new(IMAGE_NAME, size[0], size[1], alpha=False)
    return image


def start_camera_view(scene, camera_factory=None):
    """Open the scene's real camera on a worker thread and show it in the image; ValueError where the
    scene has no real camera chosen."""
    from ..rigs import real_rig

    # real_rig._camera looked up now, not at import: tests replace it
    view = camera_view.start_view(_real_spec(scene, "The camera view"), camera_factory or real_rig._camera)
    _seen["frames"] = -1
    if not bpy.app.timers.is_registered(refresh_camera_view):
        bpy.app.timers.register(refresh_camera_view, first_interval=CAMERA_PERIOD_S)
    camera_image()
    return view


def stop_camera_view(error: str = "") -> None:
    camera_view.stop_view(error, timeout_s=1.0)  # Blender's thread: a hung grab is not waited for
    if bpy.app.timers.is_registered(refresh_camera_view):
        bpy.app.timers.unregister(refresh_camera_view)


def write_image(pixels: np.ndarray):
    """Camera pixels (H, W, 3), uint8 or uint16 RGB top row first, into the view's image."""
    h, w = pixels.shape[:2]
    image = camera_image((w, h))
    if tuple(image.size) != (w, h):
        image.scale(w, h)
    rgba = np.ones((h, w, 4), np.float32)
    rgba[..., :3] = pixels[::-1] / np.float32(65535 if pixels.dtype == np.uint16 else 255)  # Blender: bottom row first
    image.pixels.foreach_set(rgba.ravel())
    image.update()
    return image


def refresh_camera_view():
    """The timer: the newest picture into the image; None (no more calls) once the view is over."""
    view = camera_view.current_view()
    if view is None:
        return None
    if view.error or not view.running:
        error = view.error or "the camera's thread ended"
        camera_view.stop_view(error)  # this timer ends by returning None
        report("ERROR", f"Camera view stopped: {error}")
        redraw(("VIEW_3D",))
        return None
    pixels, frames = view.latest()
    if pixels is not None and frames != _seen["frames"]:
        write_image(pixels)
        _seen["frames"] = frames
        redraw(("IMAGE_EDITOR", "VIEW_3D"))
    return CAMERA_PERIOD_S


# ------------------------------------------------------------------------------ the projector window

def projector_job(scene, window_factory=None) -> live_output.OpenWindowJob:
    """The job that opens the live projector window on the real rig's display with the scene's current result
    (the identification frame before there is one); ValueError where the scene has no display chosen. The
    scene is read here, on the main thread; the window opens on the job's worker thread."""
    spec = _real_spec(scene, "Show on Projector")
    refuse(spec.problem(camera=False))
    if window_factory is None:
        from ..rigs import real_rig

        def window_factory(display):  # the rig's hook, looked up when the window opens: tests replace it
            return real_rig._projector_window(display)
    rig = scene_state.read_rig(scene)
    if rig.strategy == JOINT:  # a joint result has an image per projector: every window at once, presenting together
        from ..services.panel.panel_state import projectors_blocker
        from ...lapig_core.multi.result_files import is_multi_result

        refuse(projectors_blocker(rig))
        folder = scene_state.read(scene).result_dir
        looks = live_output.StoredLooks(folder if folder and is_multi_result(folder) else "",
                                        scene_state.export_settings(scene).bit_depth)
        return live_output.OpenWindowsJob(rig.displays, looks, window_factory, names=list(rig.projectors))
    return live_output.OpenWindowJob(spec.display, stored_look(scene), window_factory)


def stored_look(scene) -> live_output.StoredLook:
    """The scene's result as the window shows it (what Export writes), or none."""
    folder = scene_state.read(scene).result_dir
    projector = scene_state.rig_objects(scene)[0]
    if not folder or projector is None:
        return live_output.StoredLook()
    model = scene_state.projector_model(projector)
    return live_output.StoredLook(folder, model.width, model.height, scene_state.export_settings(scene).bit_depth)


def projector_opened() -> None:
    """After the job: a timer watches the window, so the panel follows an Esc in it."""
    _seen["window_open"] = True
    if not bpy.app.timers.is_registered(watch_live_window):
        bpy.app.timers.register(watch_live_window, first_interval=WINDOW_PERIOD_S)


def close_projector(wait: bool = True) -> None:
    """wait=False (the panel's button): the window is forgotten now and its helper ends on a worker thread."""
    live_output.close_live(wait)
    _seen["window_open"] = False


def watch_live_window():
    """The timer: redraw the panel when the window closed (Esc); None once no window is open."""
    is_open = bool(live_output.open_sinks())
    if is_open != _seen["window_open"]:
        _seen["window_open"] = is_open
        redraw(("VIEW_3D",))
    return WINDOW_PERIOD_S if is_open else None


# ---------------------------------------------------------------------------------- file load, disable

def stop_all(wait: bool = True) -> None:
    """wait=False: the projector window's helper ends on a worker thread (another file loads meanwhile)."""
    stop_camera_view()
    close_projector(wait)
    if bpy.app.timers.is_registered(watch_live_window):
        bpy.app.timers.unregister(watch_live_window)


@persistent
def _on_load(*_args) -> None:
    stop_all(wait=False)


def register():
    if _on_load not in bpy.app.handlers.load_pre:
        bpy.app.handlers.load_pre.append(_on_load)


def unregister():
    if _on_load in bpy.app.handlers.load_pre:
        bpy.app.handlers.load_pre.remove(_on_load)
    stop_all()

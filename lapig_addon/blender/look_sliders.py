"""A world look's sliders in the UI: a change, once the slider rests, runs Update Look (operators/pipeline_ops
LAPIG_OT_edit_look: services/generate/look_edit.EditLookJob). A drag sends many changes: the timer starts again at each, so
the look is made once the hand stops, and waits while another job runs. Scripts, background mode and the bpy module
set the sliders and call bpy.ops.lapig.edit_look() themselves."""
import bpy

from . import scene_state, timer_jobs

SETTLE_S = 0.3  # seconds a slider rests before the look is made again
_PENDING = {"scene": ""}


def slider_changed(context) -> None:
    """The update of every look_<name> property."""
    scene = context.scene
    if not timer_jobs.in_ui(context) or not scene_state.look_sliders_shown(scene):
        return
    _PENDING["scene"] = scene.name
    if bpy.app.timers.is_registered(_apply):
        bpy.app.timers.unregister(_apply)
    bpy.app.timers.register(_apply, first_interval=SETTLE_S)


def _apply():
    from .modal_runner import active_job

    if active_job() is not None:  # a job runs (the last edit, a Generate): try again when it is done
        return SETTLE_S
    scene = bpy.data.scenes.get(_PENDING["scene"])
    wm = bpy.context.window_manager
    window = next(iter(wm.windows), None) if wm else None
    if scene is None or window is None or not scene_state.look_sliders_shown(scene):
        return None
    with bpy.context.temp_override(window=window, scene=scene):
        bpy.ops.lapig.edit_look("INVOKE_DEFAULT")
    return None


def register() -> None:
    pass  # the sliders' timer starts at their first change


def unregister() -> None:
    if bpy.app.timers.is_registered(_apply):
        bpy.app.timers.unregister(_apply)

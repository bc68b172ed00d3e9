"""A background job driven from bpy.app.timers, as the preferences' Install torch and model downloads are: the
timer steps the job (so it outlives the preferences window and never blocks the UI) and redraws the areas
that show its progress; a script, background mode and the bpy module run the job to its end instead."""
import bpy

STEP_S = 0.1  # seconds between the timer's steps


def in_ui(context) -> bool:
    """Whether a window is there to keep drawing while the job runs (else it runs to its end at once)."""
    return not bpy.app.background and getattr(context, "window", None) is not None


def redraw(area_types) -> None:
    """Tag every area of these types in every window for a redraw."""
    wm = bpy.context.window_manager
    for window in (wm.windows if wm else []):
        for area in (window.screen.areas if window.screen else []):
            if area.type in area_types:
                area.tag_redraw()


def timer_step(slot, ended, area_types):
    """A bpy.app.timers function: one step of slot.job, the areas redrawn, ended(job) once it has finished;
    it returns STEP_S to be called again, None to end the timer."""
    def step():
        job = slot.job
        if job is None:
            return None
        if not job.finished:
            job.step()
        redraw(area_types)
        if job.finished:
            ended(job)
            return None
        return STEP_S
    return step


def start(operator, slot, job, step, ui: bool, started: str):
    """Start `job` in `slot`: refused, the refusal is reported ({'CANCELLED'}); in Blender's UI (`ui`) the `step`
    timer drives it and the operator says `started` ({'FINISHED'}); else None, and the caller runs it to its end."""
    refusal = slot.start(job)
    if refusal:
        operator.report({"ERROR"}, refusal)
        return {"CANCELLED"}
    if ui:
        job.poll_timeout = 0  # the UI thread never waits for the worker
        bpy.app.timers.register(step, first_interval=STEP_S)
        operator.report({"INFO"}, started)
        return {"FINISHED"}
    return None


def stop(slot, step) -> None:
    """The add-on goes: the running job stopped (nothing may go on writing into its folder) and its timer off."""
    if slot.running():
        slot.job.stop()
        slot.ended(slot.job)
    if bpy.app.timers.is_registered(step):
        bpy.app.timers.unregister(step)

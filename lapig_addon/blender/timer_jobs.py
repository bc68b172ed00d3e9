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

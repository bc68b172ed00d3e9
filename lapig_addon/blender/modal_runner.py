"""Drive a Job from Blender's UI: a timer steps it, Esc cancels, progress shows in the status bar.

Inside the bpy module and in background mode modal operators cannot run, so the same job is
run to completion synchronously there (see jobs.Job).

Two slots (services/background_jobs.JobSlots): one foreground job (JobRunnerMixin: Esc cancels it) and
one background job (BackgroundJobRunner: Train after a Capture; its own timer, its events passed through,
the panel's Cancel). A foreground job pauses the background one and steps once it has paused.
"""
from __future__ import annotations

import bpy
from bpy.app.handlers import persistent

from ..services.background_jobs import WAITING_FOR_PAUSE, JobSlots, outcome_line
from . import scene_state, warm_start
from .operator_boundary import ReportsErrors, report_failure

SLOTS = JobSlots()


def active_job():
    return SLOTS.foreground


def cancel_background() -> bool:
    """Cancel the background job (the panel's Cancel, a new Capture, an imported one); True when one ran."""
    return SLOTS.cancel_background()


@persistent
def _on_load(*_args) -> None:
    """Another file: the background job worked for this one's scene."""
    cancel_background()


def register():
    if _on_load not in bpy.app.handlers.load_pre:
        bpy.app.handlers.load_pre.append(_on_load)


def unregister():
    if _on_load in bpy.app.handlers.load_pre:
        bpy.app.handlers.load_pre.remove(_on_load)
    cancel_background()


def can_run_modal(context) -> bool:
    return not bpy.app.background and context.window_manager is not None and context.window is not None


def _redraw_viewports(context):
    for area in (context.screen.areas if context.screen else []):
        if area.type == "VIEW_3D":
            area.tag_redraw()


class JobRunnerMixin(ReportsErrors):
    """Mix into an Operator; implement make_job(context) and on_done(context, job).

    replaces_models: the job replaces the capture or the models (Capture, Train), so a background job
    working on them is cancelled first."""

    replaces_models = False
    ran_modal = False  # on_done: the job ran in Blender's UI (not a script, not background mode)
    _timer = None
    _job = None

    def make_job(self, context):
        raise NotImplementedError

    def on_done(self, context, job):
        pass

    @classmethod
    def waits_for(cls, context) -> str:
        """Why the panel has turned this button off, besides a running job ('' when it has not): its tooltip
        says it (an operator whose refusal scripts read keeps it out of poll)."""
        return ""

    @classmethod
    def description(cls, context, properties):
        """The tooltip: the operator's own, and while a foreground job runs (the panels turn the job buttons
        off) why: JobSlots queues no second job; or why else the button is off (waits_for)."""
        text = getattr(cls, "bl_description", "") or " ".join((cls.__doc__ or "").split())
        note = SLOTS.busy_note() or cls.waits_for(context)
        return f"{text}.\n{note}" if note else text

    def _give_way(self):
        """Before the job starts: the background job is cancelled (it works on what this replaces) or paused."""
        if self.replaces_models:
            SLOTS.cancel_background()

    def execute(self, context):  # synchronous: scripts, tests, background mode
        job = self.make_job(context)
        scene = context.scene
        self._give_way()
        if not SLOTS.pause_background_until_paused():
            self.report({"ERROR"}, "The training in the background did not pause: cancel it in the Models panel")
            return {"CANCELLED"}
        try:
            job.run(on_progress=lambda progress, message: scene_state.record_job_progress(scene, progress, message))
        finally:
            SLOTS.resume_background()
        return self._finish(context, job)

    def invoke(self, context, event):
        if not can_run_modal(context):
            return self.execute(context)
        warm_start.on_first_use()  # the text and style models load in the background meanwhile
        if SLOTS.foreground_running():
            self.report({"ERROR"}, "Another LAPIG job is running: wait for it or press Esc")
            return {"CANCELLED"}
        self._job = self.make_job(context)
        self._job.poll_timeout = 0  # a worker job must never make the UI thread wait
        self._give_way()
        refusal = SLOTS.start_foreground(self._job)  # pauses the background job
        if refusal:
            self.report({"ERROR"}, refusal)
            return {"CANCELLED"}
        self.ran_modal = True
        wm = context.window_manager
        self._timer = wm.event_timer_add(0.05, window=context.window)
        wm.modal_handler_add(self)
        wm.progress_begin(0, 1000)
        return {"RUNNING_MODAL"}

    def modal(self, context, event):
        try:
            return self._modal(context, event)
        except Exception as exc:  # the UI itself failed (not the job: its failures end in _finish)
            self._job.cancel()
            self._end_modal(context)
            return report_failure(self, exc)

    def _modal(self, context, event):
        job = self._job
        if event.type == "ESC":
            job.cancel()
        elif event.type == "TIMER":
            if SLOTS.foreground_may_step():  # the background job has paused: the cores are this job's
                job.step()
                message = job.message
            else:  # the slots say so in the job's message (or why the wait failed)
                message = job.message or WAITING_FOR_PAUSE
            scene_state.record_job_progress(context.scene, job.progress, message)
            context.window_manager.progress_update(int(job.progress * 1000))
            context.workspace.status_text_set(f"{job.title}: {message} ({job.progress:.0%}) - Esc to cancel")
            _redraw_viewports(context)
        if not job.finished:
            return {"RUNNING_MODAL"}
        self._end_modal(context)
        return self._finish(context, job)

    def _end_modal(self, context):
        if self._timer is None:  # ended already (on_done failed after it)
            return
        wm = context.window_manager
        wm.event_timer_remove(self._timer)
        self._timer = None
        wm.progress_end()
        context.workspace.status_text_set(None)
        SLOTS.end_foreground(self._job)  # the background job goes on

    def _finish(self, context, job):
        if job.state == "DONE":
            self.on_done(context, job)
            return {"FINISHED"}
        if job.state == "CANCELLED":
            self.report({"WARNING"}, f"{job.title} cancelled: the scene is as it was")
            return {"CANCELLED"}
        return report_failure(self, job.error, prefix=f"{job.title} failed: ")


class BackgroundJobRunner(ReportsErrors):
    """Mix into an Operator started with INVOKE_DEFAULT; implement make_job(context) and on_done(context, job).

    The job runs in the background slot: its own timer steps it, every event passes through (Esc stays the
    foreground job's), a foreground job pauses it, and the panel shows its progress and its Cancel."""

    _timer = None
    _job = None

    def make_job(self, context):
        raise NotImplementedError

    def on_done(self, context, job):
        pass

    def refresh(self, context, job):
        """Before each step: what the job reads of Blender, anew (the artist works meanwhile)."""

    def invoke(self, context, event):
        if not can_run_modal(context):
            return {"CANCELLED"}  # a background job exists only in Blender's UI
        if SLOTS.background_running():
            return {"CANCELLED"}  # one at a time: the one running goes on
        self._job = self.make_job(context)
        if self._job is None:
            return {"CANCELLED"}
        self._job.poll_timeout = 0  # never make the UI thread wait
        SLOTS.start_background(self._job)
        wm = context.window_manager
        self._timer = wm.event_timer_add(0.1, window=context.window)
        wm.modal_handler_add(self)
        return {"RUNNING_MODAL"}

    def modal(self, context, event):
        job = self._job
        try:
            if event.type == "TIMER" and not job.finished:
                self.refresh(context, job)
                SLOTS.step_background()
                _redraw_viewports(context)
        except Exception as exc:  # the UI itself failed (not the job: its failures end below)
            job.cancel()
            self._end(context)
            return report_failure(self, exc)
        if not job.finished:
            return {"PASS_THROUGH"}
        self._end(context)
        if job.state == "DONE":
            self.on_done(context, job)
            return {"FINISHED"}
        if job.state == "CANCELLED":  # by what replaced the capture, or the panel's Cancel, which said so
            return {"CANCELLED"}
        return report_failure(self, job.error, prefix=f"{job.title} in the background failed: ")

    def cancel(self, context):  # Blender ends the operator (a file loaded, its window closed): stop cleanly
        try:
            if self._job is not None:
                self._job.stop()
                self._end(context)
        except Exception as exc:  # never a traceback; the console says what went wrong
            print(f"LAPIG: stopping the training in the background: {exc}")

    def _end(self, context):
        if self._timer is None:
            return
        context.window_manager.event_timer_remove(self._timer)
        self._timer = None
        SLOTS.end_background(self._job, outcome_line(self._job))
        _redraw_viewports(context)

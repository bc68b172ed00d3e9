"""Drive a Job from Blender's UI: a timer steps it, Esc cancels, progress shows in the status bar.

Inside the bpy module and in background mode modal operators cannot run, so the same job is
run to completion synchronously there (see jobs.Job).
"""
from __future__ import annotations

import bpy

from . import scene_state, warm_start
from .operator_boundary import ReportsErrors, report_failure

_active = {"job": None}


def active_job():
    return _active["job"]


def can_run_modal(context) -> bool:
    return not bpy.app.background and context.window_manager is not None and context.window is not None


class JobRunnerMixin(ReportsErrors):
    """Mix into an Operator; implement make_job(context) and on_done(context, job)."""

    _timer = None
    _job = None

    def make_job(self, context):
        raise NotImplementedError

    def on_done(self, context, job):
        pass

    def execute(self, context):  # synchronous: scripts, tests, background mode
        job = self.make_job(context)
        scene = context.scene
        job.run(on_progress=lambda progress, message: scene_state.record_job_progress(scene, progress, message))
        return self._finish(context, job)

    def invoke(self, context, event):
        if not can_run_modal(context):
            return self.execute(context)
        warm_start.on_first_use()  # the text and style models load in the background meanwhile
        if _active["job"] is not None and not _active["job"].finished:
            self.report({"ERROR"}, "Another LAPIG job is running: wait for it or press Esc")
            return {"CANCELLED"}
        self._job = self.make_job(context)
        self._job.poll_timeout = 0  # a worker job must never make the UI thread wait
        _active["job"] = self._job
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
            job.step()
            scene_state.record_job_progress(context.scene, job.progress, job.message)
            context.window_manager.progress_update(int(job.progress * 1000))
            context.workspace.status_text_set(f"{job.title}: {job.message} ({job.progress:.0%}) - Esc to cancel")
            for area in context.screen.areas:
                if area.type == "VIEW_3D":
                    area.tag_redraw()
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
        _active["job"] = None

    def _finish(self, context, job):
        if job.state == "DONE":
            self.on_done(context, job)
            return {"FINISHED"}
        if job.state == "CANCELLED":
            self.report({"WARNING"}, f"{job.title} cancelled: the scene is as it was")
            return {"CANCELLED"}
        return report_failure(self, job.error, prefix=f"{job.title} failed: ")

# SPDX-License-Identifier: GPL-3.0-or-later
"""The preferences' Install torch buttons: they start services/install/torch_install's job in the session's install slot.

In Blender's UI a bpy.app.timers function steps the job (it outlives the preferences window, and LAPIG's own
jobs go on meanwhile: Capture needs no torch); a script, background mode and the bpy module run it to the end
in execute(), as JobRunnerMixin does.
"""
from __future__ import annotations

import sys

import bpy

from ..services.install import torch_builds, torch_install
from ..services.install.torch_install import SLOT, TorchInstallJob
from .operator_boundary import ReportsErrors

from . import timer_jobs
from .timer_jobs import in_ui, redraw, timer_step


def target_folder() -> str:
    """The user's scripts/modules folder: where torch goes (services/install/torch_install says why)."""
    return bpy.utils.user_resource("SCRIPTS", path="modules", create=True)


def online_access() -> bool:
    return bool(getattr(bpy.app, "online_access", True))  # Blender 4.2 and later have the setting


def overridden() -> bool:
    return bool(getattr(bpy.app, "online_access_override", False))  # --offline-mode on the command line


def online_refusal() -> str:
    """Why Install torch may not download now ('' when it may)."""
    return torch_install.online_refusal(online_access(), overridden=overridden())


_in_ui = in_ui
SHOWN_IN = {"PREFERENCES", "VIEW_3D"}  # the preferences' progress bar; the sidebar's buttons (Train turns on)


def _redraw():
    redraw(SHOWN_IN)


_step = timer_step(SLOT, lambda job: _ended(job), SHOWN_IN)  # bpy.app.timers: one step of the install


def _ended(job):
    SLOT.ended(job)
    said = job.result.line() if job.state == "DONE" else SLOT.failure
    print(f"LAPIG: {said}")  # the preferences say it too; the console keeps it


def _start(operator, context, plan) -> set:
    job = TorchInstallJob(plan)
    started = timer_jobs.start(operator, SLOT, job, _step, _in_ui(context),
                               f"Installing torch ({plan.label}): the add-on preferences show its progress")
    if started:
        return started
    job.run()  # a script, background mode, the bpy module: to the end here
    _ended(job)
    if job.state == "DONE":
        operator.report({"INFO"}, job.result.line())
        return {"FINISHED"}
    operator.report({"ERROR"}, SLOT.failure)
    return {"CANCELLED"}


class LAPIG_OT_install_torch(ReportsErrors, bpy.types.Operator):
    """Download torch (the build chosen beside the button) into Blender's Python, in the background"""
    bl_idname = "lapig.install_torch"
    bl_label = "Install torch"

    build: bpy.props.StringProperty(name="Build", default="",
                                    description="CPU, CUDA128, CUDA130, ROCM or MAC (empty: the preferences' choice)")

    @classmethod
    def description(cls, context, properties):
        text = "Download torch (the build chosen beside the button) into Blender's Python, in the background"
        refusal = online_refusal()
        return f"{text}.\n{refusal}" if refusal else text

    def execute(self, context):
        refusal = online_refusal()
        if refusal:
            self.report({"ERROR"}, refusal)
            return {"CANCELLED"}
        unsupported = torch_builds.unsupported_reason()
        if unsupported:
            self.report({"ERROR"}, unsupported)
            return {"CANCELLED"}
        chosen = torch_builds.build(self.build or chosen_build(context))
        return _start(self, context, torch_install.plan_from_index(sys.executable, target_folder(), chosen))


class LAPIG_OT_install_torch_wheel(ReportsErrors, bpy.types.Operator):
    """Install torch from a wheel file on disk, without going online (its dependencies' wheels beside it)"""
    bl_idname = "lapig.install_torch_wheel"
    bl_label = "Install from a Wheel File"

    filepath: bpy.props.StringProperty(subtype="FILE_PATH")
    filter_glob: bpy.props.StringProperty(default="*.whl", options={"HIDDEN"})

    def invoke(self, context, event):
        context.window_manager.fileselect_add(self)
        return {"RUNNING_MODAL"}

    def execute(self, context):
        plan = torch_install.plan_from_wheel(sys.executable, target_folder(), bpy.path.abspath(self.filepath))
        return _start(self, context, plan)


class LAPIG_OT_cancel_torch_install(ReportsErrors, bpy.types.Operator):
    """Stop installing torch: pip stops, and nothing it downloaded is kept"""
    bl_idname = "lapig.cancel_torch_install"
    bl_label = "Cancel"

    def execute(self, context):
        if SLOT.cancel():
            self.report({"WARNING"}, "Installing torch was cancelled: nothing was changed")
        _redraw()
        return {"FINISHED"}


def chosen_build(context) -> str:
    """The preferences' build (the default for this computer where the add-on is not enabled, as in bpy)."""
    from .preferences_access import addon_preferences

    prefs = addon_preferences(context)
    if prefs is not None and prefs.torch_build:
        return prefs.torch_build
    from ...lapig_core.common.gpu_torch import nvidia_gpu_present

    return torch_builds.default_build(sys.platform, nvidia_gpu_present())


CLASSES = (LAPIG_OT_install_torch, LAPIG_OT_install_torch_wheel, LAPIG_OT_cancel_torch_install)
_register, _unregister = bpy.utils.register_classes_factory(CLASSES)


def register():
    _register()
    torch_install.remove_leftovers(bpy.utils.user_resource("SCRIPTS", path="modules", create=False))


def unregister():
    timer_jobs.stop(SLOT, _step)  # pip must not go on writing into the target
    _unregister()

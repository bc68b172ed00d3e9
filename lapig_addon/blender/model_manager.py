# SPDX-License-Identifier: GPL-3.0-or-later
"""The preferences' model manager: Download, Cancel, Use Folder and Remove for each diffusion model, and its box.

The download is services/install/model_download's job in its slot, stepped by a bpy.app.timers function in Blender's UI
(as Install torch: it outlives the preferences window); a script, background mode and the bpy module run it to
the end in execute(). It goes online only where Blender allows it (bpy.app.online_access).
"""
from __future__ import annotations

import os

import bpy

from ...lapig_core.diffusion import catalogue, fetch
from ..services.install import model_download
from ..services.install.model_download import DOWNLOADS, DownloadRequest, ModelDownloadJob
from . import torch_installer
from .operator_boundary import AsksForFolder, ReportsErrors

from . import timer_jobs
from .timer_jobs import in_ui, redraw, timer_step
ICONS = {"absent": "IMPORT", "downloading": "SORTTIME", "ready": "CHECKMARK", "damaged": "ERROR"}


def online_access() -> bool:
    return torch_installer.online_access()  # one reading of Blender's setting for both boxes


def models_root(prefs=None) -> str:
    """The models folder: the preference, else LAPIG's folder in Blender's user data (it survives updates)."""
    chosen = bpy.path.abspath(prefs.models_folder) if prefs is not None and prefs.models_folder else ""
    return chosen or bpy.utils.user_resource("DATAFILES", path=os.path.join("lapig", "models"), create=False)


OWN_FOLDER_PREFERENCE = {"instruct-pix2pix": "ip2p_model", "sd-turbo": "turbo_model", "depth-adapter": "depth_model"}


def own_folder(prefs, key: str) -> str:
    """The user's folder for that model (Use Folder), '' where none is chosen."""
    if prefs is None:
        return ""
    value = getattr(prefs, OWN_FOLDER_PREFERENCE[key], "")
    return bpy.path.abspath(value) if value else ""


def _set_own_folder(prefs, key: str, folder: str):
    setattr(prefs, OWN_FOLDER_PREFERENCE[key], folder)


def _prefs(context):
    from .preferences_access import addon_preferences

    return addon_preferences(context)


def _redraw():
    redraw({"PREFERENCES"})


_step = timer_step(DOWNLOADS, lambda job: _ended(job), {"PREFERENCES"})  # bpy.app.timers: one step of the download


def _ended(job):
    DOWNLOADS.ended(job)
    print(f"LAPIG: {DOWNLOADS.said[job.request.key][1]}")


_in_ui = in_ui


class LAPIG_OT_download_model(ReportsErrors, bpy.types.Operator):
    """Download this model into the models folder, in the background: every file checked against the
    repository's hashes; a cancelled download resumes where it stopped"""
    bl_idname = "lapig.download_model"
    bl_label = "Download"

    model: bpy.props.StringProperty(name="Model",
                                    description="The catalogue's key (instruct-pix2pix, sd-turbo, depth-adapter)")

    @classmethod
    def description(cls, context, properties):
        text = cls.__doc__.replace("\n    ", " ")
        refusal = fetch.online_refusal(online_access(), torch_installer.overridden())
        return f"{text}.\n{refusal}" if refusal else text

    def execute(self, context):
        prefs = _prefs(context)
        request = DownloadRequest(self.model, models_root(prefs), online_access(),
                                  base=prefs.hub_endpoint if prefs else "", token=prefs.hub_token if prefs else "",
                                  overridden=torch_installer.overridden(), device=prefs.device.lower() if prefs else "auto")
        job = ModelDownloadJob(request)  # an unknown model: ModelError, reported by ReportsErrors
        started = timer_jobs.start(self, DOWNLOADS, job, _step, _in_ui(context),
                                   f"Downloading {job.entry.title}: the add-on preferences show its progress")
        if started:
            return started
        job.run()
        _ended(job)
        kind, line = DOWNLOADS.said[self.model]
        self.report({"INFO"} if kind == "DONE" else {"ERROR"}, line)
        return {"FINISHED"} if kind == "DONE" else {"CANCELLED"}


class LAPIG_OT_cancel_model_download(ReportsErrors, bpy.types.Operator):
    """Stop the download: what is downloaded stays aside (never used half-way), and Download resumes it"""
    bl_idname = "lapig.cancel_model_download"
    bl_label = "Cancel"

    def execute(self, context):
        if DOWNLOADS.cancel():
            self.report({"WARNING"}, "The download was cancelled: Download resumes it")
        _redraw()
        return {"FINISHED"}


class LAPIG_OT_use_model_folder(AsksForFolder, bpy.types.Operator):
    """Use a folder of this model you already have (a diffusers pipeline: model_index.json, unet/, vae/, ...; the
    depth adapter: config.json and its weights), for computers that stay offline"""
    bl_idname = "lapig.use_model_folder"
    bl_label = "Use Folder"

    model: bpy.props.StringProperty(name="Model")

    def execute(self, context):
        folder = model_download.use_folder(self.model, bpy.path.abspath(self.directory))  # ModelError: one line
        prefs = _prefs(context)
        if prefs is None:
            self.report({"ERROR"}, "the add-on is not enabled: its preferences cannot keep the folder")
            return {"CANCELLED"}
        _set_own_folder(prefs, self.model, folder)
        self.report({"INFO"}, f"{catalogue.model(self.model).title} from {folder}")
        return {"FINISHED"}


class LAPIG_OT_remove_model(ReportsErrors, bpy.types.Operator):
    """Delete the downloaded model (or forget your own folder: its files stay)"""
    bl_idname = "lapig.remove_model"
    bl_label = "Remove"

    model: bpy.props.StringProperty(name="Model")

    def execute(self, context):
        prefs = _prefs(context)
        if own_folder(prefs, self.model):
            _set_own_folder(prefs, self.model, "")
            title = catalogue.model(self.model).title
            self.report({"INFO"}, f"{title}: your folder is no longer used (its files stay)")
            return {"FINISHED"}
        self.report({"INFO"}, model_download.remove(self.model, models_root(prefs)))
        return {"FINISHED"}


def device_line() -> str:
    """Where the diffusion models would run, in which precision; where torch cannot use this computer's GPU,
    which torch to install (the torch box above)."""
    import sys

    from ...lapig_core.common.gpu_torch import installed_torch, nvidia_gpu_present

    build = installed_torch()  # read from its files: no import of torch
    if not build.present:
        return "Diffusion needs torch: install it in the torch box above (a CUDA build for an NVIDIA GPU)"
    if nvidia_gpu_present() and not build.cuda:
        return (f"Diffusion would run on the CPU ({build.line()}): this computer has an NVIDIA GPU; install a "
                f"CUDA build in the torch box above to run it there in half precision")
    if "torch" not in sys.modules:  # importing it here would stall the preferences' first draw for seconds
        return ("Diffusion runs on CUDA, Apple's MPS or the CPU, picked when a model loads (half precision on a "
                "GPU); a model that does not fit there is refused with what it needs")
    from ...lapig_core.common import compute_device
    from ...lapig_core.diffusion.device_fit import half_precision
    from .preferences_access import compute_device as chosen

    device = compute_device.resolve(chosen())
    precision = "half precision (float16)" if half_precision(device.type) else "float32"
    return f"Diffusion runs on {compute_device.short_name(device)} in {precision}"


def draw_models(layout, prefs, fit, wrapped):
    """The model manager's box: the folder, the hub and token, each model's row with its buttons."""
    box = layout.box()
    fit = fit.boxed()
    box.label(text="Diffusion models (optional: the procedural and neural looks need none)", icon="IMAGE_DATA")
    wrapped(box, fit, device_line(), "NONE")
    col = box.column(align=True)
    col.prop(prefs, "models_folder")
    col.prop(prefs, "hub_endpoint")
    col.prop(prefs, "hub_token")
    online = online_access()
    if not online:
        wrapped(box, fit, fetch.online_refusal(False, torch_installer.overridden()), "INTERNET_OFFLINE")
    root = models_root(prefs)
    for entry in catalogue.CATALOGUE:
        row_state = model_download.model_row(entry.key, root, own_folder(prefs, entry.key))
        sub = box.box()
        sub.label(text=f"{entry.title} ({entry.repo_id})", icon=ICONS.get(row_state.state, "NONE"))
        wrapped(sub, fit, f"Licence: {entry.licence}", "NONE")
        if row_state.state == "downloading":
            line = sub.row(align=True)
            line.progress(factor=row_state.progress, text=f"{row_state.line[:60]} ({row_state.progress:.0%})")
            line.operator(LAPIG_OT_cancel_model_download.bl_idname, icon="CANCEL")
            continue
        wrapped(sub, fit, row_state.line, "NONE")
        said = DOWNLOADS.said.get(entry.key)
        if said and said[0] != "DONE":
            wrapped(sub, fit, said[1], "ERROR" if said[0] == "FAILED" else "INFO")
        buttons = sub.row(align=True)
        get = buttons.row(align=True)
        get.enabled = online and not DOWNLOADS.running()
        get.operator(LAPIG_OT_download_model.bl_idname, icon="IMPORT",
                     text="Download" if row_state.state != "ready" else "Download Again").model = entry.key
        buttons.operator(LAPIG_OT_use_model_folder.bl_idname, icon="FILEBROWSER").model = entry.key
        gone = buttons.row(align=True)
        gone.enabled = row_state.state in ("ready", "damaged") or "stopped after" in row_state.line
        gone.operator(LAPIG_OT_remove_model.bl_idname, icon="TRASH").model = entry.key
    wrapped(box, fit, "docs/diffusion-models.md: the models, their licences, the offline route", "HELP")


CLASSES = (LAPIG_OT_download_model, LAPIG_OT_cancel_model_download, LAPIG_OT_use_model_folder, LAPIG_OT_remove_model)
_register, _unregister = bpy.utils.register_classes_factory(CLASSES)


def register():
    _register()


def unregister():
    timer_jobs.stop(DOWNLOADS, _step)  # nothing may go on writing into the models folder
    _unregister()

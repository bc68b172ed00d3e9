"""Add-on preferences: where torch runs, which dependencies are present, and how to install the missing ones
(and PyTorch's CUDA build where an NVIDIA GPU has none to use it)."""
from __future__ import annotations

import sys

import bpy

from ...lapig_core.common.deps import INSTALL_DOC, check_dependencies, install_command
from ...lapig_core.common.gpu_torch import gpu_advice, installed_torch, nvidia_gpu_present
from ..services.install import torch_builds
from ..services.panel.bundle_status import bundle_lines, read_bundle
from ..services.install.torch_install import SLOT as TORCH_INSTALL
from . import model_manager, torch_installer, ui_text
from .preferences_access import addon_package as _addon_package
from .preferences_access import addon_preferences
from .preferences_access import compute_device  # noqa: F401 (scene_state reads it from here)
from .operator_boundary import ReportsErrors


class LAPIG_OT_copy_install_command(ReportsErrors, bpy.types.Operator):
    """Copy the pip command that installs LAPIG's missing dependencies"""
    bl_idname = "lapig.copy_install_command"
    bl_label = "Copy install command"

    def execute(self, context):
        context.window_manager.clipboard = install_command(sys.executable, _modules_folder())
        self.report({"INFO"}, "Install command copied to the clipboard")
        return {"FINISHED"}


def _modules_folder() -> str:
    return bpy.utils.user_resource("SCRIPTS", path="modules", create=False)


def _gpu_advice():
    return gpu_advice(installed_torch(), nvidia_gpu_present(), sys.executable, _modules_folder())


class LAPIG_OT_copy_cuda_command(ReportsErrors, bpy.types.Operator):
    """Copy the pip command that installs PyTorch's CUDA build into Blender's Python"""
    bl_idname = "lapig.copy_cuda_command"
    bl_label = "Copy CUDA install command"

    def execute(self, context):
        context.window_manager.clipboard = _gpu_advice().command
        self.report({"INFO"}, "CUDA install command copied to the clipboard")
        return {"FINISHED"}


class LAPIG_AP_preferences(bpy.types.AddonPreferences):
    bl_idname = _addon_package()

    ip2p_model: bpy.props.StringProperty(
        name="InstructPix2Pix weights", subtype="DIR_PATH",
        description="Folder with the InstructPix2Pix weights for the 'instruct-pix2pix' backend "
                    "(empty: the model manager's download, else the public checkpoint in the Hugging Face cache)")
    turbo_model: bpy.props.StringProperty(
        name="SD-Turbo weights", subtype="DIR_PATH",
        description="Folder with the one-step model's weights (empty: the model manager's download)")
    depth_model: bpy.props.StringProperty(
        name="Depth adapter weights", subtype="DIR_PATH",
        description="Folder with the depth adapter (T2I-Adapter depth, SD 1.5) that makes InstructPix2Pix follow the "
                    "object's shape (empty: the model manager's download)")
    models_folder: bpy.props.StringProperty(
        name="Models folder", subtype="DIR_PATH",
        description="Where Download puts the diffusion models (empty: LAPIG's folder in Blender's user data)")
    hub_endpoint: bpy.props.StringProperty(
        name="Model hub", default="",
        description="The Hugging Face hub's address, or a mirror's (empty: HF_ENDPOINT, else https://huggingface.co)")
    hub_token: bpy.props.StringProperty(
        name="Hub token", subtype="PASSWORD", default="",
        description="A Hugging Face read token, for gated models (optional; sent to the model hub only)")
    device: bpy.props.EnumProperty(
        name="Device", default="AUTO",
        items=[("AUTO", "Auto", "A GPU where torch can use one (CUDA, then Apple's MPS), else the CPU"),
               ("CPU", "CPU", "Always the CPU (e.g. to leave the GPU to Cycles)")],
        description="Where Train, PSA, the style networks and the native output run")
    ffmpeg_path: bpy.props.StringProperty(
        name="FFmpeg", subtype="FILE_PATH",
        description="A system ffmpeg for the video codecs the bundled PyAV lacks (HAP, HAP Alpha, HAP Q); empty: "
                    "the ffmpeg on PATH")

    torch_build: bpy.props.EnumProperty(
        name="torch build", items=[(b.key, b.label, f"{b.description} ({b.size_note})")
                                   for b in torch_builds.builds_for(sys.platform)] or [("CPU", "CPU", "")],
        default=torch_builds.default_build(sys.platform, nvidia_gpu_present()),
        description="Which torch Install torch downloads: CPU runs everywhere, a GPU build needs that GPU's driver")

    def draw(self, context):
        layout = self.layout
        fit = ui_text.fit_for(context)
        layout.prop(self, "device")
        layout.prop(self, "ffmpeg_path")
        col = layout.column(align=True)
        for line in bundle_lines(read_bundle()):  # what the zip lacks: its next step may be the torch box below
            _wrapped(col, fit, line.text, line.icon)
        _draw_torch(layout, self, fit)
        model_manager.draw_models(layout, self, fit, _wrapped)
        col = layout.column(align=True)
        col.label(text="Python dependencies:")
        deps = check_dependencies()
        for dep in deps:
            row = col.row()
            icon = "CHECKMARK" if dep.present else ("ERROR" if dep.required else "INFO")
            state = "found" if dep.present else ("missing" if dep.required else "optional, not found")
            row.label(text=f"{dep.package}: {state}", icon=icon)
        if any(d.required and not d.present for d in deps):
            box = layout.box()
            box.label(text="By hand: this command installs the missing packages; then restart Blender")
            box.label(text=install_command(sys.executable, _modules_folder()))
            box.operator(LAPIG_OT_copy_install_command.bl_idname, icon="COPYDOWN")
            box.label(text=f"{INSTALL_DOC} explains each step.")


def _wrapped(layout, fit, text: str, icon: str = "NONE"):
    """A line wrapped at the preferences' width (labels do not wrap), its next lines indented."""
    for i, part in enumerate(fit.wrap(text, icon=True, first_icon=icon != "NONE")):
        layout.label(text=part, icon=icon if i == 0 else "BLANK1")


def torch_icon(build, gpu_present: bool) -> str:
    """The torch line's icon: a check mark only for a torch that is there and can use this computer's GPU
    (or has none to use); an error for none."""
    if not build.present:
        return "ERROR"
    return "CHECKMARK" if build.accelerated or not gpu_present else "INFO"


def _draw_torch(layout, prefs, fit):
    """torch: what is installed, the Install button with its build (or the running install's progress and its
    Cancel), the offline route, and what the last install said."""
    box = layout.box()
    fit = fit.boxed()
    gpu = nvidia_gpu_present()
    build = installed_torch()
    _wrapped(box, fit, build.line(), torch_icon(build, gpu))
    if TORCH_INSTALL.running():
        job = TORCH_INSTALL.job
        row = box.row(align=True)
        row.progress(factor=job.progress, text=f"{job.message[:60]} ({job.progress:.0%})")
        row.operator(torch_installer.LAPIG_OT_cancel_torch_install.bl_idname, icon="CANCEL")
        return
    outcome = TORCH_INSTALL.outcome
    if outcome is not None:
        _wrapped(box, fit, outcome.line(), "CHECKMARK" if outcome.active else "FILE_REFRESH")
        if outcome.why_restart:
            _wrapped(box, fit, f"({outcome.why_restart})", "BLANK1")
    if TORCH_INSTALL.failure:
        _wrapped(box, fit, TORCH_INSTALL.failure, "ERROR")
    advice = gpu_advice(build, gpu, sys.executable, _modules_folder())
    for line in advice.why:
        _wrapped(box, fit, line, "NONE")
    unsupported = torch_builds.unsupported_reason()
    if unsupported:
        _wrapped(box, fit, unsupported, "ERROR")
        return
    online = torch_installer.online_access()
    row = box.row(align=True)
    row.prop(prefs, "torch_build", text="")
    sub = row.row(align=True)
    sub.enabled = online
    sub.operator(torch_installer.LAPIG_OT_install_torch.bl_idname, icon="IMPORT",
                 text="Install torch" if not build.present else "Install this build")
    if not online:
        _wrapped(box, fit, torch_installer.online_refusal(), "INTERNET_OFFLINE")
    box.operator(torch_installer.LAPIG_OT_install_torch_wheel.bl_idname, icon="FILEBROWSER")
    _wrapped(box, fit, "docs/installing-torch.md: where torch goes, the offline route, the GPU builds", "HELP")
    if advice.command:
        _wrapped(box, fit, "By hand, in a terminal (then restart Blender):", "NONE")
        box.label(text=advice.command)  # whole (the copy button takes it): a wrapped command would not paste
        box.operator(LAPIG_OT_copy_cuda_command.bl_idname, icon="COPYDOWN")


def ip2p_model() -> str:
    """The InstructPix2Pix weights folder: the preferences' own folder, else the model manager's download where it
    is ready ('' when neither, or when the add-on is registered without being enabled, as in the bpy module)."""
    from ..services.install.model_download import ready_folder

    prefs = addon_preferences()
    if prefs is None:
        return ""
    if prefs.ip2p_model:
        return bpy.path.abspath(prefs.ip2p_model)
    return ready_folder("instruct-pix2pix", model_manager.models_root(prefs))


def ready_model(key: str) -> str:
    """A catalogue model's folder where it is ready: the preferences' own folder for it (Use Folder), else the model
    manager's download ('' when neither is ready, or when the add-on is registered without being enabled)."""
    from ..services.install.model_download import ready_folder

    prefs = addon_preferences()
    if prefs is None:
        return ""
    return ready_folder(key, model_manager.models_root(prefs), model_manager.own_folder(prefs, key))


def ffmpeg_path() -> str:
    """The system ffmpeg from the preferences ('' when unset: the one on PATH)."""
    prefs = addon_preferences()
    return bpy.path.abspath(prefs.ffmpeg_path) if prefs is not None else ""


CLASSES = (LAPIG_OT_copy_install_command, LAPIG_OT_copy_cuda_command, LAPIG_AP_preferences)

register, unregister = bpy.utils.register_classes_factory(CLASSES)

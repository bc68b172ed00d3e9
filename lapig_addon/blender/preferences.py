"""Add-on preferences: where torch runs, which dependencies are present, and how to install the missing ones
(and PyTorch's CUDA build where an NVIDIA GPU has none to use it)."""
from __future__ import annotations

import sys

import bpy

from ...lapig_core.common.deps import check_dependencies, install_command
from ...lapig_core.common.gpu_torch import gpu_advice, installed_torch, nvidia_gpu_present
from ..services.bundle_status import bundle_lines, read_bundle
from .operator_boundary import ReportsErrors


def _addon_package() -> str:
    return __package__.rsplit(".", 2)[0]  # the extension package, e.g. bl_ext.user_default.lapig


class LAPIG_OT_copy_install_command(ReportsErrors, bpy.types.Operator):
    """Copy the pip command that installs LAPIG's missing dependencies"""
    bl_idname = "lapig.copy_install_command"
    bl_label = "Copy install command"

    def execute(self, context):
        target = bpy.utils.user_resource("SCRIPTS", path="modules", create=False)
        context.window_manager.clipboard = install_command(sys.executable, target)
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
                    "(empty: the public checkpoint, if it is in the Hugging Face cache)")
    device: bpy.props.EnumProperty(
        name="Device", default="AUTO",
        items=[("AUTO", "Auto", "A GPU where torch can use one (CUDA, then Apple's MPS), else the CPU"),
               ("CPU", "CPU", "Always the CPU (e.g. to leave the GPU to Cycles)")],
        description="Where Train, PSA, the style networks and the native output run")
    ffmpeg_path: bpy.props.StringProperty(
        name="FFmpeg", subtype="FILE_PATH",
        description="A system ffmpeg for the video codecs the bundled PyAV lacks (HAP, HAP Alpha, HAP Q); empty: "
                    "the ffmpeg on PATH")

    def draw(self, context):
        layout = self.layout
        layout.prop(self, "ip2p_model")
        layout.prop(self, "device")
        layout.prop(self, "ffmpeg_path")
        advice = _gpu_advice()
        layout.label(text=advice.line, icon="CHECKMARK" if not advice.command else "INFO")
        if advice.command:
            box = layout.box()
            for line in advice.why:
                box.label(text=line)
            box.label(text=advice.command)
            box.operator(LAPIG_OT_copy_cuda_command.bl_idname, icon="COPYDOWN")
        col = layout.column(align=True)
        for line in bundle_lines(read_bundle()):
            col.label(text=line.text, icon=line.icon)
        col.separator()
        col.label(text="Python dependencies:")
        deps = check_dependencies()
        for dep in deps:
            row = col.row()
            icon = "CHECKMARK" if dep.present else ("ERROR" if dep.required else "INFO")
            state = "found" if dep.present else ("missing" if dep.required else "optional, not found")
            row.label(text=f"{dep.package}: {state}", icon=icon)
        if any(d.required and not d.present for d in deps):
            box = layout.box()
            box.label(text="Install the missing packages into Blender's Python, then restart Blender:")
            target = bpy.utils.user_resource("SCRIPTS", path="modules", create=False)
            box.label(text=install_command(sys.executable, target))
            box.operator(LAPIG_OT_copy_install_command.bl_idname, icon="COPYDOWN")
            box.label(text="README.md, 'Installing the Python dependencies into Blender', explains each step.")


def compute_device() -> str:
    """'auto' or 'cpu' from the preferences ('auto' when the add-on is registered without being enabled, as
    in the bpy module)."""
    addon = bpy.context.preferences.addons.get(_addon_package())
    return addon.preferences.device.lower() if addon and addon.preferences else "auto"


def ip2p_model() -> str:
    """The InstructPix2Pix weights folder from the preferences ('' when unset, or when the add-on is
    registered without being enabled, as in the bpy module)."""
    addon = bpy.context.preferences.addons.get(_addon_package())
    return bpy.path.abspath(addon.preferences.ip2p_model) if addon and addon.preferences else ""


def ffmpeg_path() -> str:
    """The system ffmpeg from the preferences ('' when unset: the one on PATH)."""
    addon = bpy.context.preferences.addons.get(_addon_package())
    return bpy.path.abspath(addon.preferences.ffmpeg_path) if addon and addon.preferences else ""


CLASSES = (LAPIG_OT_copy_install_command, LAPIG_OT_copy_cuda_command, LAPIG_AP_preferences)

register, unregister = bpy.utils.register_classes_factory(CLASSES)

import bpy

from ..lapig_addon import storage
from ..lapig_addon.modal_runner import active_job
from ..lapig_core.deps import missing_required
from ..operators.capture_ops import capture_state

STATE_ICONS = {"DONE": "CHECKMARK", "STALE": "ERROR", "MISSING": "DOT"}


class LapigPanel:
    bl_space_type = "VIEW_3D"
    bl_region_type = "UI"
    bl_category = "LAPIG"


class LAPIG_PT_setup(LapigPanel, bpy.types.Panel):
    bl_label = "Setup"
    bl_idname = "LAPIG_PT_setup"

    def draw(self, context):
        layout = self.layout
        s = context.scene.lapig
        missing = missing_required()
        if missing:
            layout.label(text="Missing: " + ", ".join(d.package for d in missing), icon="ERROR")
            layout.label(text="See the add-on preferences")
        layout.prop(s, "target")
        layout.operator("lapig.add_rig", icon="OUTLINER_OB_LIGHT")
        layout.prop(s, "projector")
        layout.prop(s, "camera")
        if s.projector:
            p = s.projector.lapig_projector
            col = layout.column(align=True)
            row = col.row(align=True)
            row.prop(p, "resolution_x")
            row.prop(p, "resolution_y")
            col.prop(p, "throw_ratio")
            row = col.row(align=True)
            row.prop(p, "shift_x")
            row.prop(p, "shift_y")
            col.prop(p, "brightness")
            col.prop(p, "black_level")
            col.prop(p, "gamma")
        if s.camera:
            c = s.camera.lapig_camera
            col = layout.column(align=True)
            row = col.row(align=True)
            row.prop(c, "resolution_x")
            row.prop(c, "resolution_y")
            col.prop(c, "auto_exposure")
            sub = col.column()
            sub.enabled = not c.auto_exposure
            sub.prop(c, "exposure")
            col.prop(c, "response_gamma")
            col.prop(c, "noise")
        layout.prop(s, "ambient")
        if s.target is not None:
            from ..lapig_addon.preview import is_previewing

            on = is_previewing(s.target)
            layout.operator("lapig.preview_toggle", icon="HIDE_OFF" if on else "HIDE_ON",
                            text="Hide Projection Preview" if on else "Preview Projection in Viewport")


class LAPIG_PT_capture(LapigPanel, bpy.types.Panel):
    bl_label = "Capture"
    bl_idname = "LAPIG_PT_capture"

    def draw(self, context):
        layout = self.layout
        s = context.scene.lapig
        state, reason = capture_state(context.scene)
        layout.label(text=reason, icon=STATE_ICONS[state])
        col = layout.column(align=True)
        col.prop(s, "train_count")
        col.prop(s, "test_count")
        col.prop(s, "working_size")
        col.prop(s, "samples")
        col.prop(s, "gray_level")
        layout.prop(s, "pattern_source", expand=True)
        if s.pattern_source == "FOLDER":
            layout.prop(s, "pattern_folder")
        folder, temporary = storage.data_root()
        layout.label(text=storage.location_message(), icon="ERROR" if temporary else "FILE_FOLDER")
        job = active_job()
        if job is not None and not job.finished:
            layout.progress(factor=job.progress, text=f"{job.message} (Esc to cancel)")
        row = layout.row()
        ready = s.projector is not None and s.camera is not None and s.target is not None
        row.enabled = ready and not missing_required() and (job is None or job.finished)
        row.operator("lapig.capture", icon="RENDER_STILL")
        if not ready:
            layout.label(text="Add the projector and camera first", icon="INFO")
        layout.operator("lapig.import_capture", icon="IMPORT")


CLASSES = (LAPIG_PT_setup, LAPIG_PT_capture)

register, unregister = bpy.utils.register_classes_factory(CLASSES)

"""The Show panel (issue 38): the looks in order with their hold, transition and motion; Bake Show (the previz on
the timeline), Export Show and Play Show."""
import bpy

from ..lapig_addon.blender import scene_state, show_timeline, ui_text
from ..lapig_addon.rigs import live_output
from .main_panel import LapigPanel, _blocked, _button, _job_running, _lines, _pair, _progress


class LAPIG_UL_show_looks(bpy.types.UIList):
    def draw_item(self, context, layout, data, item, icon, active_data, active_propname, index):
        row = layout.row(align=True)
        row.prop(item, "name", text="", emboss=False, icon="IMAGE_DATA")
        detail = f"{item.hold_s:g}s"
        if index < len(data.show_looks) - 1:
            detail += f" | {item.transition} {item.transition_s:g}s"
        if item.motion != "none":
            detail += f" | {item.motion}"
        row.label(text=detail)


class LAPIG_PT_show(LapigPanel, bpy.types.Panel):
    bl_label = "Show"
    bl_idname = "LAPIG_PT_show"
    bl_options = {"DEFAULT_CLOSED"}

    def draw(self, context):
        layout = self.layout
        fit = ui_text.fit_for(context)
        scene = context.scene
        s = scene.lapig
        row = layout.row()
        row.template_list("LAPIG_UL_show_looks", "", s, "show_looks", s, "show_index", rows=3)
        col = row.column(align=True)
        col.operator("lapig.show_add_look", icon="ADD", text="")
        col.operator("lapig.show_remove_look", icon="REMOVE", text="")
        col.separator()
        col.operator("lapig.show_move_look", icon="TRIA_UP", text="").direction = "UP"
        col.operator("lapig.show_move_look", icon="TRIA_DOWN", text="").direction = "DOWN"
        if 0 <= s.show_index < len(s.show_looks):
            item = s.show_looks[s.show_index]
            box = layout.box()
            box.prop(item, "result_dir")
            box.prop(item, "hold_s")
            if s.show_index < len(s.show_looks) - 1:
                row = box.row(align=True)
                row.prop(item, "transition", text="")
                row.prop(item, "transition_s")
            box.prop(item, "motion")
            if item.motion != "none":
                _pair(box, item, "motion_amount", "motion_period_s")
        plan = scene_state.read_show(scene)
        if plan.looks and plan.fps > 0:
            _lines(layout, fit, [(f"{plan.frame_count()} frames, {plan.seconds():.1f} s at {plan.fps:g} fps "
                                  f"(the scene's frame rate)", True)])
        blocked = _blocked(layout, show_timeline.blocker(scene), fit)
        text, ok = show_timeline.previz_status(scene)
        _lines(layout, fit, [(text, True)], icon="CHECKMARK" if ok else "ERROR" if ok is False else "DOT")
        _button(layout, not blocked and not _job_running(), "lapig.bake_show", icon="RENDER_ANIMATION")
        _progress(layout, "LAPIG bake show")
        layout.separator()
        col = layout.column()
        col.enabled = not blocked and not _job_running()
        col.prop(s, "show_codec")
        col.prop(s, "export_bit_depth", expand=True)
        col.prop(s, "show_export_dir")
        col.operator("lapig.export_show", icon="EXPORT")
        _progress(layout, "LAPIG export show")
        _button(layout, not blocked and not _job_running() and bool(live_output.open_sinks()), "lapig.play_show",
                icon="PLAY")
        _progress(layout, "LAPIG play show")


CLASSES = (LAPIG_UL_show_looks, LAPIG_PT_show)

register, unregister = bpy.utils.register_classes_factory(CLASSES)

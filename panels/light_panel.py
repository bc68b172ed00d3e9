"""The Light sub-panel: a real projector model, the room's lux, the object's conservation category; the
Light Report's figures (from the result's light_report.json) and its warnings."""
import bpy

from ..lapig_addon.blender import scene_state, ui_text
from ..lapig_addon.services.light import light_report
from ..lapig_addon.services.light.dose_cap import DoseCapJob
from ..lapig_addon.services.light.light_report_job import LightReportJob
from .main_panel import LapigPanel, _job_running, _lines, _progress, _props


class LAPIG_PT_light(LapigPanel, bpy.types.Panel):
    bl_label = "Light in Real Units"
    bl_idname = "LAPIG_PT_light"
    bl_parent_id = "LAPIG_PT_preview_export"

    def draw(self, context):
        layout = self.layout
        fit = ui_text.fit_for(context)
        s = context.scene.lapig_light
        layout.prop(s, "preset")
        if s.preset == "NONE":
            layout.prop(s, "lumens")
        layout.operator("lapig.light_apply", icon="OUTLINER_OB_LIGHT")
        layout.prop(s, "ambient_lux")
        row = layout.row()
        row.prop(s, "use_lamp")
        if s.use_lamp:
            row.prop(s, "lamp_direction", text="")
        layout.prop(s, "category")
        if s.category != "NONE":
            col = layout.column(align=True)
            if s.category == "CUSTOM":
                col.prop(s, "limit_lux")
            _props(col, s, "hours_per_day", "days_per_year", "region_material")
            target = context.scene.lapig.target
            if target is not None and target.type == "MESH":
                col.prop_search(s, "region_group", target, "vertex_groups")
        plan = scene_state.light_plan(context.scene)
        problem = plan.problem()
        if problem:
            _lines(layout, fit, [(problem, False)])
        _progress(layout, LightReportJob.title)
        _progress(layout, DoseCapJob.title)
        # one foreground job at a time (JobSlots queues none): the tooltips say why the buttons are off meanwhile
        col = layout.column(align=True)
        col.enabled = not problem and not _job_running()
        col.operator("lapig.light_report", icon="LIGHT_SPOT")
        if s.category != "NONE":
            col.operator("lapig.light_cap", icon="LIGHT_SUN")
        folder = scene_state.read(context.scene).result_dir
        report = light_report.read_report(folder) if folder else None
        if not report:
            return
        box = layout.box()
        inner = fit.boxed()
        _lines(box, inner, [(f"{report['lumens']:,.0f} lm = {report['light_power_w']:,.1f} W of Blender light"
                             + (" (all projectors)" if report.get("projectors") else ""), True)])
        for p in report.get("projectors") or []:  # several: each one's lumens and share of the light
            _lines(box, inner, [(f"{p['name']}: {p['lumens']:,.0f} lm, {p['share']:.0%} of the light", True)],
                   icon="LIGHT_SPOT")
        _lines(box, inner, [(f"Look: {report['look_lux']['mean']} lux mean, {report['look_lux']['max']} max", True),
                            (f"Luminance: {report['luminance_cd_m2']['mean']} cd/m2 mean", True)])
        # the contrast, and under it why it is too low (the warning's lines indented under its icon)
        _lines(box, inner, [(f"Contrast against the room: {report['contrast_ratio']['median']}:1 (median)"
                             + (f". {report['warning']}" if report["warning"] else ""), True)],
               icon="ERROR" if report["warning"] else "CHECKMARK")
        dose = report.get("dose")
        if dose:
            ok = dose["within_limit"] and dose["within_yearly_budget"]
            _lines(box, inner, [(f"Dose: {dose['max_lux']} lux max, {dose['mean_lux']} mean (limit "
                                 f"{dose['limit_lux']:g})", True)], icon="CHECKMARK" if ok else "ERROR")
            _lines(box, inner, [(f"{dose['lux_hours_per_year_max']:,} lux.h a year at the brightest point "
                                 f"(budget {dose['yearly_budget_lux_hours']:,})", True)])
            if dose.get("lumens_within_limit") is not None:
                _lines(box, inner, [(f"This look keeps the limit at {dose['lumens_within_limit']:,} lumens or "
                                     f"fewer", True)], icon="INFO")


CLASSES = (LAPIG_PT_light,)

register, unregister = bpy.utils.register_classes_factory(CLASSES)

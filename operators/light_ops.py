import bpy

from ..lapig_addon.blender import light_plan_run, result_preview, scene_state
from ..lapig_addon.blender.modal_runner import JobRunnerMixin
from ..lapig_addon.blender.operator_boundary import ReportsErrors, refuse, report_notes
from ..lapig_addon.services.panel.panel_state import rig_blocker


class LAPIG_OT_light_report(JobRunnerMixin, bpy.types.Operator):
    """Render the look's light in lux, its contrast against the room and the light dose on the marked
    region; the object then shows the lux map"""
    bl_idname = "lapig.light_report"
    bl_label = "Light Report"

    def make_job(self, context):
        scene = context.scene
        plan = scene_state.light_plan(scene)
        refuse(rig_blocker(scene_state.read_rig(scene)) or plan.problem())
        # several projectors: every projector's light over the camera's pixels (the rig's strategy)
        return light_plan_run.report_job(scene, plan, scene_state.read(scene).result_dir or None)

    def on_done(self, context, job):
        report = job.result
        if report.get("projectors"):  # several: their maps are the camera's, not a projector's frame
            self.report({"INFO"}, "Each projector's share: " + report["projectors_line"])
        if report["warning"]:
            self.report({"WARNING"}, report["warning"])
        dose = report.get("dose")
        if dose and not dose["within_limit"]:
            self.report({"WARNING"}, f"{dose['max_lux']} lux on the marked region: over its {dose['limit_lux']:g} "
                                     "lux limit")
        scene = context.scene
        if report["result"] and not report.get("projectors") and result_preview.apply_mode(scene, "LUX",
                                                                                            report=self.report):
            scene_state.record_preview_mode(scene, "LUX")
        c = report["contrast_ratio"]["median"]
        self.report({"INFO"}, f"look {report['look_lux']['mean']} lux mean, contrast {c}:1 against the room")


class LAPIG_OT_light_cap(JobRunnerMixin, bpy.types.Operator):
    """Limit the look so the marked region stays within its conservation limit: a new result (the free
    one stays), which the projector, the preview and Export then use"""
    bl_idname = "lapig.light_cap"
    bl_label = "Limit Look to the Dose"

    def make_job(self, context):
        scene = context.scene
        plan = scene_state.light_plan(scene)
        problem = plan.problem() or ("" if plan.limit else "choose a conservation category first")
        if not problem and not scene_state.read(scene).result_dir:
            problem = "generate a look first"
        refuse(problem)
        return light_plan_run.cap_job(scene, plan)  # several projectors: one factor on every projector's light

    def on_done(self, context, job):
        out = job.result
        report_notes(self, out.get("notes", []))
        if "scale" in out:
            self.report({"INFO"}, f"limited look: every projector's light x{out['scale']:.2f}, "
                                  f"{out['predicted_max_lux']} lux at most on the region")
            return
        self.report({"INFO"}, f"limited look: {out['predicted_max_lux']} lux at most on the region "
                              f"({out['changed_pixel_share']:.0%} of the pixels dimmed)")


class LAPIG_OT_light_apply(ReportsErrors, bpy.types.Operator):
    """Set the projector to this model: its native resolution, the throw ratio and lens shift nearest the
    rig's within its ranges, the light power of its lumens and the black level of its contrast (the
    capture then goes stale)"""
    bl_idname = "lapig.light_apply"
    bl_label = "Use This Projector"
    bl_options = {"REGISTER", "UNDO"}

    def execute(self, context):
        plan = scene_state.light_plan(context.scene)
        problem = plan.problem()
        if problem:
            self.report({"ERROR"}, problem)
            return {"CANCELLED"}
        settings, notes = light_plan_run.apply_projector(context.scene, plan)
        for note in notes:
            self.report({"WARNING"}, note)
        self.report({"INFO"}, f"projector set: {settings['brightness']:,.1f} W for {plan.resolved_lumens:,.0f} lm")
        return {"FINISHED"}


CLASSES = (LAPIG_OT_light_report, LAPIG_OT_light_cap, LAPIG_OT_light_apply)

register, unregister = bpy.utils.register_classes_factory(CLASSES)

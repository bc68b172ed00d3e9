import bpy

from ..lapig_addon.blender import multi_rig, rig, scene_state
from ..lapig_addon.blender.operator_boundary import ReportsErrors


class LAPIG_OT_add_rig(ReportsErrors, bpy.types.Operator):
    """Add a projector and a camera aimed at the selected object, so it fills the projector's frame"""
    bl_idname = "lapig.add_rig"
    bl_label = "Add Projector and Camera"
    bl_options = {"REGISTER", "UNDO"}

    def execute(self, context):
        projector, camera, _ = scene_state.rig_objects(context.scene)  # moved, not duplicated, if there
        target = context.active_object if context.active_object and context.active_object.select_get() \
            else None
        if target is None or target.type != "MESH":
            self.report({"ERROR"}, "Select the mesh object to project on first")
            return {"CANCELLED"}
        projector, camera, placement = rig.add_rig(context, target, projector, camera)
        kind = "filling the surface" if placement.planar else "fitting the object"
        self.report({"INFO"}, f"Projector {placement.distance:.2f} m from '{target.name}', {kind}")
        return {"FINISHED"}


class LAPIG_OT_focus_on_object(ReportsErrors, bpy.types.Operator):
    """Focus the projector's and the camera's lenses on the surface object's centre"""
    bl_idname = "lapig.focus_on_object"
    bl_label = "Focus on the Object"
    bl_options = {"REGISTER", "UNDO"}

    def execute(self, context):
        projector, camera, target = scene_state.rig_objects(context.scene)
        if projector is None or target is None:
            self.report({"ERROR"}, "Add the projector and camera and choose the surface object first")
            return {"CANCELLED"}
        p, c = rig.focus_on_object(projector, camera, target)
        self.report({"INFO"}, f"Projector focused at {p:.2f} m" + (f", camera at {c:.2f} m" if camera else ""))
        return {"FINISHED"}


class LAPIG_OT_add_projector(ReportsErrors, bpy.types.Operator):
    """Add another projector like the first, placed to light what the others miss (the first mirrored across
    the camera's view), aimed at the object"""
    bl_idname = "lapig.add_projector"
    bl_label = "Add Projector"
    bl_options = {"REGISTER", "UNDO"}

    def execute(self, context):
        _, sentence = multi_rig.add_projector(context)
        self.report({"INFO"}, sentence)
        return {"FINISHED"}


class LAPIG_OT_remove_projector(ReportsErrors, bpy.types.Operator):
    """Take this projector off the rig (the light stays in the scene)"""
    bl_idname = "lapig.remove_projector"
    bl_label = "Remove Projector from the Rig"
    bl_options = {"REGISTER", "UNDO"}

    name: bpy.props.StringProperty(name="Projector")

    def execute(self, context):
        if not scene_state.remove_extra_projector(context.scene, self.name):
            self.report({"ERROR"}, f"'{self.name}' is not one of the rig's added projectors")
            return {"CANCELLED"}
        self.report({"INFO"}, f"'{self.name}' is off the rig")
        return {"FINISHED"}


class LAPIG_OT_blend_preview(ReportsErrors, bpy.types.Operator):
    """Show each projector's share of the object in its own colour (1 red, 2 green, 3 blue, 4 yellow), from
    the capture's blend weights: see it in the viewport's Rendered mode or a Cycles render"""
    bl_idname = "lapig.blend_preview"
    bl_label = "Blend Preview"
    bl_options = {"REGISTER", "UNDO"}

    def execute(self, context):
        from ..lapig_addon.blender.blend_preview import show_blend_preview

        self.report({"INFO"}, show_blend_preview(context.scene))
        return {"FINISHED"}


CLASSES = (LAPIG_OT_add_rig, LAPIG_OT_focus_on_object, LAPIG_OT_add_projector, LAPIG_OT_remove_projector,
           LAPIG_OT_blend_preview)

register, unregister = bpy.utils.register_classes_factory(CLASSES)

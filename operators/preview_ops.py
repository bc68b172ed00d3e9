import bpy

from ..lapig_addon.blender import preview, projector_nodes, scene_state
from ..lapig_addon.blender.operator_boundary import ReportsErrors
from ..lapig_addon.services.panel.panel_state import rig_blocker


class LAPIG_OT_preview_toggle(ReportsErrors, bpy.types.Operator):
    """Show the projected image on the object in Solid and Material Preview modes (reversible)"""
    bl_idname = "lapig.preview_toggle"
    bl_label = "Toggle Viewport Preview"
    bl_options = {"REGISTER", "UNDO"}

    def execute(self, context):
        blocker = rig_blocker(scene_state.read_rig(context.scene))
        if blocker:
            self.report({"ERROR"}, blocker)
            return {"CANCELLED"}
        projector, _, target = scene_state.rig_objects(context.scene)
        if preview.is_previewing(target):
            preview.disable_preview(target)
            self.report({"INFO"}, f"'{target.name}' shows its own materials again")
            return {"FINISHED"}
        # every projector of the rig casts its own image (one projector: its image alone)
        projectors = scene_state.rig_projectors(context.scene) or [projector]
        preview.enable_casts(target, [(p, projector_nodes.projected_image(p.data)) for p in projectors])
        space = context.space_data
        if space is not None and space.type == "VIEW_3D" and space.shading.type == "SOLID":
            space.shading.color_type = "TEXTURE"  # Solid mode shows image textures only like this
        self.report({"INFO"}, "Previewing the projection (toggle again to restore the materials)")
        return {"FINISHED"}


CLASSES = (LAPIG_OT_preview_toggle,)

register, unregister = bpy.utils.register_classes_factory(CLASSES)

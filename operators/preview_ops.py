import bpy

from ..lapig_addon.blender import preview, projector_nodes


class LAPIG_OT_preview_toggle(bpy.types.Operator):
    """Show the projected image on the object in Solid and Material Preview modes (reversible)"""
    bl_idname = "lapig.preview_toggle"
    bl_label = "Toggle Viewport Preview"
    bl_options = {"REGISTER", "UNDO"}

    def execute(self, context):
        s = context.scene.lapig
        if s.target is None or s.projector is None:
            self.report({"ERROR"}, "Add the projector and camera first")
            return {"CANCELLED"}
        if preview.is_previewing(s.target):
            preview.disable_preview(s.target)
            self.report({"INFO"}, f"'{s.target.name}' shows its own materials again")
            return {"FINISHED"}
        try:
            preview.enable_preview(s.target, s.projector, projector_nodes.projected_image(s.projector.data))
        except ValueError as exc:
            self.report({"ERROR"}, str(exc))
            return {"CANCELLED"}
        space = context.space_data
        if space is not None and space.type == "VIEW_3D" and space.shading.type == "SOLID":
            space.shading.color_type = "TEXTURE"  # Solid mode shows image textures only like this
        self.report({"INFO"}, "Previewing the projection (toggle again to restore the materials)")
        return {"FINISHED"}


CLASSES = (LAPIG_OT_preview_toggle,)

register, unregister = bpy.utils.register_classes_factory(CLASSES)

"""The Light sub-panel's settings, per scene (scene.lapig_light): the projector model or its lumens, the
room's lux, the object's conservation category and the show's schedule. scene_state.light_plan reads
them into services/light/light_report.LightPlan, which checks them."""
from __future__ import annotations

import bpy
from bpy.props import BoolProperty, EnumProperty, FloatProperty, FloatVectorProperty, PointerProperty, StringProperty

_PRESET_ITEMS = []  # Blender needs the enum strings to stay referenced


def preset_items(self, context):
    if not _PRESET_ITEMS:
        from ...lapig_core.photometry import presets

        _PRESET_ITEMS.append(("NONE", "Lumens below", "No model: give the projector's ANSI lumens"))
        _PRESET_ITEMS.extend((p.id, p.name, f"{p.kind}: {p.ansi_lumens:,.0f} lm, {p.contrast:,.0f}:1, throw "
                              f"{p.throw_ratio[0]}-{p.throw_ratio[1]}") for p in presets.all_presets())
    return _PRESET_ITEMS


class LapigLightSettings(bpy.types.PropertyGroup):
    preset: EnumProperty(name="Model", items=preset_items,
                         description="Projector model: a real projector's lumens and contrast "
                                     "(projector_presets.toml)")
    lumens: FloatProperty(name="Lumens", default=3000.0, min=0.0, soft_max=50000.0,
                          description="The projector's ANSI lumens (used when no model is chosen)")
    ambient_lux: FloatProperty(name="Room light (lux)", default=50.0, min=0.0, soft_max=2000.0,
                               description="The room's illuminance on the object, in lux")
    use_lamp: BoolProperty(name="Lamp direction", default=False,
                           description="The room's light comes from one lamp (else from every direction)")
    lamp_direction: FloatVectorProperty(name="Lamp direction", size=3, default=(0.0, 0.5, -1.0), subtype="DIRECTION",
                                        description="The way the room's lamp shines")
    category: EnumProperty(name="Guard", items=[
        ("NONE", "None", "No light-dose guard"),
        ("HIGH", "50 lux", "Highly sensitive: works on paper, textiles, watercolours: 50 lux, 150,000 lux.h a year"),
        ("MODERATE", "200 lux", "Moderately sensitive: oil paint, wood, horn: 200 lux, 600,000 lux.h a year"),
        ("CUSTOM", "Custom limit", "A lux limit of your own")], default="NONE",
        description="Conservation: the light-dose guard of a sensitive object (a museum's category)")
    limit_lux: FloatProperty(name="Limit (lux)", default=50.0, min=0.0, soft_max=1000.0)
    hours_per_day: FloatProperty(name="Hours a day", default=8.0, min=0.0, max=24.0)
    days_per_year: FloatProperty(name="Days a year", default=300.0, min=0.0, max=366.0)
    region_material: PointerProperty(name="Region", type=bpy.types.Material,
                                     description="Mark only the faces of this material (empty: the whole object)")
    region_group: StringProperty(name="Vertex group",
                                 description="Or mark only the faces of this vertex group of the object")


def register():
    bpy.utils.register_class(LapigLightSettings)
    bpy.types.Scene.lapig_light = PointerProperty(type=LapigLightSettings)


def unregister():
    del bpy.types.Scene.lapig_light
    bpy.utils.unregister_class(LapigLightSettings)

"""Viewport preview of the projected image through the object's material, fully reversible.

Cycles shows the projection through the projector light itself; Solid and Material Preview modes
ignore light node trees, so the preview swaps each material slot for a copy whose base colour is
multiplied by the image, projected from the projector object (Texture Coordinate 'Object') and weighted
as the projector's light falls on the surface (preview_weight: nothing where it does not reach), and
adds a projected UV map for Solid mode, which draws image textures through the active UV map.
The originals get a fake user while swapped, so saving the file can never lose them.

A rig of several projectors casts every projector's image at once (enable_casts): the copy's base colour is
multiplied by the sum of their projected images, each weighted by its own projector's reach, as their lights
add on the surface. Solid mode's UV map
follows the first caster only (one UV map, one image).
"""
from __future__ import annotations

import contextlib

import bpy

from . import preview_weight, projector_nodes, solid_reach
from .compat import material_node_tree
from ...lapig_core.optics.projector_model import ProjectorModel
from .scene_state import projector_model

ORIGINALS_KEY = "lapig_preview_originals"
PREVIEW_PREFIX = "LAPIG preview: "
EMPTY_SLOT = ""


def is_previewing(obj) -> bool:
    return ORIGINALS_KEY in obj.keys()


def caster_model(caster, image) -> ProjectorModel:
    """How `caster` casts `image`: a projector light by its own settings; the rig's camera (a rig of several
    projectors shows its camera-space result images from where they were seen) by its lens, sensor fit and
    shift, at the image's size."""
    if caster.type != "CAMERA":
        return projector_model(caster)
    cam, (width, height) = caster.data, image.size
    aspect = width / height
    if cam.sensor_fit == "VERTICAL" or (cam.sensor_fit == "AUTO" and height > width):
        sensor_h = cam.sensor_height if cam.sensor_fit == "VERTICAL" else cam.sensor_width
        width_mm = sensor_h * aspect
    else:
        width_mm = cam.sensor_width
    larger = max(width, height)  # Blender's shift is in units of the larger side
    return ProjectorModel(width=width, height=height, throw_ratio=cam.lens / width_mm,
                          shift_x=cam.shift_x * larger / width, shift_y=cam.shift_y * larger / height)


def _projection_nodes(tree, projector, image, model, row=0):
    nodes, links = tree.nodes, tree.links
    sx, sy = model.uv_scale()
    coords = nodes.new("ShaderNodeTexCoord")
    coords.object = projector
    split = nodes.new("ShaderNodeSeparateXYZ")
    links.new(coords.outputs["Object"], split.inputs[0])

    def chain(axis, scale, offset):
        div = nodes.new("ShaderNodeMath")
        div.operation = "DIVIDE"
        links.new(split.outputs[axis], div.inputs[0])
        links.new(split.outputs["Z"], div.inputs[1])
        mad = nodes.new("ShaderNodeMath")
        mad.operation = "MULTIPLY_ADD"
        links.new(div.outputs[0], mad.inputs[0])
        mad.inputs[1].default_value = -scale
        mad.inputs[2].default_value = offset
        return mad.outputs[0]

    uv = nodes.new("ShaderNodeCombineXYZ")
    links.new(chain("X", sx, 0.5 + model.shift_x), uv.inputs["X"])
    links.new(chain("Y", sy, 0.5 + model.shift_y), uv.inputs["Y"])
    tex = nodes.new("ShaderNodeTexImage")
    tex.name = tex.label = "LAPIG projected image"
    tex.image = image
    tex.extension = "CLIP"
    # exact per-pixel projection for Material Preview and renders; Solid mode uses the UV map
    links.new(uv.outputs[0], tex.inputs["Vector"])
    for i, node in enumerate((coords, split, uv, tex)):
        node.location = (-1200 + 250 * i, -400 - 300 * row)
    if projector_nodes.is_show_image(image):  # a baked show: its frames follow the scene's, as the light's do
        user = tex.image_user
        user.frame_duration, user.frame_start = int(image["lapig_show_frames"]), int(image["lapig_show_start"])
        user.frame_offset, user.use_auto_refresh, user.use_cyclic = 0, True, False
    return tex, split.outputs["Z"]  # the image node and the point's Z in the caster's space


def _colour(tree, tex):
    """The projected light of the image node: a baked show's input values through the projector's gamma (a still
    result's image is light already)."""
    if not projector_nodes.is_show_image(tex.image):
        return tex.outputs["Color"]
    gamma = tree.nodes.new("ShaderNodeGamma")
    gamma.inputs["Gamma"].default_value = float(tex.image["lapig_gamma"])
    tree.links.new(tex.outputs["Color"], gamma.inputs["Color"])
    gamma.location = (tex.location.x + 250, tex.location.y)
    return gamma.outputs["Color"]


def _cast_weight(tree, caster, local_z, appearance):
    """preview_weight's factor for one cast: a projector's light by incidence and distance, normalised at its
    focus distance; an appearance, or an image cast from the camera, by visibility alone."""
    as_light = not appearance and caster.type == "LIGHT"
    reference = caster.lapig_projector.focus_distance if as_light else 1.0
    return preview_weight.weight(tree, caster, local_z, reference, as_light)


def _summed_colour(tree, casts, appearance=False):
    """The colour of every cast, each weighted by what its caster reaches (preview_weight), added up (lights
    add on the surface), and the first image node."""
    first, total = None, None
    for i, (caster, image, model) in enumerate(casts):
        tex, local_z = _projection_nodes(tree, caster, image, model, row=i)
        colour = preview_weight.weighted(tree, _colour(tree, tex), _cast_weight(tree, caster, local_z, appearance))
        if total is None:
            first, total = tex, colour
            continue
        add = tree.nodes.new("ShaderNodeMix")
        add.data_type, add.blend_type = "RGBA", "ADD"
        add.inputs["Factor"].default_value = 1.0
        tree.links.new(total, add.inputs["A"])
        tree.links.new(colour, add.inputs["B"])
        add.location = (tex.location.x + 500, tex.location.y)
        total = add.outputs["Result"]
    return first, total


def _preview_material(original, casts, appearance=False):
    if original is not None:
        mat = original.copy()
        mat.name = PREVIEW_PREFIX + original.name
    else:
        mat = bpy.data.materials.new(PREVIEW_PREFIX + "(no material)")
    tree = material_node_tree(mat)
    tex, colour = _summed_colour(tree, casts, appearance)
    bsdf = next((n for n in tree.nodes if n.bl_idname == "ShaderNodeBsdfPrincipled"), None)
    if appearance:
        # an appearance (target, simulated or rendered capture) already includes the surface: show it
        # as is, unlit, instead of multiplying the surface again
        output = next((n for n in tree.nodes if n.bl_idname == "ShaderNodeOutputMaterial"), None)
        if output is None:
            output = tree.nodes.new("ShaderNodeOutputMaterial")
        emission = tree.nodes.new("ShaderNodeEmission")
        tree.links.new(colour, emission.inputs["Color"])
        tree.links.new(emission.outputs["Emission"], output.inputs["Surface"])
        emission.location = (output.location.x - 250, output.location.y - 200)
    elif bsdf is not None:
        mix = tree.nodes.new("ShaderNodeMix")
        mix.data_type, mix.blend_type = "RGBA", "MULTIPLY"
        mix.inputs["Factor"].default_value = 1.0
        base = bsdf.inputs["Base Color"]
        if base.is_linked:
            tree.links.new(base.links[0].from_socket, mix.inputs["A"])
        else:
            mix.inputs["A"].default_value = base.default_value
        tree.links.new(colour, mix.inputs["B"])
        tree.links.new(mix.outputs["Result"], base)
        mix.location = (bsdf.location.x - 250, bsdf.location.y)
    tree.nodes.active = tex  # Solid mode's 'Texture' colour shows the active image node
    return mat


LENS_NAME = "LAPIG projector lens"
UV_NAME = "LAPIG projection"


def _add_solid_mode_projection(obj, projector, model):
    """Solid mode maps textures through the active UV map: project one with a UV Project modifier.

    The modifier needs a camera for perspective, so a hidden camera with the projector's field of
    view rides along as the projector's child.
    """
    lens = bpy.data.cameras.new(LENS_NAME)
    lens.sensor_fit, lens.sensor_width = "HORIZONTAL", 36.0
    lens.lens = 36.0 * model.throw_ratio  # tan(half fov) = 0.5 / throw ratio
    lens.shift_x, lens.shift_y = model.shift_x, model.shift_y / model.aspect  # in image widths
    lens_obj = bpy.data.objects.new(LENS_NAME, lens)
    for coll in projector.users_collection:
        coll.objects.link(lens_obj)
    lens_obj.parent = projector
    lens_obj.hide_select = lens_obj.hide_render = True
    lens_obj.hide_viewport = True
    mesh = obj.data
    obj["lapig_preview_active_uv"] = mesh.uv_layers.active.name if mesh.uv_layers.active else ""
    uv = mesh.uv_layers.new(name=UV_NAME)
    if uv is None:
        raise ValueError(f"'{obj.name}' has no room for another UV map (Blender allows 8)")
    mesh.uv_layers.active = uv
    mod = obj.modifiers.new(UV_NAME, "UV_PROJECT")
    mod.uv_layer = uv.name
    mod.projector_count = 1
    mod.projectors[0].object = lens_obj
    mod.aspect_x, mod.aspect_y = model.width, model.height
    obj["lapig_preview_lens"] = lens_obj.name


def _remove_solid_mode_projection(obj):
    solid_reach.remove_reach_modifier(obj)
    mod = obj.modifiers.get(UV_NAME)
    if mod is not None:
        obj.modifiers.remove(mod)
    mesh = obj.data
    uv = mesh.uv_layers.get(UV_NAME)
    if uv is not None:
        mesh.uv_layers.remove(uv)
    active = obj.pop("lapig_preview_active_uv", "")
    if active and mesh.uv_layers.get(active) is not None:
        mesh.uv_layers.active = mesh.uv_layers[active]
    lens_obj = bpy.data.objects.get(obj.pop("lapig_preview_lens", ""))
    if lens_obj is not None:
        lens = lens_obj.data
        bpy.data.objects.remove(lens_obj)
        if lens is not None and lens.users == 0:
            bpy.data.cameras.remove(lens)


def enable_preview(obj, projector, image, appearance=False):
    """Show `image` cast from `projector` (a projector light, or the rig's camera: caster_model) on obj."""
    enable_casts(obj, [(projector, image)], appearance)


def enable_casts(obj, casts, appearance=False):
    """Show every (caster, image) of `casts` on obj at once, their light added (a rig of several projectors'
    Projection); one cast is enable_preview's."""
    shown = [(caster, image) for caster, image in casts if image is not None]
    if not shown:
        raise ValueError("the projector has no image to preview" if len(casts) == 1
                         else "the projectors have no image to preview: press Generate")
    casts = shown
    if obj.type != "MESH":
        raise ValueError(f"'{obj.name}' is not a mesh: the preview needs one")
    if is_previewing(obj):
        disable_preview(obj)
    modelled = [(caster, image, caster_model(caster, image)) for caster, image in casts]
    _add_solid_mode_projection(obj, modelled[0][0], modelled[0][2])
    solid_reach.add_reach_modifier(obj, [caster for caster, _ in casts])  # dark where no caster reaches
    if len(obj.material_slots) == 0:
        obj.data.materials.append(None)
        obj["lapig_preview_added_slot"] = True
    originals, fake_users = [], []
    for slot in obj.material_slots:
        original = slot.material
        originals.append(original.name if original else EMPTY_SLOT)
        fake_users.append(bool(original.use_fake_user) if original else False)
        if original is not None:
            original.use_fake_user = True
        slot.material = _preview_material(original, modelled, appearance)
    obj[ORIGINALS_KEY] = originals
    obj["lapig_preview_caster"] = casts[0][0].name
    obj["lapig_preview_appearance"] = bool(appearance)
    obj["lapig_preview_image"] = casts[0][1].name
    obj["lapig_preview_casters"] = [caster.name for caster, _ in casts]
    obj["lapig_preview_images"] = [image.name for _, image in casts]
    obj["lapig_preview_fake_users"] = fake_users


def current_preview(obj):
    """(image, appearance, caster) shown now, so a capture can turn the preview off and back on as it was
    (caster: the object it is cast from, None where it is gone); the first cast where there are several."""
    if not is_previewing(obj):
        return None
    return (bpy.data.images.get(obj.get("lapig_preview_image", "")), bool(obj.get("lapig_preview_appearance")),
            bpy.data.objects.get(obj.get("lapig_preview_caster", "")))


def _current_casts(obj, projector) -> list:
    """Every (caster, image) shown now, each one still there; the projector's own image where none is."""
    names = zip(obj.get("lapig_preview_casters", [obj.get("lapig_preview_caster", "")]),
                obj.get("lapig_preview_images", [obj.get("lapig_preview_image", "")]))
    casts = [(bpy.data.objects.get(c), bpy.data.images.get(i)) for c, i in names]
    casts = [(c, i) for c, i in casts if c is not None and i is not None]
    return casts or [(projector, projector_nodes.projected_image(projector.data))]


@contextlib.contextmanager
def real_surface(obj, projector):
    """The object in its own materials for the block (a capture must see the real surface, not the
    preview's tinted copies), then the preview back as it was."""
    previewing = is_previewing(obj)
    if previewing:
        casts, appearance = _current_casts(obj, projector), bool(obj.get("lapig_preview_appearance"))
        disable_preview(obj)
    try:
        yield
    finally:
        if previewing:
            enable_casts(obj, casts, appearance)


def disable_preview(obj):
    if not is_previewing(obj):
        return
    originals = list(obj[ORIGINALS_KEY])
    fake_users = list(obj.get("lapig_preview_fake_users", [False] * len(originals)))
    for slot, name, fake in zip(obj.material_slots, originals, fake_users):
        preview = slot.material
        original = bpy.data.materials.get(name) if name else None
        slot.material = original
        if original is not None:
            original.use_fake_user = fake
        if preview is not None and preview.name.startswith(PREVIEW_PREFIX) and preview.users == 0:
            bpy.data.materials.remove(preview)
    if obj.get("lapig_preview_added_slot"):
        obj.data.materials.pop(index=len(obj.data.materials) - 1)
        del obj["lapig_preview_added_slot"]
    del obj[ORIGINALS_KEY]
    obj.pop("lapig_preview_fake_users", None)
    obj.pop("lapig_preview_appearance", None)
    obj.pop("lapig_preview_image", None)
    obj.pop("lapig_preview_caster", None)
    obj.pop("lapig_preview_casters", None)
    obj.pop("lapig_preview_images", None)
    _remove_solid_mode_projection(obj)

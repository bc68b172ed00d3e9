"""Solid mode's share of the preview: the faces no projector can reach show none of its image.

Solid mode draws the image through the projected UV map alone (preview._add_solid_mode_projection), over every
face, so a cube's top and sides showed the front's image stretched. A Geometry Nodes modifier gives each face
turned away from every caster of the preview, or behind them all, a black material instead (UVs moved outside
the frame made such faces transparent in Solid mode, not dark). Solid mode has no room for the light's weight
(the material's preview, preview_weight, carries that): a face is in or out. Each caster reaches the modifier
through an Object Info node, so this follows it as it moves.
"""
from __future__ import annotations

import bpy

from .compat import material_node_tree

MODIFIER_NAME = "LAPIG projector reach"
UNREACHED_MATERIAL = "LAPIG not reached"


def _node(tree, kind, **settings):
    node = tree.nodes.new(kind)
    for name, value in settings.items():
        setattr(node, name, value)
    return node


def _reached_by(tree, caster):
    """The boolean field: the point's face turns towards `caster` and lies in front of it (it looks down -Z)."""
    links = tree.links
    info = _node(tree, "GeometryNodeObjectInfo", transform_space="RELATIVE")  # in the object's own space
    info.inputs["Object"].default_value = caster
    position, normal = _node(tree, "GeometryNodeInputPosition"), _node(tree, "GeometryNodeInputNormal")
    to_caster = _node(tree, "ShaderNodeVectorMath", operation="SUBTRACT")
    links.new(info.outputs["Location"], to_caster.inputs[0])
    links.new(position.outputs["Position"], to_caster.inputs[1])
    facing = _node(tree, "ShaderNodeVectorMath", operation="DOT_PRODUCT")
    links.new(normal.outputs["Normal"], facing.inputs[0])
    links.new(to_caster.outputs["Vector"], facing.inputs[1])
    forward = _node(tree, "FunctionNodeRotateVector")
    forward.inputs["Vector"].default_value = (0.0, 0.0, -1.0)
    links.new(info.outputs["Rotation"], forward.inputs["Rotation"])
    ahead = _node(tree, "ShaderNodeVectorMath", operation="DOT_PRODUCT")
    links.new(forward.outputs["Vector"], ahead.inputs[0])
    links.new(to_caster.outputs["Vector"], ahead.inputs[1])  # negative: in front of the caster
    faces = _node(tree, "FunctionNodeCompare", data_type="FLOAT", operation="GREATER_THAN")
    links.new(facing.outputs["Value"], faces.inputs["A"])
    in_front = _node(tree, "FunctionNodeCompare", data_type="FLOAT", operation="LESS_THAN")
    links.new(ahead.outputs["Value"], in_front.inputs["A"])
    both = _node(tree, "FunctionNodeBooleanMath", operation="AND")
    links.new(faces.outputs["Result"], both.inputs[0])
    links.new(in_front.outputs["Result"], both.inputs[1])
    return both.outputs[0]


def _reach_tree(name, casters) -> bpy.types.NodeTree:
    tree = bpy.data.node_groups.new(name, "GeometryNodeTree")
    tree.interface.new_socket("Geometry", in_out="INPUT", socket_type="NodeSocketGeometry")
    tree.interface.new_socket("Geometry", in_out="OUTPUT", socket_type="NodeSocketGeometry")
    links = tree.links
    group_in, group_out = _node(tree, "NodeGroupInput"), _node(tree, "NodeGroupOutput")
    reached = None
    for caster in casters:  # any caster's light reaches the face: it keeps the preview's material
        mine = _reached_by(tree, caster)
        if reached is not None:
            either = _node(tree, "FunctionNodeBooleanMath", operation="OR")
            links.new(reached, either.inputs[0])
            links.new(mine, either.inputs[1])
            mine = either.outputs[0]
        reached = mine
    unreached = _node(tree, "FunctionNodeBooleanMath", operation="NOT")
    links.new(reached, unreached.inputs[0])
    per_face = _node(tree, "GeometryNodeFieldOnDomain", data_type="BOOLEAN", domain="FACE")  # centre and normal
    links.new(unreached.outputs[0], per_face.inputs[0])
    dark = _node(tree, "GeometryNodeSetMaterial")
    dark.inputs["Material"].default_value = _unreached_material()
    links.new(group_in.outputs["Geometry"], dark.inputs["Geometry"])
    links.new(per_face.outputs[0], dark.inputs["Selection"])
    links.new(dark.outputs["Geometry"], group_out.inputs["Geometry"])
    return tree


def _unreached_material():
    """Black in every mode: no light reaches the face (Solid mode draws it by its viewport colour)."""
    material = bpy.data.materials.get(UNREACHED_MATERIAL) or bpy.data.materials.new(UNREACHED_MATERIAL)
    material.diffuse_color = (0.0, 0.0, 0.0, 1.0)
    tree = material_node_tree(material)
    bsdf = next((n for n in tree.nodes if n.bl_idname == "ShaderNodeBsdfPrincipled"), None)
    if bsdf is not None:
        bsdf.inputs["Base Color"].default_value = (0.0, 0.0, 0.0, 1.0)
    return material


def add_reach_modifier(obj, casters) -> None:
    """The faces none of `casters` (projectors, or the camera a result is cast from) reaches drawn in
    UNREACHED_MATERIAL."""
    modifier = obj.modifiers.new(MODIFIER_NAME, "NODES")
    modifier.node_group = _reach_tree(MODIFIER_NAME, casters)


def remove_reach_modifier(obj) -> None:
    modifier = obj.modifiers.get(MODIFIER_NAME)
    if modifier is None:
        return
    tree = modifier.node_group
    obj.modifiers.remove(modifier)
    if tree is not None and tree.users == 0:
        bpy.data.node_groups.remove(tree)
    material = bpy.data.materials.get(UNREACHED_MATERIAL)
    if material is not None and material.users == 0:
        bpy.data.materials.remove(material)

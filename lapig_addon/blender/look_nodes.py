"""A world look as a shader node group (services/generate/look_edit.node_recipe_of: the recipe, bpy-free): the texture node
with the sliders' Scale, Detail, Roughness, Distortion and seed, the look's colour ramp and a Hue/Saturation node,
into a group with a Color output; a Group node of it is added to the object's material, not connected, for the
artist to wire where it belongs."""
import bpy


def build_group(recipe: dict) -> bpy.types.ShaderNodeTree:
    """The node group of `recipe` (one of that name is replaced)."""
    old = bpy.data.node_groups.get(recipe["name"])
    if old is not None:
        bpy.data.node_groups.remove(old)
    group = bpy.data.node_groups.new(recipe["name"], "ShaderNodeTree")
    group.interface.new_socket("Color", in_out="OUTPUT", socket_type="NodeSocketColor")
    group.interface.new_socket("Factor", in_out="OUTPUT", socket_type="NodeSocketFloat")
    nodes, links = group.nodes, group.links
    coords = nodes.new("ShaderNodeTexCoord")
    texture = nodes.new(recipe["texture"])
    texture.name = "LAPIG texture"
    for attribute in ("voronoi_dimensions", "noise_dimensions"):  # the seed is the 4D texture's W
        if recipe["dimensions"] and hasattr(texture, attribute):
            setattr(texture, attribute, recipe["dimensions"])
    if recipe["texture"] == "ShaderNodeTexVoronoi" and recipe["feature"]:
        texture.feature = recipe["feature"]
    if recipe["texture"] == "ShaderNodeTexWave" and recipe["feature"]:
        texture.wave_type = recipe["feature"]
    for name, value in recipe["inputs"].items():
        if name in texture.inputs:
            texture.inputs[name].default_value = value
    ramp = nodes.new("ShaderNodeValToRGB")
    elements = ramp.color_ramp.elements
    stops = recipe["ramp"]
    while len(elements) < len(stops):
        elements.new(0.5)
    for element, (position, colour) in zip(elements, stops):
        element.position, element.color = position, colour
    hue = nodes.new("ShaderNodeHueSaturation")
    hue.inputs["Hue"].default_value = recipe["hue"]
    hue.inputs["Saturation"].default_value = recipe["saturation"]
    out = nodes.new("NodeGroupOutput")
    links.new(coords.outputs["Generated"], texture.inputs["Vector"])
    value = texture.outputs["Distance"] if "Distance" in texture.outputs else texture.outputs["Fac"]
    links.new(value, ramp.inputs["Fac"])
    links.new(ramp.outputs["Color"], hue.inputs["Color"])
    links.new(hue.outputs["Color"], out.inputs["Color"])
    links.new(value, out.inputs["Factor"])
    for i, node in enumerate((coords, texture, ramp, hue, out)):
        node.location = (i * 220.0, 0.0)
    return group


def add_to_material(obj, group) -> bpy.types.Node | None:
    """A Group node of `group` in the object's first material (None when it has none)."""
    material = _own_material(obj) if obj is not None else None
    if material is None:
        return None
    if material.node_tree is None:  # an old material without nodes (use_nodes goes in Blender 6)
        material.use_nodes = True
    node = material.node_tree.nodes.new("ShaderNodeGroup")
    node.node_tree, node.label = group, group.name
    node.location = (-600.0, 300.0)
    return node


def _own_material(obj):
    """The object's own first material, also while the preview has put its own in the slots."""
    from .preview import ORIGINALS_KEY

    if ORIGINALS_KEY in obj.keys():
        names = list(obj[ORIGINALS_KEY])
        return bpy.data.materials.get(names[0]) if names else None
    return obj.active_material

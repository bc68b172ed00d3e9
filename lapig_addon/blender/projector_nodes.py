"""The projector as a Cycles spot light whose node tree projects an image (Blender >= 4.0).

Geometry 'Incoming' in the light's object space gives the ray direction; x/z and y/z, scaled by
the throw ratio and offset by the lens shift, index an image texture (clip outside the frame,
closest-pixel so structured-light patterns stay pixel exact). See lapig_core.projector_model.
"""
from __future__ import annotations

import bpy

from ...lapig_core.optics import projector_cone
from .compat import light_local_direction, light_node_tree

NODE_PREFIX = "LAPIG "
TEXTURE_NODE = NODE_PREFIX + "projected image"


def _math(nodes, links, op, a, b, name):
    node = nodes.get(name) or nodes.new("ShaderNodeMath")
    node.name = node.label = name
    node.operation = op
    for index, value in enumerate((a, b)):
        if isinstance(value, (int, float)):
            node.inputs[index].default_value = value
        else:
            links.new(value, node.inputs[index])
    return node


def build_light_tree(light: bpy.types.SpotLight, model, image=None):
    """(Re)build the projection nodes of a spot light from a ProjectorModel; idempotent."""
    tree = light_node_tree(light)
    # the image texture bounds the frame; the cone only has to hold it (a wider one draws across the viewport)
    light.spot_size = projector_cone.spot_size(model)
    light.spot_blend = 0.0
    light.shadow_soft_size = 0.0  # pinhole: sharp pixels, noise-free direct light
    if hasattr(light, "use_soft_falloff"):
        light.use_soft_falloff = False  # keep the inverse-square law exact
    nodes, links = tree.nodes, tree.links
    for node in list(nodes):
        if node.bl_idname not in {"ShaderNodeEmission", "ShaderNodeOutputLight"} \
                and not node.name.startswith(NODE_PREFIX):
            nodes.remove(node)
    emission = next((n for n in nodes if n.bl_idname == "ShaderNodeEmission"), None) \
        or nodes.new("ShaderNodeEmission")
    output = next((n for n in nodes if n.bl_idname == "ShaderNodeOutputLight"), None) \
        or nodes.new("ShaderNodeOutputLight")
    links.new(emission.outputs[0], output.inputs["Surface"])
    emission.inputs["Strength"].default_value = 1.0

    split = nodes.get(NODE_PREFIX + "split") or nodes.new("ShaderNodeSeparateXYZ")
    split.name = NODE_PREFIX + "split"
    links.new(light_local_direction(nodes, links, NODE_PREFIX), split.inputs[0])

    sx, sy = model.uv_scale()
    # The ratio x/z does not depend on the sign of 'Incoming', so u = 0.5 + shift - s * x / z.
    u = _math(nodes, links, "DIVIDE", split.outputs["X"], split.outputs["Z"], NODE_PREFIX + "x/z")
    u = _math(nodes, links, "MULTIPLY", u.outputs[0], -sx, NODE_PREFIX + "u scale")
    u = _math(nodes, links, "ADD", u.outputs[0], 0.5 + model.shift_x, NODE_PREFIX + "u")
    v = _math(nodes, links, "DIVIDE", split.outputs["Y"], split.outputs["Z"], NODE_PREFIX + "y/z")
    v = _math(nodes, links, "MULTIPLY", v.outputs[0], -sy, NODE_PREFIX + "v scale")
    v = _math(nodes, links, "ADD", v.outputs[0], 0.5 + model.shift_y, NODE_PREFIX + "v")
    uv = nodes.get(NODE_PREFIX + "uv") or nodes.new("ShaderNodeCombineXYZ")
    uv.name = NODE_PREFIX + "uv"
    links.new(u.outputs[0], uv.inputs["X"])
    links.new(v.outputs[0], uv.inputs["Y"])

    texture = nodes.get(TEXTURE_NODE) or nodes.new("ShaderNodeTexImage")
    texture.name = texture.label = TEXTURE_NODE
    texture.extension = "CLIP"
    texture.interpolation = "Closest"
    links.new(uv.outputs[0], texture.inputs["Vector"])
    links.new(texture.outputs["Color"], emission.inputs["Color"])
    if image is not None:
        texture.image = image
    if is_show_image(texture.image):  # a baked show keeps its conversion, at the projector's gamma and black
        texture.image["lapig_gamma"], texture.image["lapig_black"] = float(model.gamma), float(model.black_level)
        _input_to_light(tree, texture)
    _layout(nodes)
    return texture


def _texture(light):
    texture = light.node_tree.nodes.get(TEXTURE_NODE) if light.node_tree else None
    if texture is None:
        raise RuntimeError(f"'{light.name}' is not a LAPIG projector light (no projection nodes)")
    return texture


def set_projected_image(light, image):
    """The light emits `image`: a float image of emitted light as it is (blender/result_sinks), or a baked show's
    sequence (set_projected_sequence) through its conversion to light, its frames where the show put them (a capture
    or a light report that borrowed the light gives it back so)."""
    texture = _texture(light)
    texture.image = image
    nodes = light.node_tree.nodes
    if is_show_image(image):
        user = texture.image_user
        user.frame_duration, user.frame_start = int(image["lapig_show_frames"]), int(image["lapig_show_start"])
        user.frame_offset, user.use_auto_refresh, user.use_cyclic = 0, True, False
        _input_to_light(light.node_tree, texture)
        return texture
    for name in (GAMMA_NODE, BLACK_NODE):  # a show's sequence is no longer shown
        if nodes.get(name) is not None:
            nodes.remove(nodes[name])
    emission = next((n for n in nodes if n.bl_idname == "ShaderNodeEmission"), None)
    if emission is not None:
        light.node_tree.links.new(texture.outputs["Color"], emission.inputs["Color"])
    return texture


GAMMA_NODE = NODE_PREFIX + "input gamma"
BLACK_NODE = NODE_PREFIX + "black level"
SHOW_IMAGE_PREFIX = "LAPIG show: "  # a baked show's image sequence (blender/show_timeline)


def is_show_image(image) -> bool:
    return image is not None and image.name.startswith(SHOW_IMAGE_PREFIX) and "lapig_show_frames" in image.keys()


def _input_to_light(tree, texture) -> None:
    """texture -> input^gamma -> black + (1 - black) * that -> emission: the light of projector input values
    (ProjectorModel.emitted, the gamma and black level the image records), as plain nodes, so a file holding the
    projector's pixels renders without the add-on."""
    nodes, links = tree.nodes, tree.links
    image = texture.image
    gamma = nodes.get(GAMMA_NODE) or nodes.new("ShaderNodeGamma")
    gamma.name = gamma.label = GAMMA_NODE
    gamma.inputs["Gamma"].default_value = float(image["lapig_gamma"])
    black = nodes.get(BLACK_NODE) or nodes.new("ShaderNodeVectorMath")
    black.name = black.label = BLACK_NODE
    black.operation = "MULTIPLY_ADD"
    b = float(image["lapig_black"])
    black.inputs[1].default_value = (1.0 - b,) * 3
    black.inputs[2].default_value = (b,) * 3
    emission = next(n for n in nodes if n.bl_idname == "ShaderNodeEmission")
    links.new(texture.outputs["Color"], gamma.inputs["Color"])
    links.new(gamma.outputs["Color"], black.inputs[0])
    links.new(black.outputs["Vector"], emission.inputs["Color"])
    gamma.location, black.location = (texture.location.x + 250, 0), (texture.location.x + 420, 0)


def set_projected_sequence(light, image, frame_count: int, frame_start: int, model):
    """The light projects a baked show: `image` (named SHOW_IMAGE_PREFIX + ...) a sequence of the projector's input
    pixels (PNG, Non-Color) whose first file is the scene's frame `frame_start`, `frame_count` files long; the nodes
    turn input into light as the projector does (model's gamma and black level). Blender advances it with the
    scene's frame. The image records all of it, so the light can be given it back."""
    if not image.name.startswith(SHOW_IMAGE_PREFIX):
        raise ValueError(f"a show's image is named '{SHOW_IMAGE_PREFIX}...', not '{image.name}'")
    image["lapig_show_frames"], image["lapig_show_start"] = int(frame_count), int(frame_start)
    image["lapig_gamma"], image["lapig_black"] = float(model.gamma), float(model.black_level)
    return set_projected_image(light, image)


def projected_image(light):
    texture = light.node_tree.nodes.get(TEXTURE_NODE) if light.node_tree else None
    return texture.image if texture else None


def _layout(nodes):
    order = ["geometry", "texture coordinate", "to local", "split", "x/z", "u scale", "u", "y/z", "v scale",
             "v", "uv", "projected image"]
    for column, name in enumerate(order):
        node = nodes.get(NODE_PREFIX + name)
        if node:
            node.location = (-1400 + 130 * column, 300 if name.startswith(("y", "v")) else 0)

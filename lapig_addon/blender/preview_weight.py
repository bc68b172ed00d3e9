"""How much of a cast image reaches each point of the preview material: what the projector's light would give.

A spot light lights a point by cos(incidence) / distance^2 and only in front of it; the preview's copy of the
material multiplies each cast by the same factor, normalised to 1 at normal incidence at the projector's focus
distance (where the rig aims it at the object): faces turned away get nothing, faces at grazing incidence (a
cube's top seen from in front) little, the point behind the projector where x/z, y/z would mirror the image
nothing. Outside the frame the image texture clips. An appearance (an image that already holds the surface's
shading, or one cast from the camera) is masked by the same visibility and not weighted again.

The projector's world position reaches the material through drivers, so the weight follows the projector as
it is moved, as the texture coordinates do. Shadows (parts of the object hidden from the projector behind
other parts) are not masked: a shadow map baked when the preview is turned on would go stale as soon as the
projector or the object moved, and black out lit parts; Rendered mode (Cycles, through the light) has them.
"""
from __future__ import annotations

WEIGHT_LABEL = "LAPIG light weight"


def _math(nodes, links, op, a, b=None, label=""):
    node = nodes.new("ShaderNodeMath")
    node.operation, node.label = op, label
    for index, value in enumerate((a, b)):
        if value is None:
            continue
        if isinstance(value, (int, float)):
            node.inputs[index].default_value = value
        else:
            links.new(value, node.inputs[index])
    return node.outputs[0]


def _vector_math(nodes, links, op, a, b=None, output="Vector"):
    node = nodes.new("ShaderNodeVectorMath")
    node.operation = op
    links.new(a, node.inputs[0])
    if b is not None:
        links.new(b, node.inputs[1])
    return node.outputs[output]


def projector_position(nodes, caster):
    """A Combine XYZ whose inputs are driven by the caster's world location."""
    position = nodes.new("ShaderNodeCombineXYZ")
    position.label = "LAPIG projector position"
    for index, axis in enumerate("XYZ"):
        fcurve = position.inputs[axis].driver_add("default_value")
        driver = fcurve.driver
        driver.type = "SUM"  # one transform variable: no Python expression, so it runs with scripts off
        variable = driver.variables.new()
        variable.type = "TRANSFORMS"
        target = variable.targets[0]
        target.id = caster
        target.transform_type, target.transform_space = f"LOC_{axis}", "WORLD_SPACE"
    return position


def weight(tree, caster, local_z, reference_distance: float, as_light: bool):
    """The weight socket of one cast: local_z is the Z of the point in the caster's space (the Texture
    Coordinate 'Object' of the projection nodes); as_light: cos / distance^2 (a projector's light), else the
    visibility mask alone (an appearance)."""
    nodes, links = tree.nodes, tree.links
    geometry = nodes.new("ShaderNodeNewGeometry")
    to_caster = _vector_math(nodes, links, "SUBTRACT", projector_position(nodes, caster).outputs[0],
                             geometry.outputs["Position"])
    direction = _vector_math(nodes, links, "NORMALIZE", to_caster)
    cosine = _vector_math(nodes, links, "DOT_PRODUCT", geometry.outputs["Normal"], direction, output="Value")
    in_front = _math(nodes, links, "LESS_THAN", local_z, 0.0, "in front of the projector")
    if not as_light:
        facing = _math(nodes, links, "GREATER_THAN", cosine, 0.0, "faces the caster")
        return _math(nodes, links, "MULTIPLY", facing, in_front, WEIGHT_LABEL)
    lit = _math(nodes, links, "MAXIMUM", cosine, 0.0, "cos incidence")
    distance = _vector_math(nodes, links, "LENGTH", to_caster, output="Value")
    ratio = _math(nodes, links, "DIVIDE", float(reference_distance), distance)
    falloff = _math(nodes, links, "MULTIPLY", ratio, ratio, "inverse square")
    lit = _math(nodes, links, "MULTIPLY", lit, falloff)
    return _math(nodes, links, "MULTIPLY", lit, in_front, WEIGHT_LABEL)


def weighted(tree, colour, weight_socket):
    """colour x weight."""
    node = tree.nodes.new("ShaderNodeVectorMath")
    node.operation = "SCALE"
    tree.links.new(colour, node.inputs[0])
    tree.links.new(weight_socket, node.inputs["Scale"])
    return node.outputs["Vector"]

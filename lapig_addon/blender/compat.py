"""Differences between the Blender releases the extension supports (4.2 LTS to 5.3), in one place.

Each shim names the releases it is for; scripts/test_blender_versions.sh runs the add-on's tests on
4.2.23, 4.5.15, 5.0.1, 5.1.2, 5.2.3 and 5.3.0 (4.3 and 4.4 are not tested).
"""
import contextlib

import bpy

# options of a path property that stores '//' paths relative to the .blend (a warning from 4.5 on without)
RELATIVE_PATH_OPTIONS = {"PATH_SUPPORTS_BLEND_RELATIVE"} if bpy.app.version >= (4, 5, 0) else set()


def material_node_tree(material):
    """The material's node tree; 4.x materials may start without one (5.0 always has one)."""
    if getattr(material, "node_tree", None) is None:
        material.use_nodes = True  # deprecated in 5.0, where this branch never runs
    return material.node_tree


def light_node_tree(light):
    """The light's node tree, switched on.

    4.2-5.0: a new light has use_nodes off (and on 4.x no tree at all): turn it on.
    5.1 and later: Light.use_nodes is deprecated (to be removed in 6.0) and ignored, since every light
    renders its tree; setting it only warns, so it is left alone."""
    if bpy.app.version < (5, 1, 0) or light.node_tree is None:
        light.use_nodes = True
    return light.node_tree


def light_local_direction(nodes, links, prefix):
    """The socket that gives each ray's direction in the light's own space, inside a light's node tree.

    4.5 and later: Geometry 'Incoming' through a Vector Transform world -> object. 5.3 gave the Vector
    Transform node a 'LightIndex' input in front of 'Vector', so the input is found by name.
    4.2 (checked on 4.2.23; 4.3 and 4.4 are not tested): the object space of a Vector Transform is
    garbage in a light shader, so the projection came out as one flat colour. Texture Coordinate
    'Normal' gives the same light-space direction there (equal to the 4.5 path on 4.2.23, 4.5.15,
    5.0.1 and 5.3.0)."""
    if bpy.app.version < (4, 5, 0):
        coords = nodes.get(prefix + "texture coordinate") or nodes.new("ShaderNodeTexCoord")
        coords.name = prefix + "texture coordinate"
        return coords.outputs["Normal"]
    geometry = nodes.get(prefix + "geometry") or nodes.new("ShaderNodeNewGeometry")
    geometry.name = prefix + "geometry"
    to_local = nodes.get(prefix + "to local") or nodes.new("ShaderNodeVectorTransform")
    to_local.name = prefix + "to local"
    to_local.vector_type, to_local.convert_from, to_local.convert_to = "VECTOR", "WORLD", "OBJECT"
    links.new(geometry.outputs["Incoming"], to_local.inputs["Vector"])
    return to_local.outputs["Vector"]


@contextlib.contextmanager
def unregistered_at_exit():
    """Unregister the add-on when the block ends, before the interpreter exits.

    4.2 and 4.5 (the bpy module; checked on 4.2.23 and 4.5.15): Python crashes at exit (SIGSEGV) or
    hangs while an operator class is still registered, so a headless command that registered the
    add-on failed with status -11 after its work was done. 5.0 and later exit cleanly either way."""
    try:
        yield
    finally:
        from . import addon

        if addon.is_registered():
            addon.unregister()

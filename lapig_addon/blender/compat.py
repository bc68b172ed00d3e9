"""Differences between the Blender versions the extension supports (4.2 to 5.0)."""
import bpy

# options of a path property that stores '//' paths relative to the .blend (a warning from 4.5 on without)
RELATIVE_PATH_OPTIONS = {"PATH_SUPPORTS_BLEND_RELATIVE"} if bpy.app.version >= (4, 5, 0) else set()


def material_node_tree(material):
    """The material's node tree; 4.x materials may start without one (5.0 always has one)."""
    if getattr(material, "node_tree", None) is None:
        material.use_nodes = True  # deprecated in 5.0, where this branch never runs
    return material.node_tree

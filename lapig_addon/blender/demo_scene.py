"""Demo and test scenes: a textured wall panel, a box, and a statue-like curved mesh."""
from __future__ import annotations

import math
import os

import bpy
import numpy as np

from ...lapig_core.common.imageio import write_png
from ...lapig_core.common.surfaces import make_surface
from .compat import material_node_tree

SHAPES = ("panel", "box", "statue")


def textured_material(name, texture_path):
    mat = bpy.data.materials.new(name)
    tree = material_node_tree(mat)
    nodes, links = tree.nodes, tree.links
    bsdf = next(n for n in nodes if n.bl_idname == "ShaderNodeBsdfPrincipled")
    bsdf.inputs["Roughness"].default_value = 1.0  # matte, like a projection surface
    bsdf.inputs["Specular IOR Level"].default_value = 0.0
    tex = nodes.new("ShaderNodeTexImage")
    tex.image = bpy.data.images.load(texture_path, check_existing=True)
    tex.location = (-400, 200)
    links.new(tex.outputs["Color"], bsdf.inputs["Base Color"])
    return mat


def add_surface_object(shape="panel", surface="sakura", folder=None, seed=0, size=512, tint=(1.0, 1.0, 1.0),
                       texture=None):
    """Add a textured object to the current scene and return it; the texture PNG goes to folder.

    tint multiplies the albedo (coloured, very dark or bright materials); texture, an RGB array in
    [0,1], replaces the procedural surface (a user's image in `eval`).
    """
    if shape not in SHAPES:
        raise ValueError(f"unknown shape '{shape}': choose one of {', '.join(SHAPES)}")
    folder = folder or bpy.app.tempdir
    albedo = make_surface(surface, size=size, seed=seed) if texture is None else texture
    albedo = np.clip(albedo * np.asarray(tint, np.float32), 0, 1)
    tag = "" if tuple(tint) == (1.0, 1.0, 1.0) else "_tinted"
    texture_path = os.path.join(folder, f"surface_{surface}_{seed}{tag}.png")
    write_png(texture_path, albedo)
    if shape == "panel":
        bpy.ops.mesh.primitive_plane_add(size=2.0, location=(0, 0, 1.0), rotation=(math.pi / 2, 0, 0))
    elif shape == "box":
        bpy.ops.mesh.primitive_cube_add(size=1.2, location=(0, 0, 0.6), rotation=(0, 0, math.radians(25)))
    else:
        bpy.ops.mesh.primitive_monkey_add(size=1.5, location=(0, 0, 1.0), rotation=(math.radians(90), 0, 0))
        bpy.ops.object.shade_smooth()
        mod = bpy.context.object.modifiers.new("Subdivision", "SUBSURF")
        mod.levels = mod.render_levels = 1
    obj = bpy.context.object
    obj.name = f"LAPIG demo {shape}"
    if shape in ("box", "statue"):
        bpy.ops.object.mode_set(mode="EDIT")
        bpy.ops.uv.smart_project()
        bpy.ops.object.mode_set(mode="OBJECT")
    obj.data.materials.clear()
    obj.data.materials.append(textured_material(f"{surface} surface", texture_path))
    return obj


def new_empty_scene():
    bpy.ops.wm.read_factory_settings(use_empty=True)
    return bpy.context.scene

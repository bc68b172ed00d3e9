"""Demo and test scenes: a textured wall panel, a box, and a statue-like curved mesh."""
from __future__ import annotations

import math
import os

import bpy
import numpy as np

from ...lapig_core.common.imageio import write_png
from ...lapig_core.common.surfaces import make_surface
from .compat import material_node_tree

SHAPES = ("panel", "box", "statue", "corner", "bowl", "vase", "relief")
FINISHES = ("matte", "glazed", "marble")


def _finish(bsdf, finish):
    """The surface's material beyond its texture: a glaze's gloss, or marble's subsurface light."""
    if finish == "glazed":  # a glazed ceramic: the projector's reflection shows as a highlight
        bsdf.inputs["Roughness"].default_value = 0.12
        bsdf.inputs["Specular IOR Level"].default_value = 0.8
        bsdf.inputs["Coat Weight"].default_value = 0.6
        bsdf.inputs["Coat Roughness"].default_value = 0.05
    elif finish == "marble":  # light enters and leaves a few centimetres away
        bsdf.inputs["Roughness"].default_value = 0.35
        bsdf.inputs["Specular IOR Level"].default_value = 0.4
        bsdf.inputs["Subsurface Weight"].default_value = 1.0
        bsdf.inputs["Subsurface Radius"].default_value = (1.0, 0.75, 0.55)
        bsdf.inputs["Subsurface Scale"].default_value = 0.04
    elif finish != "matte":
        raise ValueError(f"unknown finish '{finish}': choose one of {', '.join(FINISHES)}")


def textured_material(name, texture_path, finish="matte"):
    mat = bpy.data.materials.new(name)
    tree = material_node_tree(mat)
    nodes, links = tree.nodes, tree.links
    bsdf = next(n for n in nodes if n.bl_idname == "ShaderNodeBsdfPrincipled")
    bsdf.inputs["Roughness"].default_value = 1.0  # matte, like a projection surface
    bsdf.inputs["Specular IOR Level"].default_value = 0.0
    _finish(bsdf, finish)
    tex = nodes.new("ShaderNodeTexImage")
    tex.image = bpy.data.images.load(texture_path, check_existing=True)
    tex.location = (-400, 200)
    links.new(tex.outputs["Color"], bsdf.inputs["Base Color"])
    return mat


def add_surface_object(shape="panel", surface="sakura", folder=None, seed=0, size=512, tint=(1.0, 1.0, 1.0),
                       texture=None, finish="matte"):
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
    elif shape == "statue":
        bpy.ops.mesh.primitive_monkey_add(size=1.5, location=(0, 0, 1.0), rotation=(math.radians(90), 0, 0))
        bpy.ops.object.shade_smooth()
        mod = bpy.context.object.modifiers.new("Subdivision", "SUBSURF")
        mod.levels = mod.render_levels = 1
    else:
        _add_mesh(shape)
    obj = bpy.context.object
    obj.name = f"LAPIG demo {shape}"
    if shape != "panel":
        bpy.ops.object.mode_set(mode="EDIT")
        bpy.ops.uv.smart_project()
        bpy.ops.object.mode_set(mode="OBJECT")
    obj.data.materials.clear()
    obj.data.materials.append(textured_material(f"{surface} surface", texture_path, finish))
    return obj


def _mesh_object(name, verts, faces, smooth=False):
    mesh = bpy.data.meshes.new(name)
    mesh.from_pydata([tuple(v) for v in verts], [], [tuple(f) for f in faces])
    mesh.update()
    if smooth:
        mesh.shade_smooth()
    obj = bpy.data.objects.new(name, mesh)
    bpy.context.collection.objects.link(obj)
    for other in bpy.context.selected_objects:
        other.select_set(False)
    obj.select_set(True)
    bpy.context.view_layer.objects.active = obj
    return obj


def _grid(nu, nv, point):
    """Vertices point(u, v) on an nu x nv grid of [0,1]^2 and its quads (front side towards -y)."""
    verts = [point(i / (nu - 1), j / (nv - 1)) for j in range(nv) for i in range(nu)]
    faces = [(j * nu + i, j * nu + i + 1, (j + 1) * nu + i + 1, (j + 1) * nu + i)
             for j in range(nv - 1) for i in range(nu - 1)]
    return verts, faces


def _add_mesh(shape):
    """The concave and curved benchmark shapes, built from vertices (no add-on operators needed)."""
    if shape == "corner":  # two 2 m walls at 90 degrees, opening towards -y (where the rig goes)
        def point(u, v):
            s = (u - 0.5) * 2 * math.sqrt(2)  # -1.41 .. 1.41 m along the unfolded walls
            return (s / math.sqrt(2), -abs(s) / math.sqrt(2), 2 * v)  # the corner's edge at the back
        verts, faces = _grid(33, 17, point)
        obj = _mesh_object("corner", verts, faces)
    elif shape == "bowl":  # a niche: the back half of a sphere of radius 1 m, seen from inside
        def point(u, v):
            az, el = math.pi * u, math.pi * (v - 0.5)
            return (-math.cos(az) * math.cos(el), math.sin(az) * math.cos(el), 1.0 + math.sin(el))
        verts, faces = _grid(33, 25, point)
        obj = _mesh_object("bowl", verts, faces, smooth=True)
    elif shape == "vase":  # a closed surface of revolution, 1.6 m tall
        def radius(t):
            return 0.28 + 0.3 * math.sin(math.pi * (0.15 + 0.75 * t)) - 0.12 * t
        def point(u, v):
            a = 2 * math.pi * u
            return (radius(v) * math.cos(a), radius(v) * math.sin(a), 0.2 + 1.6 * v)
        verts, faces = _grid(48, 24, point)
        obj = _mesh_object("vase", verts, faces, smooth=True)
    elif shape == "relief":  # a 2 m panel with bumps up to 0.25 m deep
        def point(u, v):
            x, z = (u - 0.5) * 2, 0.2 + v * 2
            bump = 0.25 * (0.5 + 0.5 * math.sin(3 * math.pi * u) * math.sin(2 * math.pi * v))
            return (x, bump, z)
        verts, faces = _grid(61, 61, point)
        obj = _mesh_object("relief", verts, faces, smooth=True)
    else:
        raise ValueError(f"unknown shape '{shape}': choose one of {', '.join(SHAPES)}")
    return obj


def new_empty_scene():
    bpy.ops.wm.read_factory_settings(use_empty=True)
    return bpy.context.scene

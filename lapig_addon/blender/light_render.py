"""Light maps in lux over the projector's pixels, rendered by Cycles from the projector's own viewpoint.

A temporary scene links the renderable objects and a camera at the projector's pose with its
frustum (throw ratio, lens shift), so camera pixel (i, j) looks along projector pixel (i, j)'s ray and
sees what that pixel lights. One render with the projector showing white gives, per pixel, Cycles'
Diffuse Direct pass (E / pi, the albedo left out: lux = 683 pi pass, lapig_core.photometry.units), the
Diffuse Color pass (the albedo) and the object and material index passes (the object, a marked
material, or the faces of a vertex group, rendered as a temporary part of their own); a second render, with the projector off, gives the room's light: a uniform world of that
illuminance, or a Sun of it from the lamp's direction. Each map pixel averages 4 samples over its square
(a map pixel covers several projector pixels); the room light from every direction takes more.
Everything is undone on exit, even after an error; the user's scene is never rendered.

A job renders through render_steps(): one Cycles render each time it goes on, on Blender's main thread, into
LightPasses (EXR files) that lapig_core/photometry/light_passes turns into the maps on any thread.
"""
from __future__ import annotations

import os
import tempfile

import bpy
import numpy as np
from mathutils import Vector

from ...lapig_core.common.closing import BuiltOnEnter
from ...lapig_core.common.exr import read_exr_channels
from ...lapig_core.common.steps import run_to_end
from ...lapig_core.photometry.light_passes import (REGION_INDEX, TARGET_INDEX, LightPasses,  # noqa: F401
                                                   LightRenderError, ProjectorLightMaps, _rgb)
from ...lapig_core.photometry.units import lux_from_diffuse_direct, sun_strength_for_lux, world_strength_for_lux
from . import preview, projector_nodes
from .studio_scene import linear_cycles, studio_scene

STUDIO = "LAPIG light studio"


def _white_image(width, height):
    image = bpy.data.images.new(STUDIO + " white", width, height, float_buffer=True)
    image.colorspace_settings.name = "Non-Color"
    image.pixels.foreach_set(np.ones(width * height * 4, np.float32))
    return image


class LightStudio(BuiltOnEnter):
    def __init__(self, scene, projector, target, width: int, height: int, ambient_lux: float = 0.0,
                 lamp_direction=None, region_material: str = "", ambient_samples: int = 32, region_group: str = "",
                 view=None):
        self.source, self.projector, self.target = scene, projector, target
        self.view = view  # a camera object: the maps over its pixels (several projectors' light adds there)
        self.region_group = region_group
        self.width, self.height = width, height
        self.ambient_lux, self.lamp_direction = ambient_lux, lamp_direction
        self.region_material = region_material
        self.ambient_samples = ambient_samples
        self._made, self._saved = [], []
        self.scene = None
        self._dir = None

    def _build(self):
        # the object in its own materials (the preview's copies are unlit or tinted), the preview back on close
        self._surface = preview.real_surface(self.target, self.projector)
        self._surface.__enter__()
        material = None
        if self.region_material:
            material = bpy.data.materials.get(self.region_material)
            used = {slot.material for slot in self.target.material_slots}
            if material is None or material not in used:
                names = ", ".join(sorted(m.name for m in used if m)) or "none"
                raise LightRenderError(f"'{self.target.name}' has no material '{self.region_material}' to mark "
                                       f"(its materials: {names})")
        p = self.projector.lapig_projector
        if self.view is None and abs(self.width / self.height - p.resolution_x / p.resolution_y) > \
                0.02 * p.resolution_x / p.resolution_y:
            raise LightRenderError(f"a light map of {self.width} x {self.height} does not have the projector's "
                                   f"{p.resolution_x} x {p.resolution_y} shape")
        self._dir = tempfile.mkdtemp(prefix="lapig_light_")
        scene = self.scene = studio_scene(STUDIO, self.source)
        cam_data = bpy.data.cameras.new(STUDIO) if self.view is None else self.view.data.copy()
        cam = bpy.data.objects.new(STUDIO, cam_data)
        self._made += [cam, cam_data]
        scene.collection.objects.link(cam)
        scene.camera = cam
        if self.view is not None:  # the rig's camera as it is: its lens, sensor and shift, its pose
            cam.matrix_world = self.view.matrix_world.normalized()
        else:
            cam.matrix_world = self.projector.matrix_world.normalized()
            p = self.projector.lapig_projector
            w, h = p.resolution_x, p.resolution_y
            cam_data.sensor_fit = "HORIZONTAL"
            cam_data.sensor_width = 36.0
            cam_data.lens = p.throw_ratio * 36.0  # focal / sensor width = distance / image width
            cam_data.clip_start = 0.001
            cam_data.clip_end = 1e5
            s = max(w, h)  # Blender's shift is in units of the larger side; LAPIG's image shift runs opposite
            cam_data.shift_x = -p.shift_x * w / s
            cam_data.shift_y = -p.shift_y * h / s
        world = bpy.data.worlds.new(STUDIO)
        self._made.append(world)
        scene.world = world
        linear_cycles(scene, self.width, self.height, "OPEN_EXR_MULTILAYER")
        layer = scene.view_layers[0]
        layer.use_pass_diffuse_direct = layer.use_pass_diffuse_color = True
        layer.use_pass_object_index = layer.use_pass_material_index = True
        # the index passes say what is the object and the region: nothing else may carry their numbers
        for ob in scene.collection.objects:
            if ob is not self.target and ob.pass_index in (TARGET_INDEX, REGION_INDEX):
                self._saved.append((ob, "pass_index", ob.pass_index))
                ob.pass_index = 0
        for slot in self.target.material_slots:
            if slot.material is not None and slot.material is not material and slot.material.pass_index == REGION_INDEX:
                self._saved.append((slot.material, "pass_index", slot.material.pass_index))
                slot.material.pass_index = 0
        self._saved.append((self.target, "pass_index", self.target.pass_index))
        self.target.pass_index = TARGET_INDEX
        if self.region_group:  # the object as two temporary parts: the group's faces and the rest
            for part, index in zip(self._split_by_group(), (REGION_INDEX, TARGET_INDEX)):
                part.pass_index = index
                scene.collection.objects.link(part)
            if self.target.name in scene.collection.objects:
                scene.collection.objects.unlink(self.target)
        if material is not None:
            self._saved.append((material, "pass_index", material.pass_index))
            material.pass_index = REGION_INDEX
        self._saved_image = projector_nodes.projected_image(self.projector.data)

    def _split_by_group(self):
        import bmesh

        group = self.target.vertex_groups.get(self.region_group) if self.target.type == "MESH" else None
        if group is None:
            names = ", ".join(g.name for g in getattr(self.target, "vertex_groups", [])) or "none"
            raise LightRenderError(f"'{self.target.name}' has no vertex group '{self.region_group}' (its vertex "
                                   f"groups: {names})")
        depsgraph = bpy.context.evaluated_depsgraph_get()
        parts = []
        for inside in (True, False):
            bm = bmesh.new()
            try:
                bm.from_object(self.target, depsgraph)
                layer = bm.verts.layers.deform.active
                if layer is None:
                    raise LightRenderError(f"the vertex group '{self.region_group}' has no weights")

                def in_group(face):
                    return all(v[layer].get(group.index, 0.0) >= 0.5 for v in face.verts)
                drop = [f for f in bm.faces if in_group(f) != inside]
                if inside and len(drop) == len(bm.faces):
                    raise LightRenderError(f"the vertex group '{self.region_group}' has no faces (no face has all "
                                           "its vertices at weight 0.5 or more): assign faces to it")
                bmesh.ops.delete(bm, geom=drop, context="FACES")
                mesh = bpy.data.meshes.new(STUDIO + " region" if inside else STUDIO + " rest")
                bm.to_mesh(mesh)
            finally:
                bm.free()
            for slot in self.target.material_slots:
                mesh.materials.append(slot.material)
            part = bpy.data.objects.new(mesh.name, mesh)
            part.matrix_world = self.target.matrix_world
            self._made[:0] = [part, mesh]
            parts.append(part)
        return parts

    def close(self):
        if self.projector is not None and getattr(self, "_saved_image", None) is not None:
            try:
                projector_nodes.set_projected_image(self.projector.data, self._saved_image)
            except (RuntimeError, ReferenceError):
                pass
        for owner, attr, value in reversed(self._saved):
            try:
                setattr(owner, attr, value)
            except ReferenceError:
                pass
        self._saved = []
        if self.scene is not None:
            bpy.data.scenes.remove(self.scene)
            self.scene = None
        for block in self._made:
            try:
                collection = {bpy.types.Object: bpy.data.objects, bpy.types.Camera: bpy.data.cameras,
                              bpy.types.World: bpy.data.worlds, bpy.types.Image: bpy.data.images,
                              bpy.types.Light: bpy.data.lights, bpy.types.Mesh: bpy.data.meshes}[type(block)]
                collection.remove(block)
            except (KeyError, ReferenceError):
                pass
        self._made = []
        if self._dir:
            for name in os.listdir(self._dir):
                os.remove(os.path.join(self._dir, name))
            os.rmdir(self._dir)
            self._dir = None
        surface, self._surface = getattr(self, "_surface", None), None
        if surface is not None:
            surface.__exit__(None, None, None)

    def _render(self, name, samples, filter_width, folder=None) -> str:
        """One Cycles render of the studio into `folder` (default: the studio's own); the EXR's path, its rows
        top-down as the projector frame."""
        scene = self.scene
        scene.cycles.samples = samples
        scene.cycles.filter_width = filter_width
        path = os.path.join(folder or self._dir, name + ".exr")
        scene.render.filepath = path
        with bpy.context.temp_override(scene=scene):
            bpy.ops.render.render(write_still=True, scene=scene.name)
        return path

    @property
    def render_count(self) -> int:
        """How many Cycles renders render_steps() makes: the projector's light, and the room's where it has any."""
        return 2 if self.ambient_lux > 0 else 1

    def render_steps(self):
        """The maps' Cycles renders, one each time the steps go on (a job's main-thread steps): before each, the
        name of what it renders is yielded; the value is their LightPasses, which the caller turns into maps
        (maps(), on any thread) or discards. A cancel (the generator closed) removes the files made so far."""
        folder = tempfile.mkdtemp(prefix="lapig_light_passes_")
        passes = LightPasses(folder, os.path.join(folder, "white.exr"),
                             region="group" if self.region_group else "material" if self.region_material else "")
        try:
            yield "the projector's light"
            self._render_white(folder)
            if self.ambient_lux > 0:
                yield "the room's light"
                passes.room = self._render_room(folder)
        except BaseException:
            passes.discard()
            raise
        return passes

    def render_maps(self) -> ProjectorLightMaps:
        """The maps, rendered and read here (a command, a test, a benchmark: a job uses render_steps())."""
        return run_to_end(self.render_steps()).maps()

    def _render_white(self, folder) -> str:
        scene = self.scene
        white = _white_image(8, 8)
        self._made.append(white)
        projector_nodes.set_projected_image(self.projector.data, white)
        scene.collection.objects.link(self.projector)
        bg = self._background()
        if bg is not None:
            bg.inputs["Strength"].default_value = 0.0
        scene.world.color = (0, 0, 0)
        # 4 samples over each pixel's square: the light it covers; a ray exactly through a pixel centre can
        # graze the shared edge of two triangles and find it dark
        try:
            return self._render("white", 4, 1.0, folder)
        finally:
            scene.collection.objects.unlink(self.projector)

    def _background(self):
        scene = self.scene
        return scene.world.node_tree.nodes.get("Background") if scene.world.node_tree else None

    def render_frame_lux(self, emitted: np.ndarray) -> np.ndarray:
        """The illuminance (lux, H x W) the projector alone gives while it emits `emitted` (relative
        light, the frame's native H x W x 3): 4 samples within a quarter pixel of each map pixel's centre,
        so at the native size each stays inside its own projector pixel (a ray exactly through the centre
        can graze the shared edge of two triangles and find it dark)."""
        h, w = emitted.shape[:2]
        image = bpy.data.images.new(STUDIO + " frame", w, h, float_buffer=True)
        self._made.append(image)
        image.colorspace_settings.name = "Non-Color"
        rgba = np.ones((h, w, 4), np.float32)
        rgba[..., :3] = emitted
        image.pixels.foreach_set(np.flipud(rgba).ravel())  # Blender's rows run bottom-up
        projector_nodes.set_projected_image(self.projector.data, image)
        scene = self.scene
        bg = self._background()
        if bg is not None:
            bg.inputs["Strength"].default_value = 0.0
        for ob in [o for o in scene.collection.objects if o.type == "LIGHT"]:
            scene.collection.objects.unlink(ob)
        scene.collection.objects.link(self.projector)
        try:
            lit = read_exr_channels(self._render("frame", 4, 0.5))
        finally:
            scene.collection.objects.unlink(self.projector)
        return lux_from_diffuse_direct(_rgb(lit, "Diffuse Direct", "DiffDir"))

    def _render_room(self, folder) -> str:
        """The room's light alone (the projector unlinked): its EXR's path."""
        scene = self.scene
        bg = self._background()
        if self.lamp_direction is None:  # light from every direction: E = pi L on an open surface
            if bg is None:
                raise LightRenderError("the light studio's world has no Background node")
            bg.inputs["Color"].default_value = (1, 1, 1, 1)
            bg.inputs["Strength"].default_value = world_strength_for_lux(self.ambient_lux)
            samples = self.ambient_samples
        else:  # a lamp: a Sun whose illuminance on a surface facing it is the room's lux
            sun = bpy.data.lights.new(STUDIO + " lamp", "SUN")
            sun.energy = sun_strength_for_lux(self.ambient_lux)
            sun.angle = 0.0
            sun_obj = bpy.data.objects.new(STUDIO + " lamp", sun)
            self._made[:0] = [sun_obj, sun]
            direction = Vector(self.lamp_direction).normalized()  # the way the light travels
            sun_obj.rotation_euler = direction.to_track_quat("-Z", "Y").to_euler()
            scene.collection.objects.link(sun_obj)
            samples = 1
        return self._render("room", samples, 1.0 if samples > 1 else 0.01, folder)


def projector_light_maps(scene, projector, target, width: int, height: int, ambient_lux: float = 0.0,
                         lamp_direction=None, region_material: str = "", ambient_samples: int = 32,
                         region_group: str = ""):
    """ProjectorLightMaps of the rig at width x height projector-view pixels (see the module)."""
    if projector is None or target is None:
        raise LightRenderError("set up the rig first: there is no projector or no object")
    with LightStudio(scene, projector, target, width, height, ambient_lux, lamp_direction, region_material,
                     ambient_samples, region_group) as studio:
        return studio.render_maps()

"""A temporary scene that renders the user's objects lit by the projector alone.

Captures never touch the user's scene: the studio links the same objects into a scene of its own
(its own render settings, a dark world and a dim ambient 'room light'), swaps the projector's image
for a sequence of patterns, and undoes all of it on close, even after an error or a cancel.
"""
from __future__ import annotations

import contextlib
import math
import os
import shutil
import tempfile

import bpy
import numpy as np

from ...lapig_core.common.closing import BuiltOnEnter
from ...lapig_core.common.exr import ExrError, pass_rgb, read_exr_channels
from ...lapig_core.common.scratch import ScratchFolder
from ...lapig_core.optics.transport import (FAST, LightTransport, NormalGuide, indirect_from_light_passes,
                                            indirect_from_passes)
from . import projector_nodes
from .studio_scene import linear_cycles, studio_scene

STUDIO_NAME = "LAPIG capture studio"
# the view-layer passes the 'passes' bounce method reads (lapig_core.common.exr reads the file)
LIGHT_PASSES = ("use_pass_normal", "use_pass_diffuse_indirect", "use_pass_diffuse_color",
                "use_pass_glossy_indirect", "use_pass_glossy_color")
TRANSMISSION_PASSES = ("use_pass_transmission_indirect", "use_pass_transmission_color")
SUBSURFACE_PASSES = ("use_pass_subsurface_indirect", "use_pass_subsurface_color")
# each pass's name in Blender 5 and in 4.x's multilayer files
PASS_NAMES = {"diffuse": ("Diffuse Indirect", "DiffInd"), "diffuse_colour": ("Diffuse Color", "DiffCol"),
              "glossy": ("Glossy Indirect", "GlossInd"), "glossy_colour": ("Glossy Color", "GlossCol"),
              "transmission": ("Transmission Indirect", "TransInd"),
              "transmission_colour": ("Transmission Color", "TransCol"),
              "subsurface": ("Subsurface Indirect", "SubsurfaceInd"),
              "subsurface_colour": ("Subsurface Color", "SubsurfaceCol")}


def read_exr_rgba(path) -> tuple[np.ndarray, np.ndarray]:
    """(linear RGB, alpha): alpha is where the camera sees a surface (the world is transparent)."""
    os.environ.setdefault("OPENCV_IO_ENABLE_OPENEXR", "1")  # read lazily by OpenCV
    import cv2

    data = cv2.imread(str(path), cv2.IMREAD_UNCHANGED)
    if data is None:
        raise OSError(f"could not read the rendered capture {path}")
    rgb = np.ascontiguousarray(data[..., 2::-1], dtype=np.float32)
    alpha = np.ascontiguousarray(data[..., 3], dtype=np.float32) if data.shape[-1] == 4 else np.ones(rgb.shape[:2],
                                                                                                    np.float32)
    return rgb, alpha


def read_exr_rgb(path) -> np.ndarray:
    return read_exr_rgba(path)[0]


def write_pattern(path, emitted: np.ndarray):
    """Relative emitted light (H, W, 3) in [0,1] -> 16-bit TIFF the light's texture reads raw.

    Uncompressed TIFF writes in ~5 ms where a 16-bit PNG takes 30-80 ms at 800x600.
    """
    import cv2

    data = np.round(np.clip(emitted, 0, 1)[..., ::-1] * 65535).astype(np.uint16)
    if not cv2.imwrite(str(path), data, [cv2.IMWRITE_TIFF_COMPRESSION, 1]):
        raise OSError(f"could not write the projector pattern {path} (disk full?)")


def _materials_use(objects, node_types: tuple, principled_input: str) -> bool:
    for ob in objects:
        for slot in getattr(ob, "material_slots", []):
            tree = slot.material.node_tree if slot.material else None
            for node in (tree.nodes if tree else []):
                if node.bl_idname in node_types:
                    return True
                weight = node.inputs.get(principled_input) if node.bl_idname == "ShaderNodeBsdfPrincipled" \
                    else None
                if weight is not None and (weight.is_linked or weight.default_value > 0):
                    return True
    return False


def has_subsurface(objects) -> bool:
    """Whether any of the objects' materials scatters light under its surface."""
    return _materials_use(objects, ("ShaderNodeSubsurfaceScattering",), "Subsurface Weight")


def has_transmission(objects) -> bool:
    """Whether any of the objects' materials lets light through (glass, refraction, transmission)."""
    return _materials_use(objects, ("ShaderNodeBsdfGlass", "ShaderNodeBsdfRefraction", "ShaderNodeBsdfTransparent",
                                    "ShaderNodeBsdfTranslucent"), "Transmission Weight")


class CaptureStudio(BuiltOnEnter):
    def __init__(self, source_scene, projector, camera, width, height, samples=1, ambient=0.03,
                 ambient_distance=None, work_dir=None, transport: LightTransport = FAST, seed: int = 0):
        self.source_scene = source_scene
        self.transport = transport
        self.seed = seed  # Cycles' sampling seed: with bounces, two seeds give two noise draws
        self.projector, self.camera = projector, camera
        self.width, self.height, self.samples = width, height, samples
        self.ambient, self.ambient_distance = ambient, ambient_distance
        self.work_dir = work_dir  # a temporary folder of its own when None, made on __enter__
        self._scratch = None
        self.scene = None
        self.ambient_linear = None
        self._image = None
        self._saved_image = None
        self._chunk = 0
        self._saved_dof = None
        self._guide = None  # transport.NormalGuide of the bounce pass, built with its first frame

    # -- lifecycle -------------------------------------------------------------------------
    def _build(self):
        if self.work_dir is None:  # locked while it renders; the next studio removes one a kill left
            self._scratch = ScratchFolder(tempfile.gettempdir(), "lapig_render_")
            self.work_dir = str(self._scratch.path)
        self._had_render_result = any(i.type == "RENDER_RESULT" for i in bpy.data.images)
        scene = self.scene = studio_scene(STUDIO_NAME, self.source_scene)
        scene.collection.objects.link(self.projector)
        scene.collection.objects.link(self.camera)
        scene.camera = self.camera
        world = bpy.data.worlds.new(STUDIO_NAME)
        world.color = (0, 0, 0)
        if world.node_tree is not None:  # 5.0 worlds come with nodes: make the background black
            bg = world.node_tree.nodes.get("Background")
            if bg is not None:
                bg.inputs["Strength"].default_value = 0.0
        scene.world = world
        self._configure_render()
        self._configure_camera_lens()
        self._saved_image = projector_nodes.projected_image(self.projector.data)

    def _render_ambient(self, samples=32):
        """Render the room light alone, once; it is added to every projector render.

        Light adds linearly, so this is exact, and each projector render then has a single
        pinhole light: noise-free at one sample (with two lights Cycles picks one per sample and
        one sample per pixel turns into salt-and-pepper noise).
        """
        self.ambient_linear = np.zeros((self.height, self.width, 3), np.float32)
        if self.ambient <= 0:
            return
        power = self.projector.data.energy
        distance = self.ambient_distance or 1.0
        white_irradiance = power / (4 * math.pi * distance ** 2)
        sun = bpy.data.lights.new(STUDIO_NAME + " ambient", "SUN")
        sun.energy = self.ambient * white_irradiance
        sun.angle = math.radians(30)  # a broad source: soft, room-like shading
        sun_obj = bpy.data.objects.new(STUDIO_NAME + " ambient", sun)
        # from above the projector, tilted 35 degrees so its shading differs from the projector's
        sun_obj.matrix_world = self.projector.matrix_world
        sun_obj.rotation_euler.rotate_axis("X", math.radians(-35))
        scene = self.scene
        scene.collection.objects.link(sun_obj)
        scene.collection.objects.unlink(self.projector)
        cycles = scene.cycles
        saved = cycles.samples, cycles.filter_width
        try:
            cycles.samples, cycles.filter_width = samples, 1.0
            self.ambient_linear = self._render_frames([])[0]
        finally:
            cycles.samples, cycles.filter_width = saved
            scene.collection.objects.link(self.projector)
            bpy.data.objects.remove(sun_obj)
            bpy.data.lights.remove(sun)

    def _configure_render(self):
        scene = self.scene
        linear_cycles(scene, self.width, self.height, "OPEN_EXR")  # direct light: noise-free with a pinhole projector
        r = scene.render
        r.use_persistent_data = False  # persistent data made pattern captures stale
        r.image_settings.color_mode = "RGBA"
        r.use_file_extension = True
        c = scene.cycles
        c.samples = self._direct_samples()
        c.caustics_reflective = c.caustics_refractive = False
        # one sample: at the pixel centres, exact geometry for structured light
        c.filter_width = 0.01 if c.samples == 1 else 1.0
        c.seed = self.seed % (2 ** 31)
        if hasattr(c, "use_light_tree"):
            c.use_light_tree = False  # one light: the tree only costs time (20% at 640x480)
        scene.view_settings.look = "None"
        scene.view_settings.gamma = 1.0

    def _configure_camera_lens(self):
        """Cycles depth of field on the (user's) camera for the studio's renders; restored on close."""
        dof = self.camera.data.dof
        self._saved_dof = (dof.use_dof, dof.focus_object, dof.focus_distance, dof.aperture_fstop)
        t = self.transport
        dof.use_dof = t.uses_camera_dof
        if t.uses_camera_dof:
            dof.focus_object = None
            dof.focus_distance, dof.aperture_fstop = t.camera_focus_m, t.camera_f_number

    def _direct_samples(self) -> int:
        """A lens blurs by sampling its aperture, and light scatters under a surface by sampling random
        walks: with camera defocus or a subsurface material the direct pass needs samples (Realistic)."""
        t, samples = self.transport, self.samples
        if t.uses_camera_dof:
            samples = max(samples, t.camera_dof_samples)
        if t.realistic and has_subsurface(self.scene.collection.objects):
            samples = max(samples, t.subsurface_samples)
        return samples

    def close(self):
        try:
            self._restore()
        finally:  # even when the user's objects are gone (a new file loaded mid-capture)
            if self._scratch is not None:
                self._scratch.remove()
                self._scratch, self.work_dir = None, None

    def _restore(self):
        if self._saved_dof is not None and self.camera is not None and self.camera.data:
            dof = self.camera.data.dof
            dof.use_dof, dof.focus_object, dof.focus_distance, dof.aperture_fstop = self._saved_dof
            self._saved_dof = None
        if self.projector is not None and self.projector.data and self.projector.data.node_tree:
            try:
                projector_nodes.set_projected_image(self.projector.data, self._saved_image)
            except RuntimeError:
                pass
        if self._image is not None:
            bpy.data.images.remove(self._image)
            self._image = None
        if self.scene is not None:
            world = self.scene.world
            bpy.data.scenes.remove(self.scene)
            if world is not None and world.users == 0:
                bpy.data.worlds.remove(world)
            self.scene = None
        if not getattr(self, "_had_render_result", True):  # rendering made one: take it away again
            for image in [i for i in bpy.data.images if i.type == "RENDER_RESULT"]:
                bpy.data.images.remove(image)

    # -- rendering -------------------------------------------------------------------------
    def render(self, emitted_frames) -> list[np.ndarray]:
        """Render native projector frames of relative emitted light; returns linear RGB renders
        (projector light, the light it bounced in Realistic mode, and the room's ambient light)."""
        frames = list(emitted_frames)
        if not frames:
            return []
        if self.ambient_linear is None:  # lazily: a refused capture should not pay for it
            self._render_ambient()
        return [r + self.ambient_linear for r in self._render_frames(frames, self.transport.uses_bounces)]

    def _render_frames(self, frames, with_indirect=False) -> list[np.ndarray]:
        self._chunk += 1
        chunk_dir = os.path.join(self.work_dir, f"chunk_{self._chunk:05d}")
        os.makedirs(chunk_dir, exist_ok=True)
        try:
            if frames:
                self._load_patterns(chunk_dir, frames)
            count = max(1, len(frames))
            if not with_indirect:
                return self._render_pass(chunk_dir, count, "render_")
            if self.transport.bounce_method == "passes":
                return self._render_with_light_passes(chunk_dir, count)
            direct = self._render_pass(chunk_dir, count, "render_", with_alpha=True)
            indirect = self._indirect_pass(chunk_dir, count, [alpha for _, alpha in direct])
            return [d + i for (d, _), i in zip(direct, indirect)]
        finally:
            shutil.rmtree(chunk_dir, ignore_errors=True)

    def _render_pass(self, chunk_dir, count, prefix, with_alpha=False) -> list:
        paths = self._render_paths(chunk_dir, count, prefix)
        return [read_exr_rgba(p) for p in paths] if with_alpha else [read_exr_rgb(p) for p in paths]

    def _render_with_light_passes(self, chunk_dir, count) -> list[np.ndarray]:
        """One render with bounces per frame, read as Cycles' light-path passes ('passes', the default).

        The direct light is the render less its indirect passes (each light times its colour). The
        bounce light is the Diffuse Indirect pass (the irradiance, without the surface's colour)
        averaged over blocks of pixels, so a block's samples make one low-resolution pixel (a 480x360
        capture's 4x4 blocks hold 16), smoothed (a local plane fit) and scaled up under a surface-normal
        guide, times the full-size Diffuse Color: it keeps the texture it falls on and does not cross a
        crease. The glossy,
        transmitted and subsurface bounce light is added the same way, colour included
        (lapig_core.optics.transport.indirect_from_light_passes)."""
        import cv2

        t = self.transport
        c = self.scene.cycles
        low = t.indirect_size(self.width, self.height)
        saved = (c.max_bounces, c.diffuse_bounces, c.glossy_bounces, c.transmission_bounces,
                 c.transparent_max_bounces, c.volume_bounces)
        try:
            # (the direct pass's own samples: pixel centres, as Fast; a small capture's blocks hold fewer)
            c.max_bounces = c.diffuse_bounces = c.glossy_bounces = c.transmission_bounces = t.bounces
            c.transparent_max_bounces, c.volume_bounces = max(t.bounces, 4), 0
            objects = self.scene.collection.objects
            passes = LIGHT_PASSES + (TRANSMISSION_PASSES if has_transmission(objects) else ()) \
                + (SUBSURFACE_PASSES if has_subsurface(objects) else ())  # fewer channels to write and read
            with self._multilayer(passes):
                paths = self._render_paths(chunk_dir, count, "render_")
        finally:
            (c.max_bounces, c.diffuse_bounces, c.glossy_bounces, c.transmission_bounces,
             c.transparent_max_bounces, c.volume_bounces) = saved
        size = (self.width, self.height)
        area = lambda x: cv2.resize(x, low, interpolation=cv2.INTER_AREA) if x.shape[1] != low[0] else x
        out = []
        for path in paths:
            channels = read_exr_channels(path)
            combined = pass_rgb(channels, "Combined")
            alpha = next(v for k, v in channels.items() if k.endswith("Combined.A"))
            albedo = pass_rgb(channels, *PASS_NAMES["diffuse_colour"])
            irradiance = pass_rgb(channels, *PASS_NAMES["diffuse"])
            other = np.zeros_like(irradiance)
            for light, colour in (("glossy", "glossy_colour"), ("transmission", "transmission_colour"),
                                  ("subsurface", "subsurface_colour")):
                try:  # a release without one of these passes has none of that light to add
                    other += pass_rgb(channels, *PASS_NAMES[light]) * pass_rgb(channels, *PASS_NAMES[colour])
                except ExrError:
                    continue
            direct = np.maximum(combined - albedo * irradiance - other, 0.0)
            low_alpha = area(alpha)
            if self._guide is None or self._guide.low_shape != low_alpha.shape:  # the geometry's: built once
                normal = pass_rgb(channels, "Normal")
                self._guide = NormalGuide(low_alpha, area(normal), normal, size, t.indirect_smooth_px,
                                          first_order=t.indirect_fit == "linear")
            out.append(direct + indirect_from_light_passes(area(irradiance), area(other), albedo, size,
                                                           t.indirect_smooth_px, low_coverage=low_alpha,
                                                           coverage=alpha, guide=self._guide))
        return out

    def _indirect_pass(self, chunk_dir, count, coverage) -> list[np.ndarray]:
        """The light the projector's light bounced ('difference', the converged references): two
        renders of a lower resolution, the same samples and seed, one with bounces and one without;
        their difference is the bounce light alone (the direct light and its anti-aliasing cancel),
        which lapig_core.optics.transport.indirect_from_passes smooths and scales up to the capture."""
        t = self.transport
        r, c = self.scene.render, self.scene.cycles
        saved = (r.resolution_x, r.resolution_y, c.samples, c.filter_width, c.max_bounces, c.diffuse_bounces,
                 c.glossy_bounces, c.transmission_bounces, c.transparent_max_bounces, c.volume_bounces,
                 self.camera.data.dof.use_dof)
        try:
            r.resolution_x, r.resolution_y = t.indirect_size(self.width, self.height)
            c.samples, c.filter_width = t.indirect_samples, 1.0
            self.camera.data.dof.use_dof = False  # the bounce light is smooth: a lens changes nothing in it
            c.max_bounces = 0
            direct = self._render_pass(chunk_dir, count, "direct_low_", with_alpha=True)
            c.max_bounces = c.diffuse_bounces = c.glossy_bounces = c.transmission_bounces = t.bounces
            c.transparent_max_bounces, c.volume_bounces = max(t.bounces, 4), 0
            bounced = self._render_pass(chunk_dir, count, "bounced_low_")
        finally:
            (r.resolution_x, r.resolution_y, c.samples, c.filter_width, c.max_bounces, c.diffuse_bounces,
             c.glossy_bounces, c.transmission_bounces, c.transparent_max_bounces, c.volume_bounces,
             self.camera.data.dof.use_dof) = saved
        return [indirect_from_passes(b, d, (self.width, self.height), t.indirect_smooth_px, low_coverage=a,
                                     coverage=full) for b, (d, a), full in zip(bounced, direct, coverage)]

    def _render_paths(self, chunk_dir, count, prefix) -> list[str]:
        scene = self.scene
        scene.frame_start, scene.frame_end = 1, count
        scene.frame_set(1)
        scene.render.filepath = os.path.join(chunk_dir, prefix)
        with bpy.context.temp_override(scene=scene):
            bpy.ops.render.render(animation=True, scene=scene.name)
        return [os.path.join(chunk_dir, f"{prefix}{i:04d}.exr") for i in range(1, count + 1)]

    @contextlib.contextmanager
    def _multilayer(self, passes):
        """Renders write these view-layer passes into uncompressed multilayer EXR files meanwhile
        (lapig_core.common.exr reads them: OpenCV sees only a file's plain RGBA channels)."""
        layer, settings = self.scene.view_layers[0], self.scene.render.image_settings
        saved = {name: getattr(layer, name) for name in passes if hasattr(layer, name)}
        media = getattr(settings, "media_type", None)
        try:
            for name in saved:
                setattr(layer, name, True)
            if media is not None:  # 5.0 on: the multilayer format is under its own media type
                settings.media_type = "MULTI_LAYER_IMAGE"
            settings.file_format = "OPEN_EXR_MULTILAYER"
            settings.color_depth, settings.exr_codec = "32", "NONE"
            yield
        finally:
            for name, value in saved.items():
                setattr(layer, name, value)
            if media is not None:
                settings.media_type = media
            settings.file_format = "OPEN_EXR"
            settings.color_mode, settings.color_depth, settings.exr_codec = "RGBA", "32", "NONE"

    def _load_patterns(self, chunk_dir, frames):
        for i, frame in enumerate(frames, start=1):
            write_pattern(os.path.join(chunk_dir, f"pattern_{i:04d}.tif"), frame)
        # a fresh datablock per chunk: re-using one would show cached, stale patterns
        image = bpy.data.images.load(os.path.join(chunk_dir, "pattern_0001.tif"), check_existing=False)
        image.source = "SEQUENCE" if len(frames) > 1 else "FILE"
        image.colorspace_settings.name = "Non-Color"
        texture = projector_nodes.set_projected_image(self.projector.data, image)
        texture.image_user.frame_start = 1
        texture.image_user.frame_offset = 0
        texture.image_user.frame_duration = len(frames)
        texture.image_user.use_auto_refresh = True
        if self._image is not None:
            bpy.data.images.remove(self._image)
        self._image = image

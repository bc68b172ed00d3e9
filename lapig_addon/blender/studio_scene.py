"""The temporary scene a studio renders in (blender/capture_studio's captures, blender/light_render's light
maps): the user's renderable objects linked in, and Cycles set for linear, direct-light EXR renders."""
import bpy

from .geometry_probe import renderable_objects


def studio_scene(name: str, source):
    """A new scene of that name holding the source scene's renderable objects (linked, not copied)."""
    scene = bpy.data.scenes.new(name)
    for ob in renderable_objects(source):
        scene.collection.objects.link(ob)
    return scene


def linear_cycles(scene, width: int, height: int, file_format: str):
    """Cycles on the CPU at width x height, direct light only (max_bounces 0), no adaptive sampling, denoiser,
    compositor or sequencer, a transparent film, 32-bit uncompressed EXR (file_format: OPEN_EXR or
    OPEN_EXR_MULTILAYER), the view transform left linear: what each studio then adds its own settings to."""
    r = scene.render
    r.engine = "CYCLES"
    r.resolution_x, r.resolution_y, r.resolution_percentage = width, height, 100
    r.use_compositing = r.use_sequencer = False
    r.film_transparent = True  # the world is black or uniform: alpha then says where a surface is
    if file_format == "OPEN_EXR_MULTILAYER" and getattr(r.image_settings, "media_type", None) is not None:
        r.image_settings.media_type = "MULTI_LAYER_IMAGE"  # 5.0 on: multilayer is its own media
    r.image_settings.file_format = file_format  # before the depth: the format decides which depths there are
    r.image_settings.color_depth = "32"
    r.image_settings.exr_codec = "NONE"
    c = scene.cycles
    c.device = "CPU"
    c.use_adaptive_sampling = False
    c.use_denoising = False
    c.max_bounces = 0
    c.pixel_filter_type = "BOX"
    try:  # 'Raw' writes the linear render untouched; older configs only have 'Standard'
        scene.view_settings.view_transform = "Raw"
    except TypeError:
        scene.view_settings.view_transform = "Standard"
    scene.view_settings.exposure = 0.0

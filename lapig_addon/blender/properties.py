"""Settings stored in the .blend: per projector, per camera, and per scene."""
from __future__ import annotations

import bpy
from bpy.props import (BoolProperty, CollectionProperty, EnumProperty, FloatProperty, IntProperty,
                       IntVectorProperty, PointerProperty, StringProperty)

from ..services.limits import LIMITS
from .compat import RELATIVE_PATH_OPTIONS
from .scene_state import projector_model


def _prompt_changed(self, context):
    from .prompt_preview import prompt_changed  # the fast path's preview, where the one-step model is ready

    prompt_changed(self, context)


def _rebuild_projector(self, context):
    obj = self.id_data
    if getattr(obj, "type", None) == "LIGHT" and self.is_projector:
        from . import projector_nodes

        projector_nodes.build_light_tree(obj.data, projector_model(obj))
        obj.data.energy = self.brightness


class LapigProjectorSettings(bpy.types.PropertyGroup):
    is_projector: BoolProperty(name="Is LAPIG projector", default=False)
    resolution_x: IntProperty(name="Width", default=800, min=16, max=8192, update=_rebuild_projector,
                              description="The projector's native width in pixels")
    resolution_y: IntProperty(name="Height", default=600, min=16, max=8192, update=_rebuild_projector,
                              description="The projector's native height in pixels")
    throw_ratio: FloatProperty(name="Throw ratio", default=1.5, min=0.1, max=10.0,
                               update=_rebuild_projector,
                               description="Projection distance divided by image width")
    shift_x: FloatProperty(name="Shift X", default=0.0, min=-2.0, max=2.0, update=_rebuild_projector,
                           description="The lens's horizontal shift, in image widths")
    shift_y: FloatProperty(name="Shift Y", default=0.0, min=-2.0, max=2.0, update=_rebuild_projector,
                           description="The lens's vertical shift, in image heights")
    brightness: FloatProperty(name="Brightness", default=1000.0, min=0.0, soft_max=100000.0, unit="POWER",
                              update=_rebuild_projector,
                              description="Light power of full white; the camera's exposure keeps "
                                          "white from clipping")
    black_level: FloatProperty(name="Black level", default=0.002, min=0.0, max=0.5, precision=4,
                               description="Light leaked by a black input, relative to white")
    gamma: FloatProperty(name="Gamma", default=2.2, min=0.3, max=4.0,
                         description="The projector's gamma: the exponent from input value to light output")
    # light transport (lapig_core.optics.transport): how the captures render the room and the lenses
    transport_mode: EnumProperty(name="Light", items=[
        ("REALISTIC", "Realistic", "Bounce light, the projector's and the camera's lenses, vignetting: what a "
                                   "real room and real lenses show"),
        ("FAST", "Fast", "Direct light through pinhole lenses: quick, but what only the classical model assumes")],
        default="REALISTIC", description="Light transport: how light travels in the captures")
    bounces: IntProperty(name="Bounces", default=3, min=0, max=16,
                         description="Light bounces of the indirect pass (0: no inter-reflection)")
    indirect_samples: IntProperty(name="Indirect samples", default=16, min=1, max=4096,
                                  description="Samples per pixel of the indirect (bounce) pass")
    indirect_downscale: IntProperty(name="Indirect downscale", default=4, min=1, max=16,
                                    description="The bounce light renders at 1/this of the capture size "
                                                "(it is smooth) and is added to the full-size direct light")
    focus_distance: FloatProperty(name="Focus distance", default=3.0, min=0.01, max=1000.0, unit="LENGTH",
                                  description="Distance the projector's lens is focused at")
    lens_radius_mm: FloatProperty(name="Lens radius (mm)", default=5.0, min=0.0, max=200.0,
                                  description="Radius of the projector's aperture; 0: a pinhole that is "
                                              "sharp at every depth")


class LapigCameraSettings(bpy.types.PropertyGroup):
    resolution_x: IntProperty(name="Width", default=480, min=16, max=8192,
                              description="The camera's capture width in pixels")
    resolution_y: IntProperty(name="Height", default=360, min=16, max=8192,
                              description="The camera's capture height in pixels")
    auto_exposure: BoolProperty(name="Auto exposure", default=True,
                                description="Set the exposure from the white capture so it does not clip")
    exposure: FloatProperty(name="Exposure", default=0.0, min=-20.0, max=20.0, unit="NONE",
                            description="Exposure in stops when auto exposure is off")
    response_gamma: FloatProperty(name="Response gamma", default=2.2, min=0.5, max=4.0,
                                  description="Non-linear camera response (encoding gamma)")
    noise: FloatProperty(name="Noise", default=0.003, min=0.0, max=0.1, precision=4,
                         description="Sensor noise standard deviation, linear units")
    use_dof: BoolProperty(name="Lens defocus", default=False,
                          description="Blur what is off the camera's focus distance (Realistic mode; renders "
                                      "more samples per capture)")
    focus_distance: FloatProperty(name="Focus distance", default=3.0, min=0.01, max=1000.0, unit="LENGTH",
                                  description="Distance the camera's lens is focused at")
    f_number: FloatProperty(name="F-number", default=2.8, min=0.5, max=64.0,
                            description="Aperture of the camera's lens (smaller: more blur)")
    vignetting: FloatProperty(name="Vignetting", default=1.0, min=0.0, max=1.0, subtype="FACTOR",
                              description="Natural darkening towards the corners (cos^4 law; 0: none; "
                                          "Realistic mode)")


CAMERA_BACKENDS = [  # lapig_core.rig.camera_sources.BACKENDS and 'auto' (not imported here: it needs OpenCV)
    ("auto", "Auto", "The platform's own: V4L2 on Linux, DirectShow on Windows, AVFoundation on macOS; "
                     "FFMPEG for a stream URL or a video file"),
    ("v4l2", "V4L2", "Video4Linux2 (Linux)"),
    ("dshow", "DirectShow", "DirectShow (Windows; exposes the camera's exposure)"),
    ("msmf", "Media Foundation", "Media Foundation (Windows)"),
    ("avfoundation", "AVFoundation", "AVFoundation (macOS)"),
    ("ffmpeg", "FFMPEG", "FFMPEG: stream URLs and video files"),
    ("any", "Any", "Whatever OpenCV tries first"),
]


class LapigRealRigSettings(bpy.types.PropertyGroup):
    """The real projector and camera, as the installer chooses them (blender/scene_state.real_rig_spec
    builds the rigs/real_rig.RigSpec from them)."""
    name: StringProperty(name="Rig name", default="real rig",
                         description="The rig's name, recorded with its captures")
    display: StringProperty(name="Display", description="The projector's display: an index (0, 1, ...) or a part "
                                                        "of its name (Find Displays and Cameras lists them)")
    camera_source: EnumProperty(name="Camera", items=[
        ("DEVICE", "Camera", "A camera index, a stream URL or a video file, read through OpenCV"),
        ("TETHERED", "Tethered", "A tethered folder: a folder a tethering program (a DSLR's, gphoto2) saves each picture into")],
        default="DEVICE")
    camera: StringProperty(name="Camera", description="A camera index (0, 1, ...), a stream URL (rtsp://, http://) "
                                                      "or a video file")
    camera_backend: EnumProperty(name="Backend", items=CAMERA_BACKENDS, default="auto",
                                 description="How OpenCV talks to the camera")
    tethered_folder: StringProperty(name="Folder", subtype="DIR_PATH",
                                    description="The folder the tethering program saves each new picture into")
    camera_width: IntProperty(name="Width", default=0, min=0, max=16384,
                              description="The camera's picture width; 0: the camera's own")
    camera_height: IntProperty(name="Height", default=0, min=0, max=16384,
                               description="The camera's picture height; 0: the camera's own")
    use_exposure: BoolProperty(name="Exposure", description="Lock the camera's exposure at this value "
                                                            "(off: locked where it is)")
    exposure: FloatProperty(name="Exposure", default=-6.0, description="In the backend's units (V4L2: 100 us "
                                                                       "steps; DirectShow: log2 seconds)")
    use_gain: BoolProperty(name="Gain", description="Set the camera's gain (off: the camera's)")
    gain: FloatProperty(name="Gain", default=0.0, min=0.0, description="In the backend's units")
    use_focus: BoolProperty(name="Focus", description="Lock the camera's focus at this value (off: locked where "
                                                      "it is)")
    focus: FloatProperty(name="Focus", default=0.0, min=0.0, description="In the backend's units")
    use_white_balance: BoolProperty(name="White balance", description="Lock the camera's white balance at this "
                                                                      "value (off: locked where it is)")
    white_balance: FloatProperty(name="White balance", default=5000.0, min=0.0,
                                 description="Colour temperature in kelvin, where the backend takes it")
    frame_code: BoolProperty(name="Frame code", default=True,
                             description="Stamp every frame at its top and bottom edges, so a stale or torn "
                                         "picture is caught and grabbed again (off: timing alone)")
    health_checks: BoolProperty(name="Health checks", default=True,
                                description="Check the exposure and a gray ramp before the capture, and stop "
                                            "with what to change")


def _is_projector(self, obj) -> bool:
    return obj.type == "LIGHT" and obj.lapig_projector.is_projector


class LapigExtraProjector(bpy.types.PropertyGroup):
    """A projector of the rig beyond the first (scene.lapig.projector): the object, with its own
    lapig_projector settings, and the display it is on with a real rig."""
    projector: PointerProperty(name="Projector", type=bpy.types.Object, poll=_is_projector)
    display: StringProperty(name="Display", description="This projector's display with a real rig: an index or "
                                                        "a part of its name (each projector needs its own)")


def _show_changed(self, context):
    """The show's list changed: its markers on the timeline are written again (blender/show_timeline)."""
    from . import show_timeline

    show_timeline.rewrite_markers(self.id_data)


SHOW_TRANSITIONS = [
    ("dissolve", "Dissolve", "Crossfade the two looks' compensated frames in the projector's linear light"),
    ("morph", "Morph", "The in-between frames are new looks: the looks' parameters interpolated, each frame "
                       "adapted and compensated"),
]
SHOW_MOTIONS = [
    ("none", "Still", "The look holds still"),
    ("drift", "Drift", "Strokes and shapes drift slowly"),
    ("rise", "Rise", "A wave rises through the look"),
    ("pulse", "Pulse", "The look's strength pulses"),
    ("colour_cycle", "Colour cycle", "The look's colours cycle"),
    ("world", "Its own time", "A look of the world moves by itself: water flows, fire flickers, clouds drift, "
                              "plants sway (at its Speed slider; Amount 0.5 is that speed)"),
]


class LapigShowLook(bpy.types.PropertyGroup):
    """One look of the show (issue 38): a result, its hold, its transition to the next look and its motion.
    Read by blender/scene_state.read_show into services/show/show_plan.ShowLook."""
    name: StringProperty(name="Name", description="The look's name on the timeline's markers", update=_show_changed)
    result_dir: StringProperty(name="Result", subtype="DIR_PATH", options=RELATIVE_PATH_OPTIONS, update=_show_changed,
                               description="The result folder whose look this is")
    hold_s: FloatProperty(name="Hold", default=4.0, min=0.0, soft_max=600.0, unit="TIME_ABSOLUTE",
                          update=_show_changed, description="How long the look holds, in seconds")
    transition: EnumProperty(name="Transition", items=SHOW_TRANSITIONS, default="dissolve", update=_show_changed,
                             description="How the show goes from this look to the next")
    transition_s: FloatProperty(name="Seconds", default=1.0, min=0.0, soft_max=60.0, unit="TIME_ABSOLUTE",
                                update=_show_changed, description="How long the transition to the next look lasts")
    motion: EnumProperty(name="Motion", items=SHOW_MOTIONS, default="none", update=_show_changed,
                         description="How the look moves while it holds")
    motion_amount: FloatProperty(name="Amount", default=0.5, min=0.0, max=1.0, subtype="FACTOR",
                                 update=_show_changed, description="How strongly the look moves")
    motion_period_s: FloatProperty(name="Period", default=4.0, min=0.1, soft_max=120.0, unit="TIME_ABSOLUTE",
                                   update=_show_changed, description="Seconds of one cycle of the motion")


PREVIEW_MODES = [
    ("ORIGINAL", "Original", "The object's own material"),
    ("PROJECTION", "Projection", "Each projector's image cast on the object (their light times the surface)"),
    ("TARGET", "Target", "The stylization the viewer should see"),
    ("SIMULATED", "Simulated", "What the model predicts the camera sees (PCNet; the joint model with several)"),
    ("RENDERED", "Rendered", "The Cycles capture of the projection"),
    ("COMPENSABILITY", "Problem areas", "Where the surface cannot show the target (L_ps + L_cs per pixel; with "
     "several projectors, where their joint capture falls short of the look)"),
    ("LUX", "Lux", "The look's illuminance on the object, log scale 1 to 10,000 lux (Light Report)"),
    ("CONTRAST", "Contrast", "Contrast against the room: red below 5:1, amber to 10:1, green above (Light Report)"),
]


_BACKEND_ITEMS = []  # Blender needs the enum strings to stay referenced


def _backend_items(self, context):
    if not _BACKEND_ITEMS:
        try:
            from ...lapig_core.lgst import BACKENDS, DEFAULT_BACKEND

            names = sorted(BACKENDS, key=lambda n: (n != DEFAULT_BACKEND, n))  # first item = default
        except ImportError:  # torch missing: the panel says so; keep the default listed
            names = []
        _BACKEND_ITEMS.extend((n, n, f"LGST backend '{n}'") for n in (names or ["styletransfer"]))
    return _BACKEND_ITEMS


def _preview_mode_changed(self, context):
    from . import result_preview

    result_preview.apply_mode(context.scene, self.preview_mode, report=None)


def _export_bit_depth_changed(self, context):
    """The light emits what the export would write, so it follows the bit depth."""
    from . import scene_store

    try:
        scene_store.show_scene_result(self.id_data)  # the scene these settings belong to
    except (OSError, ValueError):  # result gone or unreadable: the light keeps its image
        pass


def _show_codec_items():
    """Each codec's trade-off (size, quality, which players take it) from lapig_core/export/codecs."""
    from ...lapig_core.export.codecs import CODECS

    items = [(c.name, c.label, c.help) for c in CODECS.values()]
    return items + [("png", "PNG sequence", "A folder of PNGs per projector (8 or 16 bit, exact, the largest); "
                                            "every player and compositor reads it")]


SHOW_CODEC_ITEMS = _show_codec_items()


class LapigSceneSettings(bpy.types.PropertyGroup):
    projector: PointerProperty(name="Projector", type=bpy.types.Object, poll=_is_projector)
    # the rig's other projectors, in order (projector 2, 3, ...); read and written by blender/scene_state only
    extra_projectors: CollectionProperty(type=LapigExtraProjector, name="More projectors")
    camera: PointerProperty(name="Camera", type=bpy.types.Object, poll=lambda self, obj: obj.type == "CAMERA")
    target: PointerProperty(name="Surface", type=bpy.types.Object, poll=lambda self, obj: obj.type == "MESH",
                            description="The surface object: the mesh the projector lights")
    rig_kind: EnumProperty(name="Rig", items=[
        ("VIRTUAL", "Virtual rig", "Capture, judge and preview with the Cycles studio of the projector and camera "
                                   "objects"),
        ("REAL", "Real rig", "A real projector and camera: capture through a real projector (a window on a "
                             "display) and camera; looks play live on the projector")], default="VIRTUAL",
        description="Which projector and camera capture the surface: Blender's (virtual) or real ones")
    real: PointerProperty(type=LapigRealRigSettings, name="Real rig")
    ambient: FloatProperty(name="Ambient light", default=0.03, min=0.0, max=1.0, subtype="FACTOR",
                           description="Room light on the object, as a fraction of the projector's white")
    train_count: IntProperty(name="Training images", default=32, **LIMITS["train_count"].bounds())
    test_count: IntProperty(name="Test images", default=8, **LIMITS["test_count"].bounds())
    working_size: IntProperty(name="Working size", default=256, step=32, **LIMITS["working_size"].bounds(),
                              description="Long side of the working frame, in pixels: the networks work on the "
                                          "whole projector frame at this size (e.g. 256 -> 256x192 at 4:3, "
                                          "256x144 at 16:9), rounded to a multiple of 4")
    gray_level: FloatProperty(name="Gray level", default=0.5, min=0.05, max=0.95,
                              description="Projector input value of the surface capture s")
    samples: IntProperty(name="Samples", default=1, **LIMITS["samples"].bounds(),
                         description="Cycles samples per capture (the projector light is noise-free, "
                                     "samples only anti-alias)")
    pattern_source: EnumProperty(name="Patterns", items=[
        ("GENERATED", "Generated", "Varied natural-image-like patterns"),
        ("FOLDER", "Folder", "Your own images")], default="GENERATED")
    pattern_folder: StringProperty(name="Pattern folder", subtype="DIR_PATH")
    seed: IntProperty(name="Seed", default=0, **LIMITS["seed"].bounds())
    last_capture_dir: StringProperty(name="Last capture", subtype="DIR_PATH", options=RELATIVE_PATH_OPTIONS)
    last_capture_fingerprint: StringProperty(name="Scene fingerprint of the last capture")
    last_capture_transport: StringProperty(name="Light transport of the last capture")
    last_capture_rig: StringProperty(name="Rig of the last capture",
                                     description="The virtual rig, or which real rig; '' when unknown")
    last_capture_projector_size: IntVectorProperty(name="Projector resolution of the last capture", size=2,
                                                   default=(0, 0))
    last_capture_coverage: StringProperty(name="Coverage of the last capture",
                                          description="JSON: each projector's share of the object (several projectors)")
    # models
    finetune_iterations: IntProperty(name="Iterations", default=0, **LIMITS["finetune_iterations"].bounds(),
                                     description="Fine-tuning iterations per network; 0 for the standard "
                                                 "recipe, fewer for a rough but quick fine-tune")
    train_in_background: BoolProperty(name="Train in the background", default=True,
                                      description="After each Capture, fine-tune the networks and make the rendered "
                                                  "choice while you work; Generate uses the first look until then")
    models_fingerprint: StringProperty(name="Rig fingerprint the models were trained for")
    models_status: StringProperty(name="Models")
    # stylize
    prompt: StringProperty(name="Prompt", default="Make it a stained glass artwork", update=_prompt_changed,
                           description="What the object should look like under the projection")
    backend: EnumProperty(name="Backend", items=_backend_items,
                          description="Language-guided style transfer that turns the prompt into a look")
    style_override: StringProperty(name="Mix",
                                   description="Style mix: an optional explicit mix instead of the prompt's, "
                                               "e.g. 'black_ink_cells:0.7, teal_red_mosaic:0.3'")
    style_image: StringProperty(name="Image", subtype="FILE_PATH", options=RELATIVE_PATH_OPTIONS,
                                description="Style image: an optional painting or photo of a material whose style "
                                            "the look "
                                            "takes (the 'arbitrary' backend); empty for the prompt's look")
    style_prompt_weight: FloatProperty(name="Prompt share", default=0.0, subtype="FACTOR",
                                       **LIMITS["style_prompt_weight"].bounds(),
                                       description="How much of the prompt's own look is mixed into the "
                                                   "style image's (0: the image only)")
    use_psa: BoolProperty(name="PSA", default=True,
                          description="Surface adaptation (PSA): adapt the look to what this surface and projector "
                                      "can show")
    psa_adaptation: FloatProperty(name="Adaptation", default=0.5, subtype="FACTOR",
                                  **LIMITS["psa_adaptation"].bounds(),
                                  description="0: keep my look (its brightness and colour too); 1: whatever this "
                                              "surface can show (darker on dark parts, tinted on coloured ones). "
                                              "From 0.5 on, only the style's strokes, edges and colour relations "
                                              "are kept")
    style_seed: IntProperty(name="Seed", default=0, **LIMITS["style_seed"].bounds())
    dark_outside: BoolProperty(name="Dark outside the object", default=True,
                               description="Black projector pixels where the frame misses the object (the "
                                           "capture found no surface there), so no stray light lands behind it")
    output_size: IntProperty(name="Output size", default=0, **LIMITS["output_size"].bounds(),
                             description="Long side of the final projector image, up to the projector's "
                                         "resolution; 0 for its native resolution. The look and its "
                                         "compensation are computed at this size after the adaptation")
    refine_steps: IntProperty(name="Refine steps", default=4, **LIMITS["refine_iterations"].bounds(),
                              description="Refine on the rig: project the result, capture it, correct the projector "
                                          "image where the capture misses the target, at most this many times "
                                          "(it stops earlier once a step gains less than 0.05 dB)")
    result_dir: StringProperty(name="Result folder", subtype="DIR_PATH", options=RELATIVE_PATH_OPTIONS)
    result_fingerprint: StringProperty(name="Rig fingerprint of the result")
    result_summary: StringProperty(name="Result")
    result_reach_message: StringProperty(name="What the surface can show",
                                         description="Said when most of the look is out of the surface's reach")
    preview_mode: EnumProperty(name="Show", items=PREVIEW_MODES, default="ORIGINAL", update=_preview_mode_changed,
                               description="What the object shows in the viewport")
    # export
    export_bit_depth: EnumProperty(name="Bit depth", items=[("8", "8 bit", ""), ("16", "16 bit", "")], default="8",
                                   update=_export_bit_depth_changed)
    export_path: StringProperty(name="File", subtype="FILE_PATH", default="//projector_image.png",
                                description="Export to: the projector image's file (a sidecar .json beside it)")
    crossfade_frames: IntProperty(name="Crossfade frames", default=60, **LIMITS["crossfade_frames"].bounds())
    crossfade_fps: FloatProperty(name="Frame rate", default=30.0, **LIMITS["crossfade_fps"].bounds(),
                                 description="Frames per second of the crossfade played on the projector")
    # the show (issue 38): read and written by blender/scene_state only; its markers by blender/show_timeline
    show_looks: CollectionProperty(type=LapigShowLook, name="Show")
    show_index: IntProperty(name="Look", default=0, min=0)
    show_markers: StringProperty(name="Show markers", description="JSON: the markers the show wrote, [frame, name]")
    show_baked: StringProperty(name="Baked show", subtype="DIR_PATH", options=RELATIVE_PATH_OPTIONS,
                               description="The folder of the show's baked projector frames")
    show_baked_key: StringProperty(name="Baked show's plan", description="The show the baked frames were made of")
    show_codec: EnumProperty(name="Codec", items=SHOW_CODEC_ITEMS,
        default="h264", description="What Export Show writes")
    show_export_dir: StringProperty(name="Folder", subtype="DIR_PATH", default="//show_export",
                                    description="Export to: the folder Export Show writes the show into")
    job_progress: FloatProperty(name="Progress", default=0.0, min=0.0, max=1.0, subtype="FACTOR")
    job_message: StringProperty(name="Status")


def _look_slider_changed(self, context):
    from . import look_sliders

    look_sliders.slider_changed(context)


def _look_slider_properties() -> dict:
    """A world look's sliders (lapig_core/look_parameters) as look_<name>, their ranges from services/limits."""
    from ...lapig_core.look_parameters import PARAMETERS, LookParameters

    props, defaults = {}, LookParameters()
    for p in PARAMETERS:
        kind = IntProperty if p.integer else FloatProperty
        extra = {} if p.integer else {"step": p.step * 100, "precision": 2 if p.step < 1 else 0}
        props[f"look_{p.name}"] = kind(name=p.label, description=p.tip, default=getattr(defaults, p.name),
                                       **LIMITS[f"look_{p.name}"].bounds(), update=_look_slider_changed, **extra)
    props["look_sliders_result"] = StringProperty(
        name="Sliders' result", subtype="DIR_PATH", options=RELATIVE_PATH_OPTIONS,
        description="The result whose world look the sliders show ('' when it has none)")
    return props


LapigSceneSettings.__annotations__.update(_look_slider_properties())

CLASSES = (LapigProjectorSettings, LapigCameraSettings, LapigRealRigSettings, LapigExtraProjector, LapigShowLook,
           LapigSceneSettings)


def register():
    for cls in CLASSES:
        bpy.utils.register_class(cls)
    bpy.types.Object.lapig_projector = PointerProperty(type=LapigProjectorSettings)
    bpy.types.Object.lapig_camera = PointerProperty(type=LapigCameraSettings)
    bpy.types.Scene.lapig = PointerProperty(type=LapigSceneSettings)


def unregister():
    del bpy.types.Scene.lapig
    del bpy.types.Object.lapig_camera
    del bpy.types.Object.lapig_projector
    for cls in reversed(CLASSES):
        bpy.utils.unregister_class(cls)

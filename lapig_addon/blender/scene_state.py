"""The one reader and writer of scene.lapig and of the projector and camera settings.

It turns them into the plain values of services/state.py, which everything else decides on, and
records what the jobs produced. Each builder takes explicit overrides (None: the scene's value), so
the command line passes its arguments without writing them into the scene.
"""
from __future__ import annotations

import os

import bpy

from ...lapig_core.capture.settings import CaptureSettings
from ...lapig_core.optics.projector_model import ProjectorModel
from ...lapig_core.optics.transport import LightTransport
from ..services.state import (CameraSettings, ExportSettings, GenerateRequest, Rig, SceneState,
                              overridden)
from . import preferences, storage
from . import fingerprint


def projector_model(obj) -> ProjectorModel:
    p = obj.lapig_projector
    return ProjectorModel(width=p.resolution_x, height=p.resolution_y, throw_ratio=p.throw_ratio,
                          shift_x=p.shift_x, shift_y=p.shift_y, gamma=p.gamma, black_level=p.black_level)


def projector_size(obj) -> tuple[int, int]:
    """The projector's (width, height) in pixels."""
    p = obj.lapig_projector
    return p.resolution_x, p.resolution_y


def write_projector_settings(obj, settings: dict) -> None:
    """Set the projector's settings by name (services/light/light_report.projector_settings: a real model's)."""
    p = obj.lapig_projector
    for name, value in settings.items():
        setattr(p, name, value)


def light_transport(projector, camera) -> LightTransport:
    """How the captures of this projector and camera render light (lapig_core.optics.transport)."""
    p = projector.lapig_projector
    c = camera.lapig_camera if camera is not None else None
    lens = {} if c is None else {"camera_dof": c.use_dof, "camera_focus_m": c.focus_distance,
                                 "camera_f_number": c.f_number, "vignetting": c.vignetting}
    return LightTransport(mode=p.transport_mode, bounces=p.bounces, indirect_samples=p.indirect_samples,
                          indirect_downscale=p.indirect_downscale, projector_focus_m=p.focus_distance,
                          projector_lens_radius_mm=p.lens_radius_mm, **lens)


def rig_fingerprint(projector, camera, target) -> str:
    """The short hash of everything the rig's captures depend on, its light transport included."""
    return fingerprint.rig_fingerprint(projector, camera, target, light_transport(projector, camera).state())


def write_light_transport(projector, camera, transport: LightTransport):
    """Set the rig's light transport (the benchmarks' and tests' setups)."""
    p, c = projector.lapig_projector, camera.lapig_camera
    p.transport_mode, p.bounces, p.indirect_samples = transport.mode, transport.bounces, transport.indirect_samples
    p.indirect_downscale, p.focus_distance = transport.indirect_downscale, transport.projector_focus_m
    p.lens_radius_mm = transport.projector_lens_radius_mm
    c.use_dof, c.focus_distance, c.f_number = transport.camera_dof, transport.camera_focus_m, transport.camera_f_number
    c.vignetting = transport.vignetting


def camera_settings(obj) -> CameraSettings:
    c = obj.lapig_camera
    return CameraSettings(width=c.resolution_x, height=c.resolution_y, auto_exposure=c.auto_exposure,
                          exposure=c.exposure, response_gamma=c.response_gamma, noise=c.noise)


def rig_objects(scene) -> tuple:
    """(projector, camera, surface object) as the scene names them; None where one is not set."""
    s = scene.lapig
    return s.projector, s.camera, s.target


def _is_projector(obj) -> bool:
    return obj is not None and obj.type == "LIGHT" and obj.lapig_projector.is_projector


def rig_projectors(scene) -> list:
    """The rig's projector objects: projector 1 (scene.lapig.projector) then the extra ones in their order,
    each once; entries that lost their object or are no LAPIG projector are left out."""
    s = scene.lapig
    out = [s.projector] if _is_projector(s.projector) else []
    for item in s.extra_projectors:
        if _is_projector(item.projector) and item.projector not in out:
            out.append(item.projector)
    return out


def projector_displays(scene) -> list[str]:
    """Each projector's display with a real rig, in rig_projectors' order ('' where not chosen)."""
    s = scene.lapig
    first = [s.real.display.strip()] if _is_projector(s.projector) else []
    seen = set(first and [s.projector.name])
    rest = []
    for item in s.extra_projectors:
        if _is_projector(item.projector) and item.projector.name not in seen:
            seen.add(item.projector.name)
            rest.append(item.display.strip())
    return first + rest


def add_extra_projector(scene, obj) -> None:
    """The rig gets `obj` as its next projector (projector 1 when it has none)."""
    s = scene.lapig
    if s.projector is None:
        s.projector = obj
        return
    s.extra_projectors.add().projector = obj


def remove_extra_projector(scene, name: str) -> bool:
    """Take the extra projector of that object name off the rig (the object stays); False where none is."""
    items = scene.lapig.extra_projectors
    for i, item in enumerate(items):
        if item.projector is not None and item.projector.name == name:
            items.remove(i)
            return True
    return False


CAMERA_CONTROLS = ("exposure", "gain", "focus", "white_balance")  # each with its use_ toggle in scene.lapig.real


def uses_real_rig(scene) -> bool:
    """Whether the scene's rig is a real projector and camera (the panel's Rig)."""
    return scene.lapig.rig_kind == "REAL"


def real_rig_spec(scene):
    """The scene's real rig (rigs/real_rig.RigSpec), built from the panel's settings (scene.lapig.real), or
    None where the scene uses the virtual one. The one reader of those settings."""
    from ..rigs.real_rig import RigSpec

    s = scene.lapig
    if not uses_real_rig(scene):
        return None
    r = s.real
    settings = {key: getattr(r, key) for key in CAMERA_CONTROLS if getattr(r, "use_" + key)}
    settings.update({key: value for key, value in (("width", r.camera_width), ("height", r.camera_height)) if value})
    tethered = r.camera_source == "TETHERED"
    folder = r.tethered_folder.strip()
    return RigSpec(name=r.name.strip() or "real rig", display=r.display.strip(),
                   camera="" if tethered else r.camera.strip(), camera_backend=r.camera_backend,
                   tethered_folder=bpy.path.abspath(folder) if tethered and folder else "",
                   camera_settings=settings, frame_code=r.frame_code, health_checks=r.health_checks)


def record_real_rig(scene, spec) -> None:
    """The scene uses this real rig from now on (None: the virtual one again; the real rig's settings stay
    for the next time). ValueError for a camera backend the panel does not offer."""
    s = scene.lapig
    if spec is None:
        s.rig_kind = "VIRTUAL"
        return
    r = s.real
    try:
        r.camera_backend = spec.camera_backend.lower()
    except TypeError:
        names = [item.identifier for item in r.bl_rna.properties["camera_backend"].enum_items]
        raise ValueError(f"unknown camera backend '{spec.camera_backend}': use one of {', '.join(names)}") from None
    r.name, r.display, r.camera = spec.name, spec.display, spec.camera
    r.camera_source = "TETHERED" if spec.tethered_folder else "DEVICE"
    if spec.tethered_folder:
        r.tethered_folder = spec.tethered_folder
    settings = spec.camera_settings
    r.camera_width, r.camera_height = int(settings.get("width") or 0), int(settings.get("height") or 0)
    for key in CAMERA_CONTROLS:
        setattr(r, "use_" + key, settings.get(key) is not None)
        if settings.get(key) is not None:
            setattr(r, key, float(settings[key]))
    r.frame_code, r.health_checks = spec.frame_code, spec.health_checks
    s.rig_kind = "REAL"


def choose_real_device(scene, display: str | None = None, camera: str | None = None) -> None:
    """The installer chose a display or a camera from the found ones (None: that one stays)."""
    r = scene.lapig.real
    if display is not None:
        r.display = display
    if camera is not None:
        r.camera, r.camera_source = camera, "DEVICE"


def _real_rig_key(scene) -> str | None:
    """The identity key of the scene's real rig (staleness follows the rig, not the objects); None: virtual."""
    spec = real_rig_spec(scene)
    if spec is None:
        return None
    from ..rigs.real_rig import RealRigFactory

    names = [p.name for p in rig_projectors(scene)]
    several = tuple((n, d, None) for n, d in zip(names, projector_displays(scene))) if len(names) > 1 else ()
    return RealRigFactory(spec, projectors=several).rig_identity().key()  # another display: another rig


def read_rig(scene, projector=None, camera=None, target=None) -> Rig:
    """The rig of the given objects (None: the scene's own), checked for what each must be."""
    own = rig_objects(scene)
    projector, camera, target = projector or own[0], camera or own[1], target or own[2]
    if projector is not None and not (projector.type == "LIGHT" and projector.lapig_projector.is_projector):
        projector = None
    if camera is not None and camera.type != "CAMERA":
        camera = None
    if target is not None and target.type != "MESH":
        target = None
    objects = [ob for ob in (projector, camera, target) if ob is not None]
    spec = real_rig_spec(scene)
    # the scene's other projectors belong to its own rig only (a script capturing other objects names one)
    extras = rig_projectors(scene)[1:] if projector is not None and projector == own[0] else []
    objects += extras
    every = [projector] + extras if projector is not None else []
    return Rig(projector=projector.name if projector else None, camera=camera.name if camera else None,
               target=target.name if target else None, scene=scene.name,
               outside_scene=tuple(ob.name for ob in objects if ob.name not in scene.objects),
               fingerprint=_fingerprint(scene, projector, camera, target, len(objects) == 3 + len(extras), extras),
               transport=light_transport(projector, camera).label() if projector and camera else "",
               projector_size=projector_size(projector) if projector else None,
               kind="REAL" if spec else "VIRTUAL",
               label=f"the real rig '{spec.name}'" if spec else "the virtual rig",
               devices_problem=spec.problem() if spec else "",
               projectors=tuple(p.name for p in every),
               projector_sizes=tuple((p.lapig_projector.resolution_x, p.lapig_projector.resolution_y) for p in every),
               displays=tuple(projector_displays(scene)) if extras else ())


def _fingerprint(scene, projector, camera, target, complete: bool, extras=()) -> str:
    """One projector: its rig's fingerprint as ever; several: that and each other projector's, hashed."""
    real = _real_rig_key(scene)
    if real is not None:
        return real
    if not complete:
        return ""
    first = rig_fingerprint(projector, camera, target)
    if not extras:
        return first
    import hashlib

    parts = [first] + [rig_fingerprint(p, camera, target) for p in extras]
    return hashlib.sha1("+".join(parts).encode()).hexdigest()[:16]


def read(scene) -> SceneState:
    s = scene.lapig
    return SceneState(rig=read_rig(scene), capture_dir=storage.resolve_capture_dir(s.last_capture_dir),
                      capture_fingerprint=s.last_capture_fingerprint, capture_transport=s.last_capture_transport,
                      capture_rig=s.last_capture_rig,
                      capture_projector_size=tuple(s.last_capture_projector_size)
                      if all(s.last_capture_projector_size) else None,
                      models_fingerprint=s.models_fingerprint,
                      models_status=s.models_status, result_dir=storage.resolve_result_dir(s.result_dir),
                      result_fingerprint=s.result_fingerprint, preview_mode=s.preview_mode,
                      **_capture_coverage(s.last_capture_coverage))


def _capture_coverage(text: str) -> dict:
    """SceneState's capture_coverage and capture_reach from what record_coverage wrote ('' for none)."""
    if not text:
        return {}
    import json

    try:
        data = json.loads(text)
        return {"capture_coverage": tuple((str(n), float(v)) for n, v in zip(data["names"], data["shares"])),
                "capture_reach": float(data["reached"])}
    except (ValueError, KeyError, TypeError):
        return {}


def capture_settings(scene, **overrides) -> CaptureSettings:
    """The one builder of CaptureSettings: the scene's Capture settings, then the caller's overrides
    (any CaptureSettings field)."""
    s = scene.lapig
    name = storage.setup_name_for(s.target.name if s.target else "")
    settings = CaptureSettings(
        out_dir=storage.capture_root(name), setup_name=name, train_count=s.train_count, test_count=s.test_count,
        working_size=s.working_size, gray_level=s.gray_level, samples=s.samples, ambient=s.ambient, seed=s.seed,
        pattern_folder=bpy.path.abspath(s.pattern_folder) if s.pattern_source == "FOLDER" else None,
        chunk=8 if bpy.app.background else 2)  # small chunks keep the UI responsive
    return overridden(settings, **overrides)


def generate_request(scene, **overrides) -> GenerateRequest:
    s = scene.lapig
    request = GenerateRequest(prompt=s.prompt, backend=s.backend, mix=s.style_override, psa=s.use_psa,
                              adaptation=s.psa_adaptation, seed=s.style_seed, ip2p_model=preferences.ip2p_model(),
                              depth_model=preferences.ready_model("depth-adapter"),
                              one_step_model=preferences.ready_model("sd-turbo"), dark_outside=s.dark_outside,
                              output_size=s.output_size,
                              style_images=(bpy.path.abspath(s.style_image),) if s.style_image.strip() else (),
                              style_prompt_weight=s.style_prompt_weight)
    return overridden(request, **overrides)


def export_settings(scene, **overrides) -> ExportSettings:
    s = scene.lapig
    settings = ExportSettings(path=bpy.path.abspath(s.export_path), bit_depth=int(s.export_bit_depth),
                              crossfade_frames=s.crossfade_frames)
    return overridden(settings, **overrides)


def finetune_iterations(scene) -> int | None:
    """Fine-tuning iterations per network; None for the standard recipe."""
    return scene.lapig.finetune_iterations or None


def compute_device() -> str:
    """Where torch runs, from the add-on's preferences: 'auto' or 'cpu' (lapig_core/common/compute_device)."""
    return preferences.compute_device()


def train_in_background(scene) -> bool:
    """Whether a Capture made in the UI starts Train in the background (the Models panel's option)."""
    return bool(scene.lapig.train_in_background)


def refine_steps(scene) -> int:
    """The cap on Refine on the rig's steps (the panel's Refine steps)."""
    return int(scene.lapig.refine_steps)


def rig_metadata(scene) -> dict:
    """The rig as an exported image's sidecar describes it."""
    projector, camera, target = rig_objects(scene)
    cam = camera_settings(camera) if camera else None
    return {"projector": {**projector_model(projector).to_dict(), "brightness_w": projector.lapig_projector.brightness,
                          "object": projector.name},
            "camera": None if cam is None else {"resolution": [cam.width, cam.height],
                                                "response_gamma": cam.response_gamma, "lens_mm": camera.data.lens},
            "surface_object": target.name if target else None}


def record_rig(scene, projector, camera, target):
    s = scene.lapig
    s.projector, s.camera, s.target = projector, camera, target


def record_capture(scene, folder, fingerprint: str, transport: str = ""):
    """fingerprint: the rig's at the capture; '' for one captured elsewhere (tied to no rig here).
    transport: the light transport's label at the capture ('' when unknown)."""
    s = scene.lapig
    s.last_capture_dir, s.last_capture_fingerprint = storage.stored_path(folder), fingerprint
    s.last_capture_transport = transport
    # for the stale reasons when the projector's resolution or the rig changes later (tied to this rig only)
    rig = read_rig(scene) if fingerprint else None
    s.last_capture_projector_size = (rig.projector_size if rig else None) or (0, 0)
    # which rig: the scene's, where it is the one captured with (a capture from elsewhere: unknown)
    s.last_capture_rig = rig.label if rig is not None and rig.fingerprint == fingerprint else ""
    s.last_capture_coverage = ""  # a capture of several projectors records its own next (record_coverage)


def record_coverage(scene, names, shares, reached: float):
    """Each projector's share of the object at the capture just recorded, and all together's."""
    import json

    scene.lapig.last_capture_coverage = json.dumps({"names": list(names),
                                                    "shares": [round(float(v), 4) for v in shares],
                                                    "reached": round(float(reached), 4)})


def record_models(scene, fingerprint: str, status: str | None = None):
    """status: how they were trained; None keeps the scene's."""
    s = scene.lapig
    s.models_fingerprint = fingerprint
    if status is not None:
        s.models_status = status


def record_result(scene, folder, summary_line: str, reach_message: str = ""):
    """reach_message: the plain sentence when most of the look is out of the surface's reach."""
    s = scene.lapig
    s.result_dir, s.result_summary = storage.stored_path(folder), summary_line
    s.result_reach_message = reach_message
    s.result_fingerprint = read_rig(scene).fingerprint
    record_look_sliders(scene, folder)  # a world look's sliders follow its result


def look_slider_values(scene) -> dict:
    """The world look's sliders as the panel holds them ({name: value}, lapig_core/look_parameters)."""
    from ...lapig_core.look_parameters import PARAMETERS

    return {p.name: getattr(scene.lapig, f"look_{p.name}") for p in PARAMETERS}


def look_sliders_shown(scene) -> bool:
    """Whether the sliders stand for the scene's result (a world look's; set by record_look_sliders)."""
    s = scene.lapig
    return bool(s.look_sliders_result) and s.look_sliders_result == s.result_dir


def record_look_sliders(scene, folder) -> None:
    """The sliders set to the world look of the result in `folder` (result.json's lgst.look_parameters), without
    running their update (which would make it again); none shown for a look of another kind."""
    import json

    s = scene.lapig
    try:
        with open(os.path.join(folder, "result.json"), encoding="utf-8") as f:
            values = (json.load(f).get("lgst") or {}).get("look_parameters")
    except (OSError, ValueError):
        values = None
    if not isinstance(values, dict):
        s.look_sliders_result = ""
        return
    for name, value in values.items():
        key = f"look_{name}"
        if key in s.bl_rna.properties:
            s[key] = int(value) if s.bl_rna.properties[key].type == "INT" else float(value)
    s.look_sliders_result = storage.stored_path(folder)


def record_preview_mode(scene, mode: str):
    """What the object shows, already applied: set without re-running the property's update callback."""
    s = scene.lapig
    s["preview_mode"] = s.bl_rna.properties["preview_mode"].enum_items[mode].value


def record_job_progress(scene, progress: float, message: str):
    s = scene.lapig
    s.job_progress, s.job_message = progress, message


def write_stylize_settings(scene, request: GenerateRequest):
    """Set the Stylize panel to a request (a scene built for it, such as the demo's, then shows it)."""
    s = scene.lapig
    s.prompt, s.backend, s.style_override = request.prompt, request.backend, request.mix
    s.use_psa, s.psa_adaptation, s.style_seed = request.psa, request.adaptation, request.seed
    s.dark_outside, s.output_size = request.dark_outside, request.output_size
    s.style_image = request.style_images[0] if request.style_images else ""  # the panel holds one
    s.style_prompt_weight = request.style_prompt_weight


def light_plan(scene):
    """The Light sub-panel's settings (scene.lapig_light) as a services.light_report.LightPlan; its
    problem() says what is wrong with them."""
    from ...lapig_core.photometry.dose import ConservationLimit, Schedule
    from ..services.light.light_report import LightPlan

    s = scene.lapig_light
    limit = None
    if s.category != "NONE":
        limit = ConservationLimit(s.category.lower(), s.limit_lux, Schedule(s.hours_per_day, s.days_per_year))
    return LightPlan(preset="" if s.preset == "NONE" else s.preset, lumens=0.0 if s.preset != "NONE" else s.lumens,
                     ambient_lux=s.ambient_lux, lamp_direction=tuple(s.lamp_direction) if s.use_lamp else None,
                     limit=limit, region_material=s.region_material.name if s.region_material else "",
                     region_group=s.region_group)


# ------------------------------------------------------------------ the show (issue 38)

def scene_fps(scene) -> float:
    """The scene's frame rate, which is the show's."""
    r = scene.render
    return r.fps / r.fps_base if r.fps_base else 0.0


def read_show(scene):
    """The show of scene.lapig.show_looks as a services/show/show_plan.ShowPlan, at the scene's frame rate, starting
    at the scene's first frame; a look's result folder is found again beside a moved .blend ('' when gone)."""
    from ..services.show.show_plan import ShowLook, ShowPlan

    looks = tuple(ShowLook(result_dir=storage.resolve_result_dir(item.result_dir) if item.result_dir else "",
                           name=item.name, hold_s=item.hold_s, transition=item.transition,
                           transition_s=item.transition_s, motion=item.motion, motion_amount=item.motion_amount,
                           motion_period_s=item.motion_period_s)
                  for item in scene.lapig.show_looks)
    return ShowPlan(looks=looks, fps=scene_fps(scene), frame_start=scene.frame_start)


def show_index(scene) -> int:
    return scene.lapig.show_index


def add_show_look(scene, folder: str, name: str = "", **settings) -> int:
    """A look of the result `folder` at the end of the show (hold, transition, motion: the defaults or
    `settings`); the index of the new look, which becomes the active one."""
    s = scene.lapig
    item = s.show_looks.add()
    for key, value in settings.items():
        setattr(item, key, value)
    if not name:
        from ..services.show.show_plan import look_name

        name = look_name(folder)
    item.name = name
    item.result_dir = storage.stored_path(folder)  # last: its update writes the markers once all is set
    s.show_index = len(s.show_looks) - 1
    return s.show_index


def remove_show_look(scene, index: int) -> bool:
    from ..services.show.show_plan import index_after_removal

    s = scene.lapig
    if not 0 <= index < len(s.show_looks):
        return False
    s.show_looks.remove(index)
    s.show_index = index_after_removal(len(s.show_looks), index)
    _show_list_changed(scene)
    return True


def move_show_look(scene, index: int, direction: int) -> int:
    """Move look `index` one place up (-1) or down (+1); its new index (the active one)."""
    from ..services.show.show_plan import moved

    s = scene.lapig
    _, target = moved(range(len(s.show_looks)), index, direction)
    if target != index:
        s.show_looks.move(index, target)
        s.show_index = target
        _show_list_changed(scene)
    return target


# Called with the scene when a look is removed or moved (no property's update runs then): blender/show_timeline
# registers its rewrite of the timeline's markers here, as scene_state sits below it and must not import it.
SHOW_LIST_LISTENERS: list = []


def _show_list_changed(scene) -> None:
    for listener in list(SHOW_LIST_LISTENERS):
        listener(scene)


def set_show_look(scene, index: int, **settings) -> None:
    """Change look `index`'s settings by name (name, hold_s, transition, transition_s, motion, ...)."""
    item = scene.lapig.show_looks[index]
    for key, value in settings.items():
        setattr(item, key, value)


def show_markers(scene) -> list:
    """The markers the show wrote last, [(frame, name)]."""
    import json

    try:
        return [(int(f), str(n)) for f, n in json.loads(scene.lapig.show_markers or "[]")]
    except (ValueError, TypeError):
        return []


def record_show_markers(scene, markers) -> None:
    import json

    scene.lapig.show_markers = json.dumps([[int(f), str(n)] for f, n in markers])


def show_baked(scene) -> tuple[str, str]:
    """(the baked show's folder, absolute, '' when none or gone; the key of the show it was baked from)."""
    s = scene.lapig
    folder = bpy.path.abspath(s.show_baked) if s.show_baked else ""
    return (folder if folder and os.path.isdir(folder) else ""), s.show_baked_key


def record_show_baked(scene, folder: str, key: str) -> None:
    s = scene.lapig
    s.show_baked, s.show_baked_key = (storage.stored_path(folder) if folder else ""), key

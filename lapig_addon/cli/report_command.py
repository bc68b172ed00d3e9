"""`python -m lapig_addon report`: the light plan of the scene's rig and look, as JSON.

Every input is checked before the .blend opens (services/light_report.LightPlan.problem). The maps are
rendered with the light as the scene has it and scaled to the plan's lumens (light adds linearly), so the
scene is not changed unless --apply --save asks for it.
"""
from __future__ import annotations

import math
import os

# the parser is built before numpy and OpenCV are checked (cli/main): the work's imports are in _work()


def _work():
    global np, to_float, write_png, resize_image, read_output_image, quantised_frame, dose, light_maps, units
    global light_report, print_json
    import numpy as np

    from ...lapig_core.common.imageio import to_float, write_png
    from ...lapig_core.common.resample import resize_image
    from ...lapig_core.export.result_files import read_output_image
    from ...lapig_core.optics.projector_model import quantised_frame
    from ...lapig_core.photometry import dose, light_maps, units
    from ..services import light_report
    from .output import print_json


def add_parser(sub):
    r = sub.add_parser("report", help="the look in lux, cd/m2 and contrast against the room, and the light "
                                      "dose on a marked region, as JSON")
    r.add_argument("--blend", help=".blend file with a LAPIG rig (default: the open file)")
    r.add_argument("--save", action="store_true", help="with --apply: save the .blend afterwards")
    r.add_argument("--result", help="result folder (default: the scene's result; none: a white frame)")
    r.add_argument("--preset", default="", help="a projector preset id (see --list-presets)")
    r.add_argument("--list-presets", action="store_true", help="print the projector presets and stop")
    r.add_argument("--lumens", type=float, default=0.0, help="ANSI lumens (default: the preset's)")
    r.add_argument("--contrast", type=float, default=0.0, help="the projector's contrast ratio (default: the preset's)")
    r.add_argument("--ambient-lux", type=float, default=0.0, help="the room's illuminance on the object (lux)")
    r.add_argument("--lamp-direction", help="x,y,z: the way the room's lamp shines (default: from every direction)")
    r.add_argument("--category", choices=["none", "high", "moderate", "custom"], default="none",
                   help="conservation category of the object: high (50 lux), moderate (200 lux), custom")
    r.add_argument("--limit-lux", type=float, default=50.0, help="custom: the lux limit")
    r.add_argument("--hours-per-day", type=float, default=8.0, help="the show's hours a day (default 8)")
    r.add_argument("--days-per-year", type=float, default=300.0, help="the show's days a year (default 300)")
    r.add_argument("--region-material", default="", help="mark only the faces of this material (default: the object)")
    r.add_argument("--size", default="160x120", help="light map size WxH (default 160x120)")
    r.add_argument("--maps", metavar="DIR", help="write the lux, luminance and contrast maps as PNGs here")
    r.add_argument("--cap-out", metavar="PNG", help="write the projector image limited to the category's lux here")
    r.add_argument("--apply", action="store_true", help="set the projector light's power and black level from "
                                                        "the plan (with --save: keep them)")
    r.set_defaults(func=cmd_report)


def _direction(text):
    if not text:
        return None
    try:
        values = tuple(float(v) for v in text.split(","))
    except ValueError:
        raise ValueError(f"--lamp-direction must be three numbers like 0,0,-1, got '{text}'") from None
    if len(values) != 3:
        raise ValueError(f"--lamp-direction must be three numbers like 0,0,-1, got '{text}'")
    return values


def _size(text):
    try:
        w, h = (int(v) for v in text.lower().split("x"))
    except ValueError:
        raise ValueError(f"--size must look like 160x120, got '{text}'") from None
    if not (8 <= w <= 4096 and 8 <= h <= 4096):
        raise ValueError(f"--size must be 8 to 4096 pixels a side, got '{text}'")
    return w, h


def plan_from_args(args) -> light_report.LightPlan:
    limit = None
    if args.category != "none":
        limit = dose.ConservationLimit(args.category, args.limit_lux,
                                       dose.Schedule(args.hours_per_day, args.days_per_year))
    plan = light_report.LightPlan(preset=args.preset, lumens=args.lumens, contrast=args.contrast,
                                  ambient_lux=args.ambient_lux, lamp_direction=_direction(args.lamp_direction),
                                  limit=limit, region_material=args.region_material)
    return plan.check()


def _frame(folder, model):
    image = read_output_image(folder, "projector")
    return to_float(quantised_frame(image, model.width, model.height, 8))


def _table_row(projector, target, model, plan, white_lux_mean):
    import bpy  # noqa: F401  (Blender's types for the matrices)
    from ..blender import rig

    preset = plan.projector_preset
    loc = tuple(projector.matrix_world.translation)
    rot = tuple(math.degrees(a) for a in projector.matrix_world.to_euler("XYZ"))
    return {"name": projector.name, "maker": preset.maker if preset else "", "model": preset.model if preset else "",
            "resolution": [model.width, model.height], "lumens": plan.resolved_lumens,
            "throw_ratio": model.throw_ratio, "shift_x": model.shift_x, "shift_y": model.shift_y,
            "position_m": loc, "rotation_deg": rot,
            "target_distance_m": rig.axial_distance(projector, rig.object_centre(target)),
            "target_lux": white_lux_mean}


def cmd_report(args) -> int:
    _work()
    from ...lapig_core.photometry import presets

    if args.list_presets:
        print_json({"presets": [p.to_dict() for p in presets.all_presets()]})
        return 0
    plan = plan_from_args(args)  # before the .blend opens
    width, height = _size(args.size)
    from ..blender import light_render, scene_state
    from ..blender.scene_store import BlenderSceneStore
    from .commands import _open_scene, _save_if_asked

    scene = _open_scene(args)
    projector, _, target = scene_state.rig_objects(scene)
    model = scene_state.projector_model(projector)
    if plan.resolved_contrast:
        model = type(model)(**{**model.to_dict(), "black_level": units.black_level_from_contrast(plan.resolved_contrast)})
    watts = units.lumens_to_watts(plan.resolved_lumens, model)
    if projector.data.energy <= 0:
        raise ValueError(f"'{projector.name}' has no light power to render with: set its brightness above 0")
    scale = watts / projector.data.energy
    maps = light_render.projector_light_maps(scene, projector, target, width, height, plan.ambient_lux,
                                             plan.lamp_direction, plan.region_material)
    maps.white_lux = maps.white_lux * scale
    if not maps.on_object.any():
        raise ValueError(f"the projector does not reach '{target.name}': aim it at the object")
    if plan.region_material and not (maps.region & maps.on_object).any():
        raise ValueError(f"the material '{plan.region_material}' has no faces the projector lights: mark "
                         "faces it reaches, or the whole object")
    store = BlenderSceneStore(scene)
    state = store.read()
    folder = os.path.abspath(args.result) if args.result else state.result_dir
    emitted = None
    if folder:
        frame = _frame(folder, model)
        small = resize_image(model.emitted(frame).astype(np.float32), width, height)
        emitted = small @ units.LUMA
    report = light_report.light_report(plan, maps, emitted, model)
    report["result"] = folder or None
    report["projector_table_row"] = _table_row(projector, target, model, plan,
                                               float(maps.white_lux[maps.on_object].mean()))
    if args.maps:
        os.makedirs(args.maps, exist_ok=True)
        look = maps.white_lux * (emitted if emitted is not None else 1.0)
        total = look + maps.ambient_lux
        contrast = units.contrast_ratio(maps.white_lux, maps.ambient_lux, plan.resolved_contrast)
        write_png(os.path.join(args.maps, "lux.png"), light_maps.lux_colour_map(total, maps.on_object))
        write_png(os.path.join(args.maps, "luminance.png"),
                  light_maps.lux_colour_map(units.luminance_cd_m2(maps.albedo, total), maps.on_object, 0.3, 3000))
        write_png(os.path.join(args.maps, "contrast.png"), light_maps.contrast_colour_map(contrast, maps.on_object))
        report["maps"] = os.path.abspath(args.maps)
    if args.cap_out:
        report["cap"] = _write_capped(args.cap_out, plan, scene, projector, target, model, maps, folder, scale)
    if folder:
        report["report_file"] = light_report.write_report(folder, report)
    if args.apply:
        projector.lapig_projector.brightness = watts
        if plan.resolved_contrast:
            projector.lapig_projector.black_level = model.black_level
        _save_if_asked(args)
    print_json(report)
    return 0


def _write_capped(path, plan, scene, projector, target, model, maps, folder, scale) -> dict:
    from ..blender import light_render

    if plan.limit is None:
        raise ValueError("--cap-out needs a conservation category (--category)")
    if not folder:
        raise ValueError("--cap-out needs a result: generate a look first")
    frame = _frame(folder, model)
    with light_render.LightStudio(scene, projector, target, model.width, model.height,
                                  region_material=plan.region_material) as studio:
        native = studio.render_maps()
    white = native.white_lux * scale
    ambient = resize_image(np.repeat(maps.ambient_lux[..., None], 3, -1).astype(np.float32), model.width,
                           model.height)[..., 0]
    region = native.region & native.on_object
    capped, info = light_report.capped_frame(plan, frame, white, ambient, region, model)
    write_png(os.path.abspath(path), capped)
    predicted = white * (model.emitted(capped) @ units.LUMA) + ambient
    return {**info, "path": os.path.abspath(path),
            "predicted_max_lux": round(float(predicted[region].max()), 2)}

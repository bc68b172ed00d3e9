"""`python -m lapig_addon report`: the light plan of the scene's rig and look, as JSON.

Every input is checked before the .blend opens (services/light/light_report.LightPlan.problem). The maps are
rendered with the light as the scene has it and scaled to the plan's lumens (light adds linearly), so the
scene is not changed unless --apply --save asks for it.
"""
from __future__ import annotations

import os

# the parser is built before numpy and OpenCV are checked (cli/main): the work's imports are in _work()


def _work():
    global dose, units, light_report, print_json
    from ...lapig_core.photometry import dose, units
    from ..services.light import light_report
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
    r.add_argument("--region-group", default="", help="mark only the faces of this vertex group (default: the object)")
    r.add_argument("--map-width", type=int, default=160,
                   help="light map width in pixels, its height in the projector's shape (default 160)")
    r.add_argument("--maps", metavar="DIR", help="write the lux, luminance and contrast maps as PNGs here")
    r.add_argument("--cap-out", metavar="PNG", help="write the projector image limited to the category's lux here")
    r.add_argument("--cap-result", action="store_true",
                   help="make the look limited to the category's lux a result of its own (<result>_dose_cap; "
                        "with --save the scene's result, which Export and the preview then use)")
    r.add_argument("--psnr", action="store_true", help="with --cap-result: project both looks on the rig and "
                                                       "report the cap's cost in PSNR against the target")
    r.add_argument("--apply", action="store_true",
                   help="set the projector to the plan: the preset's native resolution, the throw ratio and lens "
                        "shift nearest the rig's within its ranges, the light's power and black level (with "
                        "--save: keep them; they are part of the rig's fingerprint, so the capture goes stale)")
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


def plan_from_args(args) -> light_report.LightPlan:
    limit = None
    if args.category != "none":
        limit = dose.ConservationLimit(args.category, args.limit_lux,
                                       dose.Schedule(args.hours_per_day, args.days_per_year))
    plan = light_report.LightPlan(preset=args.preset, lumens=args.lumens, contrast=args.contrast,
                                  ambient_lux=args.ambient_lux, lamp_direction=_direction(args.lamp_direction),
                                  limit=limit, region_material=args.region_material,
                                  region_group=args.region_group)
    return plan.check()


def cmd_report(args) -> int:
    _work()
    from ...lapig_core.photometry import presets

    if args.list_presets:
        print_json({"presets": [p.to_dict() for p in presets.all_presets()]})
        return 0
    plan = plan_from_args(args)  # before the .blend opens
    if not 8 <= args.map_width <= 4096:
        raise ValueError(f"--map-width must be 8 to 4096 pixels, got {args.map_width}")
    from ..blender import light_plan_run
    from ..blender.scene_store import BlenderSceneStore
    from ..services.state import JOINT
    from .commands import _open_scene, _save_if_asked

    scene = _open_scene(args)
    folder = os.path.abspath(args.result) if args.result else BlenderSceneStore(scene).read().result_dir
    if BlenderSceneStore(scene).read().rig.strategy == JOINT and (args.cap_out or args.psnr):
        # the per-pixel cap and its cost are in one projector's frame; several share one factor (--cap-result)
        raise ValueError("--cap-out and --psnr work with one projector; for several use --cap-result")
    # the Light Report button's job, run here to its end (several projectors: every one's light over the camera's)
    report = light_plan_run.report_job(scene, plan, folder or None, args.map_width, args.maps).run_to_completion()
    if args.cap_out:
        report["cap"] = light_plan_run.write_capped(args.cap_out, scene, plan, folder)
    if args.cap_result:
        report["capped_result"] = light_plan_run.cap_job(scene, plan, folder, record=args.save,
                                                         measure_psnr=args.psnr).run_to_completion()
        report["capped_result"].pop("summary", None)
        _save_if_asked(args)
    if args.apply:
        settings, notes = light_plan_run.apply_projector(scene, plan)
        report["applied"] = {"settings": settings, "notes": notes}
        _save_if_asked(args)
    print_json(report)
    return 0

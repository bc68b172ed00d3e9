"""The light report of the scene's rig and look (bpy): the maps rendered, scaled to the plan's lumens,
the look's light on them, the report written into the result folder with its preview maps. The `report`
command and the panel's Light Report button both run this."""
from __future__ import annotations

import math
import os

import numpy as np

from ...lapig_core.common.imageio import to_float, write_png
from ...lapig_core.common.resample import resize_image
from ...lapig_core.export.result_files import read_output_image
from ...lapig_core.optics.projector_model import quantised_frame
from ...lapig_core.photometry import light_maps, units
from ..services import light_report
from . import light_render, rig, scene_state

LUX_MAP, CONTRAST_MAP = "light_lux", "light_contrast"  # result-folder PNGs the preview shows


def result_frame(folder, model) -> np.ndarray:
    """The result's projector frame as the projector receives it (native, 8-bit steps, float)."""
    return to_float(quantised_frame(read_output_image(folder, "projector"), model.width, model.height, 8))


def plan_model(projector, plan):
    model = scene_state.projector_model(projector)
    if plan.resolved_contrast:
        model = type(model)(**{**model.to_dict(), "black_level": units.black_level_from_contrast(plan.resolved_contrast)})
    return model


def table_row(projector, target, model, plan, white_lux_mean) -> dict:
    preset = plan.projector_preset
    return {"name": projector.name, "maker": preset.maker if preset else "", "model": preset.model if preset else "",
            "resolution": [model.width, model.height], "lumens": plan.resolved_lumens,
            "throw_ratio": model.throw_ratio, "shift_x": model.shift_x, "shift_y": model.shift_y,
            "position_m": tuple(projector.matrix_world.translation),
            "rotation_deg": tuple(math.degrees(a) for a in projector.matrix_world.to_euler("XYZ")),
            "target_distance_m": rig.axial_distance(projector, rig.object_centre(target)),
            "target_lux": white_lux_mean}


def render_plan_maps(scene, plan, width, height):
    """(maps scaled to the plan's lumens, model, power scale): white_lux as the plan's projector gives it."""
    projector, _, target = scene_state.rig_objects(scene)
    if projector is None or target is None:
        raise light_render.LightRenderError("set up the rig first: there is no projector or no object")
    if projector.data.energy <= 0:
        raise ValueError(f"'{projector.name}' has no light power to render with: set its brightness above 0")
    model = plan_model(projector, plan)
    scale = units.lumens_to_watts(plan.resolved_lumens, model) / projector.data.energy
    maps = light_render.projector_light_maps(scene, projector, target, width, height, plan.ambient_lux,
                                             plan.lamp_direction, plan.region_material,
                                             region_group=plan.region_group)
    maps.white_lux = maps.white_lux * scale
    if not maps.on_object.any():
        raise ValueError(f"the projector does not reach '{target.name}': aim it at the object")
    marked = (f"the material '{plan.region_material}'" if plan.region_material else
              f"the vertex group '{plan.region_group}'" if plan.region_group else "")
    if marked and not (maps.region & maps.on_object).any():
        raise ValueError(f"{marked} has no faces the projector lights: mark faces it reaches, or the whole object")
    return maps, model, scale


def map_size(projector, width: int = 160) -> tuple[int, int]:
    """A light map `width` pixels wide in the projector's shape."""
    columns, rows = scene_state.projector_size(projector)
    return width, max(8, round(width * rows / columns))


def run_report(scene, plan, folder: str | None, width=160, maps_dir: str | None = None) -> dict:
    """The report (see services/light_report); folder: the result (None: a white frame, nothing written)."""
    plan.check()
    projector, _, target = scene_state.rig_objects(scene)
    if projector is None or target is None:
        raise ValueError("set up the rig first: there is no projector or no object")
    width, height = map_size(projector, width)
    maps, model, _ = render_plan_maps(scene, plan, width, height)
    emitted = None
    if folder:
        small = resize_image(model.emitted(result_frame(folder, model)).astype(np.float32), width, height)
        emitted = small @ units.LUMA
    report = light_report.light_report(plan, maps, emitted, model)
    report["result"] = folder or None
    report["projector_table_row"] = table_row(projector, target, model, plan,
                                              float(maps.white_lux[maps.on_object].mean()))
    look = maps.white_lux * (emitted if emitted is not None else 1.0)
    total = look + maps.ambient_lux
    contrast = light_maps.finite_contrast(units.contrast_ratio(maps.white_lux, maps.ambient_lux,
                                                               plan.resolved_contrast))
    images = {LUX_MAP: light_maps.lux_colour_map(total, maps.on_object),
              CONTRAST_MAP: light_maps.contrast_colour_map(contrast, maps.on_object),
              "light_luminance": light_maps.lux_colour_map(units.luminance_cd_m2(maps.albedo, total),
                                                           maps.on_object, 0.3, 3000)}
    for target_dir in [d for d in (folder, maps_dir) if d]:
        os.makedirs(target_dir, exist_ok=True)
        for name, image in images.items():
            write_png(os.path.join(target_dir, name + ".png"), image)
    if maps_dir:
        report["maps"] = os.path.abspath(maps_dir)
    if folder:
        report["report_file"] = light_report.write_report(folder, report)
    return report


def write_capped(path, scene, plan, folder) -> dict:
    """The result's projector image limited to the plan's lux limit on the marked region, written to path."""
    capped, info = capped_frame(scene, plan, folder)
    write_png(os.path.abspath(path), capped)
    return {**info, "path": os.path.abspath(path)}


def cap_result(scene, plan, folder, record: bool = False, measure_psnr: bool = False) -> dict:
    """The limited look as a result of its own (services/dose_cap); record: make it the scene's result and
    show it on the projector light; measure_psnr: project both on the rig for the cap's cost."""
    from ..services import dose_cap
    from . import scene_store

    state = scene_state.read(scene)
    if measure_psnr and not state.capture_dir:  # before anything is written
        raise ValueError("measuring the cap's cost needs the scene's capture: capture first")
    capped, info = capped_frame(scene, plan, folder)
    new = dose_cap.write_capped_result(folder, capped, info)
    out = {**info, "folder": str(new)}
    if measure_psnr:
        model = plan_model(scene_state.rig_objects(scene)[0], plan)
        out.update(dose_cap.rendered_psnr_cost(scene_store.scene_seams(scene).devices, state.capture_dir, folder,
                                               result_frame(folder, model), capped))
    if record:
        scene_state.record_result(scene, str(new), scene_state.result_summary(scene) + " | limited to the light dose")
        scene_store.show_scene_result(scene)
    return out


def capped_frame(scene, plan, folder):
    """(the result's native frame limited to the plan's lux on the marked region, what the cap did)."""
    if plan.limit is None:
        raise ValueError("limiting the look needs a conservation category")
    if not folder:
        raise ValueError("limiting the look needs a result: generate a look first")
    projector, _, target = scene_state.rig_objects(scene)
    model = plan_model(projector, plan)
    room, _, scale = render_plan_maps(scene, plan, *map_size(projector))
    frame = result_frame(folder, model)
    with light_render.LightStudio(scene, projector, target, model.width, model.height,
                                  region_material=plan.region_material, region_group=plan.region_group) as studio:
        native = studio.render_maps()
    white = native.white_lux * scale
    ambient = resize_image(np.repeat(room.ambient_lux[..., None], 3, -1).astype(np.float32), model.width,
                           model.height)[..., 0]
    region = native.region & native.on_object
    capped, info = light_report.capped_frame(plan, frame, white, ambient, region, model)
    predicted = white * (model.emitted(capped) @ units.LUMA) + ambient
    return capped, {**info, "predicted_max_lux": round(float(predicted[region].max()), 2)}


def apply_projector(scene, plan) -> tuple[dict, list[str]]:
    """Set the scene's projector to the plan's model (services/light_report.projector_settings); the
    brightness, resolution and lens are part of the rig's fingerprint, so the capture goes stale."""
    projector = scene_state.rig_objects(scene)[0]
    if projector is None:
        raise ValueError("set up the rig first: there is no projector")
    settings, notes = light_report.projector_settings(plan, scene_state.projector_model(projector))
    scene_state.write_projector_settings(projector, settings)
    return {k: (round(v, 6) if isinstance(v, float) else v) for k, v in settings.items()}, notes

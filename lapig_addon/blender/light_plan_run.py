"""The light report of the scene's rig and look (bpy): the maps rendered, scaled to the plan's lumens,
the look's light on them, the report written into the result folder with its preview maps. The `report`
command and the panel's Light Report button both run this."""
from __future__ import annotations

import math
import os

import numpy as np

from ...lapig_core.common.imageio import write_png
from ...lapig_core.common.resample import resize_image
from ...lapig_core.photometry import light_maps, units
from ..services import light_report
from . import light_render, rig, scene_state

LUX_MAP, CONTRAST_MAP = "light_lux", "light_contrast"  # result-folder PNGs the preview shows


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
        small = resize_image(model.emitted(light_report.native_frame(folder, model)).astype(np.float32), width, height)
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


def cap_job(scene, plan, folder: str | None = None, record: bool = True, measure_psnr: bool = False):
    """Limit Look to the Dose as a job (services/dose_cap.DoseCapJob) on the scene's seams: its result (or
    `folder`), its capture's lock, its rig's device factory."""
    from ..services.dose_cap import DoseCapJob
    from .scene_store import scene_seams

    return DoseCapJob(scene_seams(scene), plan, SceneLight(scene, plan), folder, record=record,
                      measure_psnr=measure_psnr)


def cap_result(scene, plan, folder, record: bool = False, measure_psnr: bool = False) -> dict:
    """The limited look as a result of its own, the job run to its end (the command line); record: it becomes
    the scene's result; measure_psnr: both projected on the rig for the cap's cost."""
    return cap_job(scene, plan, folder, record, measure_psnr).run_to_completion()


def capped_frame(scene, plan, folder):
    """(the result's native frame limited to the plan's lux on the marked region, what the cap did)."""
    from ..services.dose_cap import capped_look

    if not folder:
        raise ValueError("limiting the look needs a result: generate a look first")
    light = SceneLight(scene, plan)
    room, native = light.room(), light.native()
    return capped_look(plan, light.model, light_report.native_frame(folder, light.model), room, native)


class SceneLight:
    """The scene's light from its projector in lux, as the dose cap needs it (services/dose_cap.LightRenders):
    Cycles renders, each on Blender's main thread."""

    def __init__(self, scene, plan):
        if plan.limit is None:
            raise ValueError("limiting the look needs a conservation category")
        self.scene, self.plan = scene, plan
        self.projector, _, self.target = scene_state.rig_objects(scene)
        if self.projector is None or self.target is None:
            raise ValueError("set up the rig first: there is no projector or no object")
        self.model = plan_model(self.projector, plan)
        self.scale = None  # the plan's lumens over the light's power, found by room()

    def room(self):
        maps, _, self.scale = render_plan_maps(self.scene, self.plan, *map_size(self.projector))
        return maps

    def native(self):
        if self.scale is None:
            self.room()
        with light_render.LightStudio(self.scene, self.projector, self.target, self.model.width, self.model.height,
                                      region_material=self.plan.region_material,
                                      region_group=self.plan.region_group) as studio:
            maps = studio.render_maps()
        maps.white_lux = maps.white_lux * self.scale
        return maps

    def report(self, folder: str) -> dict:
        return run_report(self.scene, self.plan, folder)


def apply_projector(scene, plan) -> tuple[dict, list[str]]:
    """Set the scene's projector to the plan's model (services/light_report.projector_settings); the
    brightness, resolution and lens are part of the rig's fingerprint, so the capture goes stale."""
    projector = scene_state.rig_objects(scene)[0]
    if projector is None:
        raise ValueError("set up the rig first: there is no projector")
    settings, notes = light_report.projector_settings(plan, scene_state.projector_model(projector))
    scene_state.write_projector_settings(projector, settings)
    return {k: (round(v, 6) if isinstance(v, float) else v) for k, v in settings.items()}, notes

"""The light report and the dose cap of the scene's rig and look (bpy): SceneLight (one projector, its own frame)
or JointSceneLight (every projector over the camera's pixels), chosen by the rig's strategy (scene_light), reads
the rig on the main thread and renders the maps as job steps (one Cycles render a step);
services/light/light_report_job (the Light Report button and the `report` command: report_job) and services/light/dose_cap
(Limit Look to the Dose: cap_job) turn them into the report, the capped look and their files on a worker thread."""
from __future__ import annotations

import math
import os

import numpy as np

from ...lapig_core.common.imageio import write_png
from ...lapig_core.common.steps import run_to_end
from ...lapig_core.photometry import units
from ..services.light import light_report
from ..services.light.light_joint import joint_lumens
from ..services.state import JOINT, PROJECTOR_SPACE
from ..services.ways import chosen_way
from . import light_render, rig, scene_state

LUX_MAP, CONTRAST_MAP = light_report.LUX_MAP, light_report.CONTRAST_MAP  # result-folder PNGs the preview shows


def plan_model(projector, plan):
    model = scene_state.projector_model(projector)
    if plan.resolved_contrast:
        model = type(model)(**{**model.to_dict(), "black_level": units.black_level_from_contrast(plan.resolved_contrast)})
    return model


def rig_row(projector, target, model, plan) -> dict:
    """The rig's row of the projector table (the report adds the object's lux: target_lux)."""
    preset = plan.projector_preset
    return {"name": projector.name, "maker": preset.maker if preset else "", "model": preset.model if preset else "",
            "resolution": [model.width, model.height], "lumens": plan.resolved_lumens,
            "throw_ratio": model.throw_ratio, "shift_x": model.shift_x, "shift_y": model.shift_y,
            "position_m": tuple(projector.matrix_world.translation),
            "rotation_deg": tuple(math.degrees(a) for a in projector.matrix_world.to_euler("XYZ")),
            "target_distance_m": rig.axial_distance(projector, rig.object_centre(target))}


def map_size(projector, width: int = 160) -> tuple[int, int]:
    """A light map `width` pixels wide in the projector's shape."""
    columns, rows = scene_state.projector_size(projector)
    return width, max(8, round(width * rows / columns))


def scene_light(scene, plan, width: int = 160):
    """The scene's light for the report and the dose cap, as the rig's strategy models it: one projector's in its
    own frame (SceneLight), several projectors' over the camera's pixels (JointSceneLight)."""
    return chosen_way(scene_state.read_rig(scene), SceneLight, JointSceneLight)(scene, plan, width)


def report_job(scene, plan, folder: str | None, width: int = 160, maps_dir: str | None = None):
    """The Light Report as a job (services/light/light_report_job.LightReportJob): the report of the scene's look
    (folder: its result; None: a white frame, nothing written there), its maps `width` pixels wide."""
    from ..services.light.light_report_job import LightReportJob

    return LightReportJob(plan, scene_light(scene, plan, width), folder or None, maps_dir)


def write_capped(path, scene, plan, folder) -> dict:
    """The result's projector image limited to the plan's lux limit on the marked region, written to path (the
    command line's --cap-out: one projector's frame, rendered and computed here); what the cap did."""
    from ..services.light.dose_cap import capped_look

    if plan.limit is None:
        raise ValueError("limiting the look needs a conservation category")
    if not folder:
        raise ValueError("limiting the look needs a result: generate a look first")
    light = SceneLight(scene, plan)
    room = light_report.plan_maps(run_to_end(light.room_steps()), light.scale, light.target_name, plan)
    _, capped, info = capped_look(plan, light, folder, room, run_to_end(light.native_steps()))
    write_png(os.path.abspath(path), capped)
    return {**info, "path": os.path.abspath(path)}


def cap_job(scene, plan, folder: str | None = None, record: bool = True, measure_psnr: bool = False):
    """Limit Look to the Dose as a job (services/light/dose_cap.DoseCapJob) on the scene's seams: its result (or
    `folder`), its capture's lock, its rig's device factory; a rig of several projectors limits every projector's
    light by one factor (services/light/dose_cap_joint)."""
    from ..services.light.dose_cap import DoseCapJob
    from .scene_store import scene_seams

    if plan.limit is None:
        raise ValueError("limiting the look needs a conservation category")
    return DoseCapJob(scene_seams(scene), plan, scene_light(scene, plan), folder, record=record,
                      measure_psnr=measure_psnr)


class SceneLight:
    """The scene's light from its projector in lux, as the report and the dose cap need it
    (services/light/light_report_job.ReportLight, services/light/dose_cap.LightRenders): the rig read when made, on the main
    thread, and every input checked; the Cycles renders as steps, each on Blender's main thread, into passes a
    worker turns into maps (light_report.plan_maps)."""

    strategy = PROJECTOR_SPACE

    def __init__(self, scene, plan, width: int = 160):
        plan.check()
        self.scene, self.plan = scene, plan
        self.projector, _, self.target = scene_state.rig_objects(scene)
        if self.projector is None or self.target is None:
            raise light_render.LightRenderError("set up the rig first: there is no projector or no object")
        check_power([self.projector])
        self.model = plan_model(self.projector, plan)
        self.scale = units.lumens_to_watts(plan.resolved_lumens, self.model) / self.projector.data.energy
        self.size = map_size(self.projector, width)
        self.target_name = self.target.name
        self.row = rig_row(self.projector, self.target, self.model, plan)

    def room_steps(self, start: float = 0.0, end: float = 1.0):
        """The maps at the report's size with the room's light: one Cycles render a step; the passes."""
        return self._steps(self.size, self.plan.ambient_lux, start, end)

    def native_steps(self, start: float = 0.0, end: float = 1.0):
        """The projector's light at its native size (no room light): one render; the passes."""
        return self._steps((self.model.width, self.model.height), 0.0, start, end)

    def _steps(self, size, ambient_lux, start, end):
        plan = self.plan
        with light_render.LightStudio(self.scene, self.projector, self.target, *size, ambient_lux,
                                      plan.lamp_direction, plan.region_material,
                                      region_group=plan.region_group) as studio:
            count = studio.render_count
            return (yield from studio_steps(studio, lambda done: start + (end - start) * done / count, "rendering "))


def check_power(projectors) -> None:
    """Refused in one line where a projector has no light to render with."""
    for p in projectors:
        if p.data.energy <= 0:
            raise ValueError(f"'{p.name}' has no light power to render with: set its brightness above 0")


def studio_steps(studio, progress, label: str):
    """A LightStudio's renders as steps (progress(renders done), label + what is rendered); their value is its
    passes. A cancel removes the renders' files."""
    renders, done = studio.render_steps(), 0
    try:
        while True:
            try:
                what = next(renders)
            except StopIteration as finished:
                return finished.value
            yield progress(done), label + what
            done += 1
    finally:
        renders.close()


def apply_projector(scene, plan) -> tuple[dict, list[str]]:
    """Set the scene's projector to the plan's model (services/light/light_report.projector_settings); the
    brightness, resolution and lens are part of the rig's fingerprint, so the capture goes stale."""
    projector = scene_state.rig_objects(scene)[0]
    if projector is None:
        raise ValueError("set up the rig first: there is no projector")
    settings, notes = light_report.projector_settings(plan, scene_state.projector_model(projector))
    scene_state.write_projector_settings(projector, settings)
    return {k: (round(v, 6) if isinstance(v, float) else v) for k, v in settings.items()}, notes


class JointSceneLight:
    """The light of a rig of several projectors over its camera's pixels (issue 36; the joint strategy): each
    projector's maps from a LightStudio viewed from the rig's camera (light_render's view), so their light adds
    pixel by pixel; the room's light rendered once, with the first. Each projector at its own lumens
    (services/light/light_joint.joint_lumens: the plan's are the first's, the others' in proportion to their own light
    power); a result's look as each projector shows its image of it (result.json's projectors[k].image), rendered
    as the light it emits. Read on the main thread when made; steps() renders, one Cycles render a step."""

    strategy = JOINT

    def __init__(self, scene, plan, width: int = 160):
        plan.check()
        self.scene, self.plan = scene, plan
        self.projectors = scene_state.rig_projectors(scene)
        _, self.camera, self.target = scene_state.rig_objects(scene)
        if not self.projectors or self.camera is None or self.target is None:
            raise light_render.LightRenderError("set up the rig first: there is no projector, camera or object")
        check_power(self.projectors)
        self.models = [plan_model(p, plan) for p in self.projectors]
        self.names = [p.name for p in self.projectors]
        self.lumens = joint_lumens(plan, [p.data.energy for p in self.projectors], self.models)
        self.scales = [units.lumens_to_watts(lm, m) / p.data.energy
                       for lm, m, p in zip(self.lumens, self.models, self.projectors)]
        c = self.camera.lapig_camera
        width = min(width, c.resolution_x)
        self.size = (width, max(8, round(width * c.resolution_y / c.resolution_x)))
        self.target_name = self.target.name
        self.rows = [rig_row(p, self.target, m, plan) for p, m in zip(self.projectors, self.models)]
        for row, lm in zip(self.rows, self.lumens):
            row["lumens"] = lm

    def steps(self, frames=None, start: float = 0.0, end: float = 1.0):
        """Steps (progress from start to end, message), one render each; the value is (each projector's maps at
        its lumens, each one's relative emitted light of its frame over the camera's pixels, or None for white
        frames). frames: each projector's native image (values as Export writes them), or None."""
        plan, maps, emitted = self.plan, [], ([] if frames is not None else None)
        count = len(self.projectors) * (2 if frames is not None else 1) + (1 if plan.ambient_lux > 0 else 0)
        done = 0
        for k, (projector, model, scale) in enumerate(zip(self.projectors, self.models, self.scales)):
            with light_render.LightStudio(self.scene, projector, self.target, *self.size,
                                          plan.ambient_lux if k == 0 else 0.0, plan.lamp_direction,
                                          plan.region_material, region_group=plan.region_group,
                                          view=self.camera) as studio:
                passes = yield from studio_steps(studio, lambda n: start + (end - start) * (done + n) / count,
                                                 f"rendering {projector.name}: ")
                done += studio.render_count
                m = passes.maps()
                m.white_lux = m.white_lux * scale
                maps.append(m)
                if frames is not None:
                    yield start + (end - start) * done / count, f"rendering {projector.name}: its image of the look"
                    done += 1
                    look = studio.render_frame_lux(model.emitted(frames[k]).astype(np.float32)) * scale
                    with np.errstate(divide="ignore", invalid="ignore"):
                        emitted.append(np.where(m.white_lux > 1e-9, look / np.maximum(m.white_lux, 1e-12), 0.0))
        return maps, emitted

"""Light Report as a job (issue 35): the Light Report button and the `report` command run this.

No bpy. The Cycles renders of the room's light are the job's main-thread steps, one render a step (the UI redraws
between them, Esc cancels there); the maps' arithmetic, the report and its files (light_report.json and its colour
maps, written whole or not at all: common/atomic) are a worker's steps. A cancel before the worker's last step
writes nothing: the previous report stays as it was. In the UI it is a foreground job (blender/modal_runner,
services/background_jobs.JobSlots): the background Train pauses while it runs. Limit Look to the Dose
(services/dose_cap) writes the limited look's report through the same steps, on the room maps it has rendered.
"""
from __future__ import annotations

import os
from typing import Protocol

from ...lapig_core.optics.projector_model import ProjectorModel
from . import light_report
from .jobs import Job


class ReportLight(Protocol):
    """The scene's light from its projector, read on Blender's main thread when made (blender/light_plan_run.
    SceneLight); its renders are steps a job drives on that thread."""

    model: ProjectorModel  # the plan's projector: its native size, gamma and black level
    size: tuple[int, int]  # the report's maps: width, height
    scale: float  # the plan's lumens over the light's power as the scene has it (light adds linearly)
    target_name: str  # the object's name, for what is refused
    row: dict  # the rig's row of the projector table (target_lux: the report adds it)

    def room_steps(self, start: float, end: float):
        """Steps (progress from start to end, message), one Cycles render each, whose value is the passes of the
        projector's light and the room's at `size` (light_passes.LightPasses: maps() on any thread)."""


class LightReportJob(Job):
    """The light report of the scene's look (`folder`: its result; None: a white frame, nothing written into a
    result); maps_dir: the colour maps there too. The result is the report, as the `report` command prints it."""

    title = "LAPIG light report"

    def __init__(self, plan, light: ReportLight, folder: str | None, maps_dir: str | None = None):
        super().__init__()
        self.plan, self.light, self.folder, self.maps_dir = plan, light, folder or None, maps_dir

    def steps(self):
        self.plan.check()
        self.result = yield from report_steps(self, self.plan, self.light, self.folder, self.maps_dir)


def report_steps(job: Job, plan, light: ReportLight, folder: str | None, maps_dir: str | None = None, room=None,
                 span: tuple[float, float] = (0.0, 1.0)):
    """The report's steps, for `job` to `yield from`; their value is the report. room: the room maps at the
    report's size when the job has them already (the dose cap), else rendered here, one render a step."""
    start, end = span
    passes = None
    try:
        if room is None:
            passes = yield from light.room_steps(start, start + 0.8 * (end - start))
        return (yield from job.drive(lambda: _report_work(plan, light, passes, room, folder, maps_dir,
                                                          start + 0.8 * (end - start)), False))
    finally:
        if passes is not None:  # a cancel before the worker read them (else gone already)
            passes.discard()


def _report_work(plan, light: ReportLight, passes, room, folder, maps_dir, progress: float):
    """On a worker thread: the maps from the passes, the report and its files; its value is the report."""
    yield progress, "the light report"
    maps = room if room is not None else light_report.plan_maps(passes, light.scale, light.target_name, plan)
    emitted = light_report.look_emitted(folder, light.model, maps.white_lux.shape[1],
                                        maps.white_lux.shape[0]) if folder else None
    report = light_report.light_report(plan, maps, emitted, light.model)
    report["result"] = folder or None
    report["projector_table_row"] = {**light.row, "target_lux": float(maps.white_lux[maps.on_object].mean())}
    images = light_report.report_images(plan, maps, emitted)
    if maps_dir:
        report["maps"] = os.path.abspath(maps_dir)
    yield progress + 0.1 * (1 - progress), "writing the light report"  # a cancel until here writes nothing
    if maps_dir:
        light_report.write_maps(maps_dir, images)
    if folder:
        report["report_file"] = light_report.write_report(folder, report, images)
    return report


class SeveralReportJob(Job):
    """The light report of a rig of several projectors (issue 36): every projector's light over the camera's
    pixels (blender/light_plan_run.SeveralSceneLight: its renders are this job's main-thread steps, one render a
    step), added on a worker (light_report.several_report), the report written whole into the result as one
    projector's is. Its 'projectors' name each one's lumens and share of the light on the object; 'dose' is
    that of their sum, and 'dose_cap_scale' the one factor on every projector's light that meets the limit."""

    title = "LAPIG light report"

    def __init__(self, plan, light, folder: str | None, maps_dir: str | None = None):
        super().__init__()
        self.plan, self.light, self.folder, self.maps_dir = plan, light, folder or None, maps_dir

    def steps(self):
        self.plan.check()
        frames = None
        if self.folder:
            from ...lapig_core.multi.result_files import projector_images

            frames = [image for _, image in projector_images(self.folder)]
        maps, emitted = yield from self.light.steps(frames)
        return_value = yield from self.drive(lambda: self._work(maps, emitted), False)
        self.result = return_value

    def _work(self, maps, emitted):
        yield 0.85, "the light report"
        light = self.light
        report, total, combined = light_report.several_report(self.plan, maps, emitted, light.models, light.names,
                                                              light.lumens)
        if not total.on_object.any():
            raise ValueError(f"no projector reaches '{light.target_name}' in the camera's view: aim them at it")
        report["frame"] = "camera"  # the maps are over the rig camera's pixels
        report["result"] = self.folder
        # the one factor on every projector's light that Limit Look to the Dose would apply
        report["dose_cap_scale"] = (round(light_report.several_cap_factor(self.plan, total, combined), 4)
                                    if self.plan.limit else None)
        report["projector_table_rows"] = [{**row, "target_lux": p["white_lux_mean"]}
                                          for row, p in zip(light.rows, report["projectors"])]
        images = light_report.report_images(self.plan, total, combined)
        if self.maps_dir:
            report["maps"] = os.path.abspath(self.maps_dir)
            light_report.write_maps(self.maps_dir, images)
        if self.folder:
            report["report_file"] = light_report.write_report(self.folder, report, images)
        return report

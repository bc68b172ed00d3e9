"""Light Report as a job (issue 35): the Light Report button and the `report` command run this, for any rig.

No bpy. The Cycles renders of the light are the job's main-thread steps, one render a step (the UI redraws between
them, Esc cancels there); the maps' arithmetic, the report and its files (light_report.json and its colour maps,
written whole or not at all: common/atomic) are a worker's steps. A cancel before the worker's last step writes
nothing: the previous report stays as it was. In the UI it is a foreground job (blender/modal_runner,
services/background_jobs.JobSlots): the background Train pauses while it runs. Limit Look to the Dose
(services/light/dose_cap) writes the limited look's report through the same steps, on the room maps it has rendered.

The way is the light's strategy (its `strategy`, the rig's: services/ways.chosen_way): one projector's maps are in
its own frame (ProjectorReportWay, below), several projectors' over the camera's pixels, added
(services/light/light_joint.JointReportWay); the steps and the files are the same for both.
"""
from __future__ import annotations

import os
from typing import Protocol

from ....lapig_core.optics.projector_model import ProjectorModel
from . import light_report
from ..jobs import Job
from ..ways import chosen_way


class ReportLight(Protocol):
    """The scene's light from its projector, read on Blender's main thread when made (blender/light_plan_run.
    SceneLight); its renders are steps a job drives on that thread."""

    strategy: str  # state.PROJECTOR_SPACE: the maps in the projector's frame (JointSceneLight: JOINT)
    model: ProjectorModel  # the plan's projector: its native size, gamma and black level
    size: tuple[int, int]  # the report's maps: width, height
    scale: float  # the plan's lumens over the light's power as the scene has it (light adds linearly)
    target_name: str  # the object's name, for what is refused
    row: dict  # the rig's row of the projector table (target_lux: the report adds it)

    def room_steps(self, start: float, end: float):
        """Steps (progress from start to end, message), one Cycles render each, whose value is the passes of the
        projector's light and the room's at `size` (light_passes.LightPasses: maps() on any thread)."""


def report_way(light):
    """The one place the Light Report's way is chosen: by the light's strategy, which is the rig's."""
    return chosen_way(light, ProjectorReportWay, "light.light_joint:JointReportWay")


class LightReportJob(Job):
    """The light report of the scene's look (`folder`: its result; None: a white frame, nothing written into a
    result); maps_dir: the colour maps there too. The result is the report, as the `report` command prints it."""

    title = "LAPIG light report"

    def __init__(self, plan, light: ReportLight, folder: str | None, maps_dir: str | None = None):
        super().__init__()
        self.plan, self.light, self.maps_dir = plan, light, maps_dir
        self.folder = report_way(light).own_result(folder or None)

    def steps(self):
        self.plan.check()
        self.result = yield from report_steps(self, self.plan, self.light, self.folder, self.maps_dir)


def report_steps(job: Job, plan, light: ReportLight, folder: str | None, maps_dir: str | None = None, room=None,
                 span: tuple[float, float] = (0.0, 1.0)):
    """The report's steps, for `job` to `yield from`; their value is the report. room: the room maps at the
    report's size when the job has them already (one projector's dose cap), else rendered here, one render a
    step."""
    way = report_way(light)
    start, end = span
    middle = start + 0.8 * (end - start)
    rendered = None
    try:
        if room is None:
            rendered = yield from way.render_steps(light, folder, start, middle)
        return (yield from job.drive(lambda: _report_work(way, plan, light, rendered, room, folder, maps_dir,
                                                          middle), False))
    finally:
        if rendered is not None:  # a cancel before the worker read them (else gone already)
            way.discard(rendered)


def _report_work(way, plan, light, rendered, room, folder, maps_dir, progress: float):
    """On a worker thread: the maps from the renders, the report and its files; its value is the report."""
    yield progress, "the light report"
    report, maps, emitted = way.report(plan, light, rendered, folder, room)
    images = light_report.report_images(plan, maps, emitted)
    if maps_dir:
        report["maps"] = os.path.abspath(maps_dir)
    yield progress + 0.1 * (1 - progress), "writing the light report"  # a cancel until here writes nothing
    if maps_dir:
        light_report.write_maps(maps_dir, images)
    if folder:
        report["report_file"] = light_report.write_report(folder, report, images)
    return report


class ProjectorReportWay:
    """LightReportJob's way for one projector (the projector-space strategy): the maps in the projector's own
    frame, the look's light from its native frame. own_result(folder) -> the folder reported; render_steps(light,
    folder, start, end): main-thread steps whose value is the renders; report(plan, light, rendered, folder,
    room) on a worker -> (report, the maps, the look's emitted light) for the colour maps; discard(rendered)."""

    @staticmethod
    def own_result(folder):
        return folder

    @staticmethod
    def render_steps(light, folder, start, end):
        return (yield from light.room_steps(start, end))

    @staticmethod
    def report(plan, light, rendered, folder, room=None):
        maps = room if room is not None else light_report.plan_maps(rendered, light.scale, light.target_name, plan)
        emitted = light_report.look_emitted(folder, light.model, maps.white_lux.shape[1],
                                            maps.white_lux.shape[0]) if folder else None
        report = light_report.light_report(plan, maps, emitted, light.model)
        report["result"] = folder or None
        report["projector_table_row"] = {**light.row, "target_lux": float(maps.white_lux[maps.on_object].mean())}
        return report, maps, emitted

    @staticmethod
    def discard(rendered):
        rendered.discard()

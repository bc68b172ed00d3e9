"""The look limited to the light dose, as a result of its own: a copy of the result whose projector image
is the capped frame, so Export, the preview and the projector show the limited look; the free one stays.

No bpy. DoseCapJob (Limit Look to the Dose, and the `report --cap-result` command) runs it as a foreground job
like Refine: the light maps are rendered through a LightRenders (Cycles, on Blender's main thread, one render a
step), read, capped and written on a worker thread, all under the capture's folder lock; the limited look's light
report is written as Light Report writes one (services/light/light_report_job), on the room maps the cap rendered; its
cost in PSNR is measured by
projecting both frames on the rig, the device factory's device driven on the thread it needs (services/capture/projection),
against the free look's target, as Render Real Capture measures a result."""
from __future__ import annotations

import os
import shutil
from pathlib import Path
from typing import Protocol

import numpy as np

from ....lapig_core.capture.dataset import resolve_setup
from ....lapig_core.capture.staging import hold_root
from ....lapig_core.common.imageio import read_image
from ....lapig_core.common.resample import resize_image
from ....lapig_core.common.scratch import ScratchFolder
from ....lapig_core.common.steps import mapped_steps
from ....lapig_core.export.result_files import output_name, read_output_image, read_summary, write_result
from ....lapig_core.optics.projector_model import ProjectorModel
from ....lapig_core.photometry import units
from ....lapig_core.common.psnr import masked_psnr
from . import light_report
from ..export.export_result import result_frame
from ..jobs import Job
from .light_report_job import ReportLight, report_steps
from ..ports import Seams
from ..capture.projection import projection_steps
from ..ways import chosen_way

SUFFIX = "_dose_cap"
LIMITED = " | limited to the light dose"  # after the result's line: the panel shows it on a line of its own


class LightRenders(ReportLight, Protocol):
    """The scene's light from the projector's viewpoint (blender/light_plan_run.SceneLight: Cycles renders as
    steps, on Blender's main thread): room_steps() the report's maps with the room's light, and"""

    model: ProjectorModel  # the plan's projector: its native size, gamma and black level

    def native_steps(self, start: float, end: float):
        """Steps whose value is the passes of the projector's light at its native size (no room light)."""


class DoseCapJob(Job):
    """Limit the scene's result so the marked region stays within the plan's lux limit, as a new result.

    record: the new result becomes the scene's (the light, the preview and a live window show it) and its
    light report is written; measure_psnr: both frames projected on the rig for the cap's cost. Nothing is
    recorded before the new folder is complete; a cancel leaves the scene as it was."""

    title = "LAPIG limit to the dose"

    def __init__(self, seams: Seams, plan, light: LightRenders, folder: str | None = None, record: bool = True,
                 measure_psnr: bool = False):
        """folder: the result to limit (None: the scene's)."""
        super().__init__()
        self.seams, self.plan, self.light, self.folder = seams, plan, light, folder
        self.record, self.measure_psnr = record, measure_psnr

    def _inputs(self) -> tuple[str, str]:
        """(the result folder, the scene's capture or ''), checked before anything is rendered."""
        if self.plan.limit is None:
            raise ValueError("limiting the look needs a conservation category")
        state = self.seams.store.read()
        folder = self.folder or state.result_dir
        if not folder:
            raise ValueError("limiting the look needs a result: generate a look first")
        if self.measure_psnr and not state.capture_dir:
            raise ValueError("measuring the cap's cost needs the scene's capture: capture first")
        if self.measure_psnr and self.seams.devices is None:
            raise ValueError("measuring the cap's cost needs a rig to project on")
        return folder, state.capture_dir

    def steps(self):
        folder, capture = self._inputs()
        self.result = yield from cap_way(self.light)(self, folder, capture)


def cap_way(light):
    """The one place the dose cap's way is chosen, by the light's strategy (the rig's): one projector's frame is
    limited pixel by pixel (projector_cap_steps), several projectors' light by one factor (dose_cap_joint)."""
    return chosen_way(light, projector_cap_steps, "light.dose_cap_joint:joint_cap_steps")


def projector_cap_steps(job: DoseCapJob, folder: str, capture: str):
    """DoseCapJob's steps for one projector: the room's light and the projector's at its native size rendered
    (main thread), the frame capped on a worker, the cap's cost measured on the rig where asked, the limited look
    recorded with its report. Their value is what the cap did."""
    # as Generate and Refine: no capture replaces the setup (nor Train writes beside it) meanwhile
    held = hold_root(resolve_setup(capture).root, job.title) if capture else None
    light, plan = job.light, job.plan
    rendered = []  # the renders' passes: the worker reads them; a cancel before it does removes them here
    try:
        rendered.append((yield from light.room_steps(0.05, 0.35)))
        rendered.append((yield from light.native_steps(0.35, 0.55)))
        free, capped, info, new, room = yield from job.drive(
            lambda: capped_result_steps(plan, light, folder, *rendered), False)
        out = {**info, "folder": str(new)}
        if job.measure_psnr:
            devices = job.seams.devices
            out.update((yield from job.drive(
                lambda: psnr_cost_steps(devices, capture, folder, free, capped), devices.main_thread)))
    finally:
        for passes in rendered:
            passes.discard()
        if held is not None:
            held.release()
    if job.record:
        yield 0.9, "the light report of the limited look"
        yield from _record(job, str(new), room)
    return out


def _record(job: DoseCapJob, new: str, room):
    """The limited look becomes the scene's result, shown on the light (and a live window), with its report (on
    the room maps the cap rendered: written on a worker)."""
    store = job.seams.store
    summary = read_summary(new)
    store.record_result(new, (summary.get("summary_line") or summary.get("prompt") or "result") + LIMITED)
    job.seams.show(result_frame(store, new, store.export_settings().bit_depth, summary=summary))
    yield from report_steps(job, job.plan, job.light, new, room=room, span=(0.9, 1.0))


def capped_result_steps(plan, light: LightRenders, folder, room_passes, native_passes):
    """On a worker: the maps read from the renders' passes, the cap, the new result. Steps whose value is (the free
    frame, the capped frame, what the cap did, the new result's folder, the room maps)."""
    try:
        yield 0.6, "limiting the look"
        room = light_report.plan_maps(room_passes, light.scale, light.target_name, plan)
        free, capped, info = capped_look(plan, light, folder, room, native_passes)
        yield 0.7, "writing the limited look"
        return free, capped, info, write_capped_result(folder, capped, info), room
    finally:
        room_passes.discard()
        native_passes.discard()


def capped_look(plan, light: LightRenders, folder, room, native_passes) -> tuple[np.ndarray, np.ndarray, dict]:
    """(the result's native frame, it limited to the plan's lux on the marked region: light_report.capped_frame,
    what the cap did with the brightest lux it predicts there), from the room maps and the native render."""
    model = light.model
    native = light_report.plan_maps(native_passes, light.scale, light.target_name, plan, check=False)
    frame = light_report.native_frame(folder, model)
    ambient = resize_image(np.repeat(room.ambient_lux[..., None], 3, -1).astype(np.float32), model.width,
                           model.height)[..., 0]
    region = native.region & native.on_object
    capped, info = light_report.capped_frame(plan, frame, native.white_lux, ambient, region, model)
    predicted = native.white_lux * (model.emitted(capped) @ units.LUMA) + ambient
    return frame, capped, {**info, "predicted_max_lux": round(float(predicted[region].max()), 2)}


def write_capped_result(folder, capped: np.ndarray, cap_info: dict) -> Path:
    """<folder>_dose_cap (or _2, ...): the result with its output projector image replaced by `capped`
    (native H x W x 3 in [0, 1]), written whole or not at all."""
    folder = Path(folder)
    name = output_name(folder, "projector")
    h, w = read_image(folder / f"{name}.png").shape[:2]
    if capped.shape[:2] != (h, w):
        raise ValueError(f"the result's projector image is {w}x{h}, not the projector's native frame "
                         f"{capped.shape[1]}x{capped.shape[0]}: generate it at the native size (Output size 0) "
                         "to limit it")
    summary = read_summary(folder)
    summary["dose_cap"] = {**cap_info, "capped_from": str(folder)}
    scratch = ScratchFolder(folder.parent, ".writing_")
    try:
        for entry in folder.iterdir():
            if entry.is_file() and entry.name not in ("result.json", light_report.REPORT_FILE, f"{name}.png",
                                                      "comparison.png"):
                shutil.copy2(entry, scratch.path / entry.name)
        write_result(scratch.path, {name: np.clip(capped, 0, 1)}, summary)
    except BaseException:
        scratch.remove()
        raise
    return scratch.move_to_new_folder(folder.name + SUFFIX)


def psnr_cost_steps(devices, capture_dir, folder, frame: np.ndarray, capped: np.ndarray):
    """Steps that project both frames on the rig; their value is each one's PSNR against the free look's target
    (dB) and the difference."""
    projected = projection_steps(devices, os.fspath(capture_dir), [frame, capped], chunk=2)
    captured, _ = yield from mapped_steps(projected, lambda done: (
        0.7 + 0.2 * done, "projecting the free and the limited look on the rig"))
    target = resize_image(read_output_image(folder, "target"), captured.shape[2], captured.shape[1])
    whole = np.ones(target.shape[:2], bool)  # numpy PSNR over the frame: Light Report needs no torch
    free, limited = (masked_psnr(c, target, whole) for c in captured)
    return {"psnr_free_db": round(free, 3), "psnr_capped_db": round(limited, 3),
            "psnr_cost_db": round(free - limited, 3)}

"""Render Real Capture: the result's projector images shown on the rig and captured, through the device factory
every job uses. The way is chosen once, by the rig: one projector's captures are registered into its working
frame (ProjectorRenderWay, below), several projectors' images are shown at once and captured in camera space
(services/render/render_joint); the job's steps are the same for both, one image a step. result.json is written last.
"""
from __future__ import annotations

import os

from ....lapig_core.capture.settings import CaptureError
from ....lapig_core.common import metrics
from ....lapig_core.common.resample import resize_image
from ....lapig_core.common.steps import mapped_steps
from ....lapig_core.export.result_files import output_name, read_output_image, read_summary, write_result
from ..panel import panel_state
from ..jobs import Job
from ..pipeline_errors import PipelineError, current_capture, hold_capture
from ..ports import Seams
from ..capture.projection import projection_steps, register_at
from ..ways import chosen_way


class RenderResultJob(Job):
    """Project the result's projector images on the rig and capture them: the 'real capture'."""

    title = "LAPIG render result"

    def __init__(self, seams: Seams):
        super().__init__()
        self.seams = seams

    def steps(self):
        way = render_way(self.seams)
        folder, capture, summary, sets = way.inputs(self.seams)  # sets: {the capture's name: the image(s) shown}
        yield way.projecting
        devices, rig_settings = self.seams.devices, way.rig_settings(self.seams.store)  # the store reads bpy: here
        held = hold_capture(capture, self.title) if way.holds_capture else None

        def render():  # the fraction done of each way's rounds, as the progress bar's step
            return mapped_steps(way.rounds(devices, capture, list(sets.values()), rig_settings),
                                lambda done: (0.1 + 0.8 * done, f"captured {round(done * len(sets))}/{len(sets)}"))

        try:
            captured = yield from self.drive(render, devices.main_thread, holding=held)
        except CaptureError as exc:
            raise PipelineError(str(exc)) from None
        yield 0.9, way.comparing
        self.result = way.record(self.seams, folder, capture, summary, dict(zip(sets, captured)), rig_settings)


def render_way(seams):
    """The one place Render's way is chosen: several projectors' images are shown at once, captured in camera
    space."""
    return chosen_way(seams.store.read().rig, ProjectorRenderWay, "render.render_joint:JointRenderWay")()


class ProjectorRenderWay:
    """RenderResultJob's steps for one projector: inputs(seams) -> (result folder, capture, summary, image sets)
    and rig_settings(store) on the main thread; rounds(devices, capture, images, rig_settings): a generator of the
    fraction done whose value is one capture per image; record(seams, folder, capture, summary, {name: capture},
    rig_settings) writes the figures and the captures and returns the summary."""

    projecting = 0.1, "projecting the result on the rig"
    comparing = "comparing with the targets"
    holds_capture = False

    def inputs(self, seams):
        state = seams.store.read()
        blocker = panel_state.single_result_blocker(state)
        if blocker:
            raise PipelineError(blocker)
        folder = state.result_dir  # its images with and without PSA where made, native where made
        sets = {"rendered" + suffix: read_output_image(folder, "projector" + suffix) for suffix in ("", "_nopsa")
                if os.path.isfile(os.path.join(folder, f"projector{suffix}.png"))}
        return folder, current_capture(state), read_summary(folder), sets

    def rig_settings(self, store):
        return store.export_settings().bit_depth  # the frames are the pixels of the files Export writes

    def rounds(self, devices, capture, images, bit_depth):
        registered, raw = yield from projection_steps(devices, capture, images, chunk=1, bit_depth=bit_depth)
        return list(zip(registered, raw))

    def record(self, seams, folder, capture, summary, captured, bit_depth):
        rendered = {}
        for name, (cap, _) in captured.items():
            suffix = name[len("rendered"):]
            rendered[name] = cap
            # the look of the image that was projected (the native one where made), at the working frame
            target = resize_image(read_output_image(folder, "target" + suffix), cap.shape[1], cap.shape[0])
            summary["metrics"]["rendered_psnr" + suffix] = metrics.psnr(cap, target)
            summary["metrics"]["rendered_ssim" + suffix] = metrics.ssim(cap, target)
        if output_name(folder, "target") != "target":  # and at the output size, on the object
            target = read_output_image(folder, "target")
            cap, valid = register_at(capture, next(iter(captured.values()))[1], target.shape[1], target.shape[0])
            rendered["rendered_native"] = cap
            summary["metrics"]["rendered_psnr_native"] = metrics.masked_psnr(cap, target, valid)
            summary["metrics"]["rendered_ssim_native"] = metrics.ssim(cap, target)
        summary["rendered_bit_depth"] = bit_depth
        write_result(folder, rendered, summary)
        return summary

"""Refine on the rig: the scene's result projected, captured and corrected until the captures stop
improving (lapig_core.refine), through the device factory every job uses (Cycles, a real or a simulated
rig alike). The way is chosen once, by the rig: one projector is refined in projector space (ProjectorRefineWay,
below: the paper's frame), several together in camera space (services/refine/refine_joint: one capture of all of them
per round, every image corrected together); the job's steps are the same for both.

Nothing is written until the loop has finished: the refined projector images (working frame and native)
go into the result folder under names of their own, then result.json, written last and whole, names them
(result_files.output_name), so a cancel, a failure or a kill leaves the result as it was.
"""
from __future__ import annotations

import cv2
import numpy as np

from ....lapig_core.capture.dataset import DatasetError, load_capture_set, setup_dir_of
from ....lapig_core.capture.settings import CaptureError
from ....lapig_core.export.result_files import (NATIVE, read_output_image, read_result_image, refined_images, write_result)
from ....lapig_core.photometric.classical import ClassicalModel
from ....lapig_core.photometric.first_look import load_first_look
from ....lapig_core.photometric.targets import reachable_mask
from ....lapig_core.refine.check import RegistrationCheckError
from ....lapig_core.refine.loop import Refinement, RefineError, RefineSettings
from ..panel import panel_state
from ..export.export_result import result_frame
from ..jobs import Job
from ..limits import LIMITS
from ..pipeline_errors import PipelineError, current_capture, hold_capture, summary_made_on
from ..ports import Seams
from ..capture.projection import projection_session
from .refine_lines import record_refinement, refine_line
from ..ways import chosen_way

REFINED = "projector_refined"


def classical_of(capture: str) -> ClassicalModel:
    """The setup's classical model: the capture's first look (Train reuses that same fit), else the one saved
    with Train's choice (a capture from before first looks), else fitted on the capture's pairs now."""
    meta_only = load_capture_set(capture, pairs=False)
    look = load_first_look(setup_dir_of(meta_only), meta_only.meta.get("fingerprint"))
    if look is not None:
        return look.classical
    try:  # Train's choice needs torch; refinement itself is numpy only
        from ....lapig_core.photometric import choice as compensator_choice
    except ImportError:
        compensator_choice = None
    saved = compensator_choice and compensator_choice.load_choice(setup_dir_of(meta_only) / "models")
    if saved:
        return saved[1]
    cs = load_capture_set(capture)
    if len(cs.prj_train) < 4:
        raise PipelineError("refinement needs the capture's classical model: train the models first")
    return ClassicalModel.fit(cs.prj_train, cs.cam_train)


class RefineResultJob(Job):
    """Closed-loop refinement of the scene's result on its rig; Esc (cancel) keeps the result as it was."""

    title = "LAPIG refine on the rig"

    def __init__(self, seams: Seams, iterations: int, settings: RefineSettings | None = None):
        super().__init__()
        problem = LIMITS["refine_iterations"].problem(iterations)
        if problem or iterations < 1:
            raise PipelineError(problem or "refinement needs at least 1 step")
        self.seams = seams
        self.settings = settings or RefineSettings(iterations=iterations)

    def steps(self):
        way = refine_way(self.seams)
        folder, capture = way.inputs(self.seams)
        # reading the images and fitting the model take seconds: a worker step, since with Cycles this
        # generator runs on Blender's main thread
        summary, refinement = yield from self.drive(lambda: way.prepared(folder, capture, self.settings), False)
        devices, rig_settings = self.seams.devices, way.rig_settings(self.seams.store)  # the store reads bpy: here
        held = hold_capture(capture, self.title)  # no capture may replace the setup while the rig refines
        try:  # the lock goes once the rig is closed, on the camera's thread after a cancel
            yield from self.drive(lambda: way.rounds(devices, capture, refinement, rig_settings), devices.main_thread,
                                  holding=held)
        except (CaptureError, RegistrationCheckError, RefineError) as exc:
            raise PipelineError(str(exc)) from None
        written = yield from self.drive(lambda: way.write(folder, summary, refinement), False)
        self.result = way.record(self.seams, folder, *written)


def refine_way(seams):
    """The one place the refinement's way is chosen: several projectors are refined together in camera space."""
    return chosen_way(seams.store.read().rig, ProjectorRefineWay, "refine.refine_joint:JointRefineWay")


class ProjectorRefineWay:
    """RefineResultJob's steps for one projector, in projector space: inputs(seams) -> (result folder, capture)
    on the main thread; prepared(folder, capture, settings), rounds(seams, capture, refinement) and
    rounds(devices, capture, refinement, rig_settings(store)) and write(folder, summary, refinement) ->
    (summary, record, image) are step generators; record(seams, folder, summary, record, image) puts the
    refined result into the scene on the main thread."""

    @staticmethod
    def inputs(seams):
        """The result folder and the capture, from the scene (the main thread: the store reads bpy)."""
        state = seams.store.read()
        blocker = panel_state.single_result_blocker(state)
        if blocker:
            raise PipelineError(blocker)
        if seams.devices is None:
            raise PipelineError("refinement needs a rig to project on and capture with")
        return state.result_dir, current_capture(state)

    @staticmethod
    def prepared(folder, capture, settings):
        return prepared_refinement(folder, capture, settings)

    @staticmethod
    def rig_settings(store):
        return store.export_settings().bit_depth  # the images are shown at the depth Export writes

    @staticmethod
    def rounds(devices, capture, refinement, bit_depth):
        return refine_rounds(devices, capture, refinement, bit_depth)

    @staticmethod
    def write(folder, summary, refinement):
        return write_refined(folder, summary, refinement)

    @staticmethod
    def record(seams, folder, summary, record, image):
        """The refined result into the scene (the main thread): its line, the light, the preview and the live window."""
        store = seams.store
        store.record_result(folder, summary["summary_line"], (summary.get("surface_reach") or {}).get("message", ""))
        # the preview and the live sinks show the refined image, as Export will write it
        seams.show(result_frame(store, folder, store.export_settings().bit_depth, image=image, summary=summary))
        return {"folder": folder, "refine": record, "line": refine_line(record).lstrip("; ")}


def prepared_refinement(folder: str, capture: str, settings: RefineSettings):
    """Steps whose value is (the result's summary, the Refinement of its projector image against its target on
    the setup's classical model); the native output where the result has one."""
    yield 0.02, "reading the result and the setup's model"
    summary = summary_made_on(folder, capture)
    try:
        cs = load_capture_set(capture, pairs=False)
    except DatasetError as exc:
        raise PipelineError(str(exc)) from None
    model = classical_of(capture)
    valid = reachable_mask(cs.cam_black, cs.cam_white)
    if cs.projector_valid is not None:
        valid &= cs.projector_valid
    target, start, native = _images_to_refine(folder, summary, cs.cam_black.shape[:2])
    try:
        return summary, Refinement(model, target, cs.cam_black, cs.cam_white, valid, start, settings,
                                   native_start=native)
    except RefineError as exc:
        raise PipelineError(str(exc)) from None


def _images_to_refine(folder: str, summary: dict, working_shape) -> tuple:
    """(target, start, native) of the result: its native output where it has one (what the projector shows),
    against its native look averaged onto the working frame; else its working-frame image and PSA's target."""
    names = refined_images(folder, summary)
    native_name = names.get("projector") if names.get("projector", "").endswith(NATIVE) else None
    native_name = native_name or ("projector" + NATIVE if _has(folder, "projector" + NATIVE) else None)
    if native_name and _has(folder, "target" + NATIVE):
        h, w = working_shape  # the working frame the captures are registered at
        target = cv2.resize(read_result_image(folder, "target" + NATIVE), (w, h), interpolation=cv2.INTER_AREA)
        return target, None, read_result_image(folder, native_name)
    start = read_result_image(folder, names.get("projector_working", "projector"))
    return read_result_image(folder, "target"), start, None


def write_refined(folder: str, summary: dict, refinement: Refinement):
    """Steps that write the refined images, then result.json naming them; their value is (the summary written,
    the refinement's record, the projector image as stored)."""
    yield 0.96, "writing the refined result"
    record = refinement.record.to_dict()
    record["frame"] = "native" if refinement.native is not None else "working"  # which image was captured
    images = {REFINED: refinement.working_images[0]}
    chosen = {"projector_working": REFINED, "projector": REFINED}
    if refinement.native is not None:
        images[REFINED + NATIVE] = refinement.images[0]
        chosen["projector"] = REFINED + NATIVE
    record["images"] = chosen
    record_refinement(summary, record)
    write_result(folder, images, summary)  # the images first, result.json last: it names them
    return summary, record, read_output_image(folder, "projector")


def refine_rounds(devices, capture: str, refinement: Refinement, bit_depth: int = 8):
    """A generator of (progress, message) that runs `refinement` on the rig of `capture` (opened once, closed on
    exit, cancel included); its record says what it did."""
    cap = refinement.settings.iterations
    with projection_session(devices, capture, bit_depth=bit_depth) as rig:
        while not refinement.done:
            images, repeats = refinement.request()
            rounds = [rig.capture(images)[0] for _ in range(repeats)]
            refinement.take(np.stack(rounds, axis=1).reshape((-1,) + rounds[0].shape[1:]))
            rec = refinement.record
            yield 0.05 + 0.9 * min(rec.iterations, cap) / (cap + 1), \
                f"refining on the rig: step {rec.iterations}/{cap}, last capture {rec.history[-1]:.1f} dB " \
                f"(noise floor {rec.noise_floor_psnr:.1f})"


def _has(folder, name) -> bool:
    import os

    return os.path.isfile(os.path.join(folder, name + ".png"))

"""Train: fine-tune the networks on the capture, then choose the compensator by measurement on the rig.

The networks are one projector's (the projector-space strategy, services/state.Rig.strategy); a rig of several
has its joint model fitted at the capture, so there is nothing to train. The torch work runs on a worker thread
(jobs.WorkerJob); the rendered choice's steps on the thread the rig needs.
"""
from __future__ import annotations

import os
import time

import numpy as np

from ....lapig_core.common import compute_device
from ....lapig_core.capture.dataset import load_capture_set, read_setup_json, resolve_setup, setup_dir_of
from ....lapig_core.photometric import choice as compensator_choice
from ....lapig_core.pipeline import train_models
from ....lapig_core.photometric import first_look
from ..panel import panel_state
from ..capture.capture_job import CaptureError
from ..jobs import WorkerJob
from ..pipeline_errors import PipelineError, capture_record, current_capture, hold_capture
from ..ports import Seams
from ..capture.projection import project_and_capture, projection_steps
from ..state import JOINT


def capture_first_look(folder: str):
    """The capture's first look (photometric/first_look), or None where Capture fitted none for it."""
    meta = read_setup_json(resolve_setup(folder).setup_json)
    return first_look.load_first_look(setup_dir_of(resolve_setup(folder)), meta.get("fingerprint"))


def _setup_stamp(folder: str) -> tuple:
    """setup.json's identity on disk: a new capture swaps in a new file."""
    st = os.stat(resolve_setup(folder).setup_json)
    return st.st_ino, st.st_mtime_ns, st.st_size


def _why_not_measured(cs, verification, devices) -> str:
    """Why the rig cannot measure the choice, for the models line: a data set this rig did not capture
    (imported, or made on another rig); '' otherwise."""
    if verification is None or devices is None:
        return ""  # nothing to measure (the capture's test count), or no rig: PCNet's choice, as its line says
    if cs.meta.get("fingerprint") != devices.rig_identity().key():
        made_on = cs.meta.get("device") or "another rig"
        return f"not measured on the rig: the capture was made on '{made_on}', not on this rig"
    return ""


def device_choice(store, explicit: str | None) -> str:
    """'auto' or 'cpu': the command's, else the store's (the preference; read in prepare(), on the main thread)."""
    choice = explicit or store.compute_device()
    if choice not in compute_device.CHOICES:
        raise PipelineError(f"unknown device '{choice}': use {' or '.join(compute_device.CHOICES)}")
    return choice


class TrainModelsJob(WorkerJob):
    """Fine-tune the networks (worker thread), then choose the compensator by measurement: the rig renders
    both compensations of the held-back images, as it rendered the capture (main thread, bpy)."""

    title = "LAPIG training"
    TRAIN_SHARE = 0.9  # of the progress bar; the rest is the renders of the choice
    rig_in_use = None  # a Train in the background: a callable saying why it may not open the rig now ('' if it may)
    # a Train in the background: a main-thread device (Cycles' studio, a scene of its own that changes the
    # projector's image) is opened and closed within each render's step, so the artist's undo, save or edit
    # between two steps never meets it
    device_per_render = False
    choice_skipped = ""  # why the rig did not measure the choice, for the models line

    def __init__(self, seams: Seams, iterations: int | None = None, capture: str | None = None,
                 device: str | None = None):
        """iterations: fine-tuning iterations per network (None: the standard recipe); capture: a capture
        folder named explicitly (None: the scene's), recorded as the scene's when the models are; device:
        'auto' or 'cpu' (None: the store's, i.e. the add-on's preference)."""
        super().__init__()
        self.seams, self.iterations, self.capture, self.device = seams, iterations, capture, device

    def prepare(self):
        state = self.seams.store.read()
        if state.rig.strategy == JOINT:  # their joint model is fitted at the capture: no networks for them
            raise PipelineError(panel_state.train_blocker(state))
        folder = current_capture(state, self.capture)
        self._stamp = _setup_stamp(folder)  # what a pause checks on resume: the same capture
        self._device_choice = device_choice(self.seams.store, self.device)
        return folder

    def hold(self, folder):
        return hold_capture(folder, self.title)

    def work(self, folder, report, cancel_event):
        cs = load_capture_set(folder)
        had_first_look = capture_first_look(folder) is not None
        device = compute_device.resolve(self._device_choice)
        trained = train_models(cs, on_progress=report, cancel_event=cancel_event, iterations=self.iterations,
                               device=device)
        # both compensations of the held-back images, here on the worker: CompenNeSt's forward pass would
        # otherwise hold Blender's main thread, where the rendered choice's steps run with Cycles
        phases = trained["phases"]
        with phases.timing("verification"):
            verification = compensator_choice.verification(cs, trained["CompenNeSt"], trained["classical"])
        return {"fingerprint": cs.meta.get("fingerprint", ""), "seconds": trained["seconds"], "folder": folder,
                "phases": phases,
                "choice": trained["choice"].line(), "capture_set": cs, "trained": trained,
                "verification": verification, "had_first_look": had_first_look, "device": trained["device"],
                "trained_on": compute_device.short_name(device), "threads": trained.get("threads", {})}

    def finish(self, output):
        store = self.seams.store
        if self.capture:  # the named capture becomes the scene's, so the models belong to it
            store.record_capture(output["folder"], *capture_record(output["folder"]))
        # PCNet's choice, saved with the models: it stands if the renders below cannot run or are cancelled
        store.record_models(output["fingerprint"], self._models_line(output, output["trained"]["choice"]))
        return output

    @property
    def in_use_note(self) -> str:
        """What a Generate uses meanwhile, for the panel's line on a Train in the background."""
        if self.result is None:  # the networks are not saved yet
            return "first look in use until it finishes"
        return "networks saved; choosing their compensator on the rig"

    @staticmethod
    def _models_line(out, chosen) -> str:
        """The models step's line: how long, the choice, and what it means for the capture's first look."""
        on = f" on {out['trained_on']}" if out.get("trained_on") else ""
        line = f"Fine-tuned in {out['seconds']:.0f} s{on}; {out['choice']}"
        note = first_look.after_train_note(chosen) if out.get("had_first_look") else ""
        return f"{line}; {note}" if note else line

    def steps(self):
        for progress, message in super().steps():
            yield self.TRAIN_SHARE * progress, ("models trained" if progress >= 1.0 else message)
        out = self.result
        t0 = time.perf_counter()
        chosen = yield from self._render_choice(out["capture_set"], out["trained"], out["folder"], out["verification"])
        out["seconds"] += time.perf_counter() - t0
        out["phases"].add("rendered_choice", time.perf_counter() - t0)
        if chosen is not None:
            out["choice"] = chosen.line()
            self.seams.store.record_models(out["fingerprint"], self._models_line(out, chosen))
        elif self.choice_skipped:
            out["choice"] = f"{out['choice']} ({self.choice_skipped})"
            self.seams.store.record_models(out["fingerprint"], self._models_line(out, out["trained"]["choice"]))
        # the result goes to the operator and the CLI: not the capture's arrays nor the networks
        self.result = {k: v for k, v in out.items() if k not in ("capture_set", "trained", "verification")}

    def _render_choice(self, cs, trained, folder, v):
        """Render both compensations of the held-back images (``v``, computed on the worker) and save the better
        one as the setup's choice; None when there are no held-back images to measure on. A pause (a job in the background) stops
        between renders: the device closes and the lock goes, and the renders go on from there on resume."""
        devices = self.seams.devices
        self.choice_skipped = _why_not_measured(cs, v, devices)
        if v is None or devices is None or self.choice_skipped:  # PCNet's choice stands
            return None
        images, share = v.images, self.TRAIN_SHARE
        count, captured = len(images), []

        def measure(first):
            if self.device_per_render and devices.main_thread:  # opened, rendered and closed in this one step
                one = project_and_capture(devices, folder, images[first:first + 1], seed=first, chunk=1)[0]
                done = (first + 1) / count
                yield share + (1 - share) * 0.99 * done, \
                    f"measuring both compensations on the rig: {first + 1}/{count} captured"
                return list(one)
            steps = projection_steps(devices, folder, images[first:], chunk=1, stop=lambda: self.pause_requested)
            while True:
                try:
                    part = next(steps)
                except StopIteration as end:
                    return list(end.value[0])
                done = (first + part * (count - first)) / count
                yield share + (1 - share) * 0.99 * done, \
                    f"measuring both compensations on the rig: {round(done * count)}/{count} captured"

        try:
            while len(captured) < count:
                progress = share + (1 - share) * 0.99 * len(captured) / count
                yield from self.pause_point(progress)
                devices = self.seams.devices  # as the job's owner has it now (a background job's: after an undo)
                in_use = self.rig_in_use() if self.rig_in_use is not None else ""
                if in_use:  # the artist's live window or camera view: the rig is theirs until closed
                    time.sleep(self.poll_timeout)
                    yield progress, f"waiting for the rig: {in_use}"
                    continue
                # no capture may replace the models while this runs
                held = yield from self._hold_when_free(folder, progress)
                if self.pause_requested:  # asked while the lock was taken: pause before opening the device
                    held.release()
                    continue
                first = len(captured)
                # the lock goes once the device is closed, on the camera's thread after a cancel
                captured += yield from self.drive(lambda: measure(first), devices.main_thread, holding=held)
            chosen = compensator_choice.choose_by_captures(v, np.stack(captured).astype(np.float32),
                                                           rig=devices.rig_identity().name)
            compensator_choice.save_choice(setup_dir_of(cs) / "models", chosen, trained["classical"])
        except CaptureError as exc:
            raise PipelineError(f"{exc} (the models are trained; {trained['choice'].line()})") from None
        return chosen

    def _hold_when_free(self, folder, progress):
        """The capture's lock, once the job that paused this one has let go of it; then the capture checked to
        be the one trained on (WorkerJob.retake)."""
        retake = self.retake(folder)
        while True:
            try:
                next(retake)
            except StopIteration as done:
                return done.value
            time.sleep(self.poll_timeout)
            yield progress, "waiting for the capture's folder"

    def resumed(self, folder):
        if _setup_stamp(folder) != self._stamp:
            raise PipelineError("the capture was replaced while the training was paused: train again")

# SPDX-License-Identifier: GPL-3.0-or-later
"""The fast path (issue 53, item 4): as the prompt is typed, the one-step model's look on the surface, compensated by
the capture's models and shown by the sinks (the projector light); Generate then runs the full PSA.

    preview = PromptPreview(start_job, clock=time.monotonic)
    preview.typed("a stained glass")   # each change of the prompt (Blender: the prompt property's update)
    preview.tick()                     # often (Blender: a timer): starts, steps and ends the preview jobs

A preview starts DELAY_S after the last change; a newer prompt cancels the preview under way (its image is never
shown) and waits its own DELAY_S; a new job starts only once the old one's worker has let go (one model call at a
time). Only where the one-step model is ready and the look is a diffusion look (fast_path_problem): otherwise the
prompt's update does nothing and the user sees no change. No bpy here and no torch at import: the clock is passed in
(a fake one in the tests), blender/prompt_preview is the thin Blender side.
"""
from __future__ import annotations

import functools
import time
from dataclasses import dataclass
from typing import Callable

from ..jobs import WorkerJob
from ..panel.panel_state import fast_path_problem  # noqa: F401 (the Blender side asks it here)

DELAY_S = 0.5  # after the last keystroke


@dataclass(frozen=True)
class PreviewRequest:
    prompt: str
    model: str  # the one-step model's folder
    seed: int = 0


class Debounce:
    """The prompt whose wait is over: typed() restarts the wait, due() hands the prompt over once."""

    def __init__(self, delay_s: float = DELAY_S, clock: Callable[[], float] = time.monotonic):
        self.delay_s, self.clock = float(delay_s), clock
        self.pending: str | None = None
        self._due_at = 0.0

    def typed(self, prompt: str) -> None:
        self.pending = prompt
        self._due_at = self.clock() + self.delay_s

    def due(self) -> str | None:
        if self.pending is None or self.clock() < self._due_at:
            return None
        prompt, self.pending = self.pending, None
        return prompt

    def clear(self) -> None:
        self.pending = None


class PromptPreview:
    """The previews of one session: start_job(prompt) makes a job (a WorkerJob, not started); tick() runs them."""

    def __init__(self, start_job: Callable[[str], WorkerJob], delay_s: float = DELAY_S,
                 clock: Callable[[], float] = time.monotonic):
        self.start_job = start_job
        self.debounce = Debounce(delay_s, clock)
        self.job: WorkerJob | None = None
        self.shown: list[str] = []  # the prompts whose preview was shown, in order (the panel's last one)
        self.cancelled = 0  # previews overtaken by a newer prompt
        self.said = ""  # the last preview's one line where it failed

    def typed(self, prompt: str) -> None:
        """The prompt changed: the preview under way is cancelled and a new one waits DELAY_S."""
        if self.job is not None and not self.job.finished:
            self.job.cancel()  # its image is never shown (finish() does not run)
            self.cancelled += 1
        self.debounce.typed(prompt)

    def stop(self) -> None:
        """Generate (the full PSA run) begins: no preview may land on its result."""
        self.debounce.clear()
        if self.job is not None and not self.job.finished:
            self.job.cancel()
            self.cancelled += 1

    @property
    def busy(self) -> bool:
        """Something to do: a wait under way, a job running, or a cancelled job's worker still finishing."""
        return self.debounce.pending is not None or (self.job is not None and (not self.job.finished
                                                                               or _worker_alive(self.job)))

    def tick(self) -> bool:
        """One step: the running job stepped (ended: shown or failed), a due prompt started. Returns busy."""
        job = self.job
        if job is not None and not job.finished:
            job.step()
            if job.finished:
                if job.state == "DONE":
                    self.shown.append(job.request.prompt)
                    self.said = ""
                elif job.state == "FAILED":
                    self.said = job.message
        if self.job is None or (self.job.finished and not _worker_alive(self.job)):
            prompt = self.debounce.due()
            if prompt is not None:
                self.job = self.start_job(prompt)
                self.job.step()  # prepare() and the worker started
        return self.busy


def _worker_alive(job) -> bool:
    thread = getattr(job, "_thread", None)
    return thread is not None and thread.is_alive()


@functools.lru_cache(maxsize=1)
def _surface_and_models(folder: str, stamp: tuple, device: str):
    """The capture's white-lit surface, footprint and models, loaded once per capture (a preview per keystroke must
    not read checkpoints each time)."""
    from ....lapig_core.capture.dataset import load_capture_set
    from ....lapig_core.common import compute_device
    from ....lapig_core.photometric.training_data import SurfaceTensors
    from ....lapig_core.pipeline import first_look_models, object_footprint, saved_models_problem, surface_models
    from ..pipeline_errors import PipelineError
    from ..train.train_job import capture_first_look

    dev = compute_device.resolve(device)
    problem, saved = saved_models_problem(folder)
    if problem is None:
        cs = load_capture_set(folder, pairs=False)
        models = surface_models(cs, train_if_missing=False, saved=saved, device=dev)
    else:
        look = capture_first_look(folder)
        if look is None:
            raise PipelineError("no models for this capture yet: Generate once (or Train) before the preview")
        cs = load_capture_set(folder, pairs=False)
        models = first_look_models(cs, look.classical, device=dev)
    footprint = object_footprint(cs)
    return SurfaceTensors.from_capture_set(cs).i_max.to(dev), footprint, models


class PromptPreviewJob(WorkerJob):
    """One preview: the one-step look of the white-lit surface, its compensation (no PSA), shown by the sinks; no
    result folder is written."""

    title = "LAPIG preview"

    def __init__(self, seams, request: PreviewRequest):
        super().__init__()
        self.seams, self.request = seams, request

    def prepare(self):
        from ..pipeline_errors import current_capture
        from ..train.train_job import _setup_stamp, device_choice

        store = self.seams.store
        folder = current_capture(store.read())
        return {"capture": folder, "stamp": _setup_stamp(folder), "device": device_choice(store, None),
                "bit_depth": store.export_settings().bit_depth}

    def work(self, job, report, cancel_event):
        import torch

        from ....lapig_core.lgst import get_backend
        from ....lapig_core.pipeline import as_image
        from ....lapig_core.psa.adaptation import psa_losses

        surface, footprint, models = _surface_and_models(job["capture"], job["stamp"], job["device"])
        report(0.2, "the one-step preview")
        look = get_backend("one-step", model=self.request.model, device=surface.device)
        target = look.stylize(surface, self.request.prompt, seed=self.request.seed)
        report(0.8, "its compensation")
        with torch.no_grad():
            image = psa_losses(target, models)["comp"]
        if footprint is not None:  # black off the object, as Generate's image
            image = image * torch.as_tensor(footprint, dtype=image.dtype, device=image.device)[None, None]
        return as_image(image), job["bit_depth"]

    def finish(self, output):
        from ..ports import ProjectorFrame

        image, bit_depth = output
        model = self.seams.store.projector_model()
        frame = ProjectorFrame(image, model.width, model.height, bit_depth, summary={"preview": self.request.prompt})
        self.seams.show(frame)
        return output

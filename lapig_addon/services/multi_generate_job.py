"""Generate for a rig of several projectors: the look on the object, jointly compensated (issue 36).

As GenerateJob for one projector: prepare() checks the request and the capture on the main thread, the work
runs on a worker thread under the capture's lock, finish() records the result in the scene. The capture must
be one of several projectors made with the rig as it is now; its joint model (fitted at the capture) is
used, or fitted here where the capture has none. The result folder holds one image per projector
(lapig_core/multi/result_files), and each image goes to the sinks that take several projectors (Blender's
lights). With the request's PSA on (the default) the look adapts to the projectors' joint reach first
(lapig_core/multi/joint_psa) and the folder keeps the look without PSA beside it.
"""
from __future__ import annotations

import datetime
import os

import numpy as np

from ...lapig_core.capture.dataset import DatasetError, read_setup_json, resolve_setup
from ...lapig_core.capture.staging import hold_root
from ...lapig_core.export.result_files import folder_name
from ...lapig_core.multi.capture_set import FIRST_LOOK, MODELS, is_multi
from . import panel_state
from .jobs import WorkerJob
from .pipeline_jobs import camera_look_geometry
from .ports import Seams
from .state import GenerateRequest


class MultiPipelineError(ValueError):
    """A step of several projectors that cannot run yet; the message says what to do first."""


def multi_capture(state, explicit: str | None = None) -> str:
    """The capture of several projectors to work on: `explicit` (--capture) or the scene's, checked to be one
    of several projectors made with this rig's projectors as they are now."""
    if explicit:
        blocker = panel_state.rig_blocker(state.rig)
        folder = explicit
    else:
        blocker = panel_state.capture_blocker(state)
        folder = state.capture_dir
    if blocker:
        raise MultiPipelineError(blocker)
    try:
        meta = read_setup_json(resolve_setup(folder).setup_json)
    except (DatasetError, OSError) as exc:
        raise MultiPipelineError(f"the capture {folder}: {exc}") from None
    if not is_multi(folder):
        raise MultiPipelineError(f"the capture is of one projector; the rig has {state.rig.projector_count}: capture "
                                 f"again")
    made_by = meta.get("fingerprint") or ""
    if made_by and state.rig.fingerprint and made_by != state.rig.fingerprint:
        raise MultiPipelineError(f"{folder} was captured with the projectors as they were then; the rig changed "
                                 f"since: capture again")
    return str(folder)


class MultiGenerateJob(WorkerJob):
    """Prompt -> the look in camera space -> each projector's image by the joint compensation."""

    title = "LAPIG generate"

    def __init__(self, seams: Seams, request: GenerateRequest, result_root=None, capture: str | None = None,
                 working_size: int | None = None):
        """working_size: the long side LGST works at (None: the scene's Working size)."""
        super().__init__()
        self.seams, self.request, self.result_root, self.capture = seams, request, result_root, capture
        self.working_size = working_size

    def prepare(self):
        from ...lapig_core.lgst import backend_class
        from ...lapig_core.lgst.prompt_mapping import validate_prompt

        r, store = self.request, self.seams.store
        state = store.read()
        folder = multi_capture(state, self.capture)
        mix = r.mix.strip()
        style_only = bool(r.style_images) and not r.prompt.strip()
        prompt, notes = validate_prompt(r.prompt) if not (mix or style_only) else (r.prompt.strip(), [])
        problem = r.problem()
        if problem:
            raise MultiPipelineError(problem)
        backend = r.lgst_backend()
        backend_class(backend)  # an unknown name is refused now
        if r.output_size:
            notes.append("several projectors: each image is at its projector's native size (Output size applies to "
                         "one projector)")
        if self.working_size is None:
            self.working_size = store.capture_settings().working_size
        options = r.backend_options()
        geometry = camera_look_geometry(store, backend, mix, prompt, self.working_size)  # main thread: ray casts
        if geometry is not None:
            options["geometry"] = geometry
        return {"capture": folder, "prompt": prompt, "notes": notes, "backend": backend,
                "backend_options": options, "mix": mix or None, "seed": r.seed,
                "psa": bool(r.psa), "adaptation": r.adaptation,
                "results": self.result_root or os.path.join(store.data_root(), "results"),
                "name": folder_name(prompt or mix or "style", datetime.datetime.now())}

    def hold(self, job):
        return hold_root(resolve_setup(job["capture"]).root, self.title)

    def work(self, job, report, cancel_event):
        from ...lapig_core.multi.capture_set import load_multi_capture
        from ...lapig_core.multi.first_look import fit_joint_first_look, load_joint_model
        from ...lapig_core.multi.result_files import write_joint_result
        from ...lapig_core.multi.stylize import stylize_joint

        report(0.02, "loading the capture of several projectors")
        cs = load_multi_capture(job["capture"], pairs=False)
        model = load_joint_model(cs.setup_dir)
        if model is None or model.count != cs.count:  # no first look at the capture: fit it now
            report(0.05, "fitting the joint model")
            model = fit_joint_first_look(load_multi_capture(job["capture"])).model
        if cancel_event.is_set():
            return None
        report(0.2, "stylizing on the object as the camera sees it")
        surface = cs.together.astype(np.float32) / 255
        settings = None
        if job["psa"]:
            from ...lapig_core.psa.adaptation import PSASettings

            settings = PSASettings(adaptation=job["adaptation"], seed=job["seed"])
        progress = lambda f, text: report(0.25 + 0.6 * f, text)  # noqa: E731
        look = stylize_joint(model, surface, job["prompt"], job["backend"], job["seed"], job["mix"],
                             job["backend_options"], self.working_size, cs.object_mask, psa=job["psa"],
                             psa_settings=settings, on_progress=progress, cancel_event=cancel_event)
        if cancel_event.is_set():  # cancelled: nothing written, the scene keeps its result
            return None
        report(0.9, "writing each projector's image")
        first_look = _first_look_record(cs.setup_dir)
        summary = {"prompt": job["prompt"], "notes": job["notes"], "backend": job["backend"], "seed": job["seed"],
                   "style_mix_override": job["mix"], "capture": str(cs.setup_dir),
                   "fingerprint": cs.meta.get("fingerprint"),
                   "models": {"first_look": True, "line": first_look.get("line", "")},
                   "multi": {k: first_look.get(k) for k in ("coverage_single", "coverage_joint", "per_projector",
                                                            "black_uplift_sentence")}}
        reached = model.reached.any(axis=0) & cs.object_mask
        folder, summary = write_joint_result(job["results"], job["name"], look, surface, cs.names, cs.sizes, summary,
                                             reached)
        return {"folder": str(folder), "summary": summary, "summary_line": summary["summary_line"]}

    def finish(self, output):
        if output is None:
            return None
        store = self.seams.store
        blocker = panel_state.rig_blocker(store.read().rig)
        if blocker:  # the rig was deleted meanwhile: keep no result no scene refers to
            import shutil

            shutil.rmtree(output["folder"], ignore_errors=True)
            raise MultiPipelineError(f"{blocker}: the result was not kept")
        store.record_result(output["folder"], output["summary_line"])
        self._show(output)
        return output

    def _show(self, output):
        show_projector_images(self.seams, output)


def show_projector_images(seams, output) -> None:
    """Each projector's image of a result of several to the sinks that take several projectors (Blender's
    lights; the live windows of a real rig, all at once): the pixels Export writes at the scene's bit depth.
    output: {"folder", "summary"}."""
    from ...lapig_core.multi.result_files import projector_images
    from .ports import ProjectorFrame

    sinks = [sink for sink in seams.sinks if getattr(sink, "several_projectors", False)]
    if not sinks:
        return
    bit_depth = seams.store.export_settings().bit_depth
    frames = [ProjectorFrame(image, *entry["size"], bit_depth, folder=output["folder"], summary=output["summary"],
                             projector_index=k) for k, (entry, image) in enumerate(projector_images(output["folder"]))]
    for sink in sinks:
        show_all = getattr(sink, "show_all", None)  # the live windows of a real rig: every frame presented together
        if show_all is not None:
            show_all(frames)
            continue
        for frame in frames:
            sink.show(frame)


def _first_look_record(setup_dir) -> dict:
    import json

    try:
        return json.loads((setup_dir / MODELS / FIRST_LOOK).read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return {}

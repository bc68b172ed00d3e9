"""Generate for a rig of several projectors: the look on the object as the camera sees it, jointly compensated
(issue 36).

GenerateJob (services/generate/generate_job) takes this way when the scene's rig has more than one projector (the Generate
button, `stylize`). The capture must be one of several projectors made with the rig as it is now; its joint model
(fitted at the capture) is used, or fitted here where the capture has none. The result folder holds one image per
projector (lapig_core/multi/result_files), and each image goes to the sinks that take several projectors (Blender's
lights). With the request's PSA on (the default) the look adapts to the projectors' joint reach first
(lapig_core/multi/joint_psa) and the folder keeps the look without PSA beside it.
"""
from __future__ import annotations

import json

import numpy as np

from ....lapig_core.common.steps import run_to_end
from ....lapig_core.multi.capture_set import FIRST_LOOK, MODELS
from ..pipeline_errors import joint_capture


def joint_model_steps(capture: str):
    """Steps whose value is (the capture of several, without its pairs, and its joint model: its first look's, else
    fitted now)."""
    from ....lapig_core.multi.capture_set import load_multi_capture
    from ....lapig_core.multi.first_look import fit_joint_first_look, load_joint_model

    cs = load_multi_capture(capture, pairs=False)
    model = load_joint_model(cs.setup_dir)
    if model is None or model.count != cs.count:
        yield 0.04, "fitting the joint model"
        model = fit_joint_first_look(load_multi_capture(capture)).model
    return cs, model


def camera_look_geometry(store, backend: str, mix: str, prompt: str, long_side: int):
    """The object as the rig's camera sees it (on the main thread), for a look of the world made in the camera's
    space; None where the look reads none, or the store has no 3D model to cast (the port's optional
    camera_look_geometry)."""
    from ....lapig_core.lgst import DEFAULT_BACKEND

    reader = getattr(store, "camera_look_geometry", None)
    if mix or backend != DEFAULT_BACKEND or not prompt or reader is None:
        return None
    try:
        return reader(long_side)
    except ValueError:  # the rays land on nothing the scene can render
        return None


class JointGenerateWay:
    """GenerateJob's steps for a rig of several projectors (see generate_job.ProjectorGenerateWay)."""

    training = None  # their joint model is fitted at the capture: nothing is trained on the way

    def capture(self, job, state):
        return joint_capture(state, job.capture)

    def inputs(self, job, state, request_inputs):
        if job.request.output_size:
            request_inputs["notes"].append("several projectors: each image is at its projector's native size "
                                           "(Output size applies to one projector)")
        if job.working_size is None:
            job.working_size = job.seams.store.capture_settings().working_size
        geometry = camera_look_geometry(job.seams.store, request_inputs["backend"], request_inputs["mix"] or "",
                                        request_inputs["prompt"], job.working_size)  # main thread: ray casts
        if geometry is not None:
            request_inputs["backend_options"]["geometry"] = geometry
        return {}

    def before_work(self, job):
        return 0.0  # no steps before the work: the progress bar is the work's
        yield

    def work(self, job, inputs, report, cancel_event):
        from ....lapig_core.multi.result_files import write_joint_result
        from ....lapig_core.multi.stylize import stylize_joint

        report(0.02, "loading the capture of several projectors")
        cs, model = run_to_end(joint_model_steps(inputs["capture"]), lambda step: report(0.05, step[1]))
        if cancel_event.is_set():
            return None
        report(0.2, "stylizing on the object as the camera sees it")
        surface = cs.together.astype(np.float32) / 255
        progress = lambda f, text: report(0.25 + 0.6 * f, text)  # noqa: E731
        look = stylize_joint(model, surface, inputs["prompt"], inputs["backend"], inputs["seed"], inputs["mix"],
                             inputs["backend_options"], job.working_size, cs.object_mask, psa=inputs["psa"],
                             psa_settings=inputs["settings"] if inputs["psa"] else None, on_progress=progress,
                             cancel_event=cancel_event)
        if cancel_event.is_set():  # cancelled: nothing written, the scene keeps its result
            return None
        report(0.9, "writing each projector's image")
        first_look = _first_look_record(cs.setup_dir)
        summary = {"prompt": inputs["prompt"], "notes": inputs["notes"], "backend": inputs["backend"],
                   "seed": inputs["seed"], "style_mix_override": inputs["mix"], "capture": str(cs.setup_dir),
                   "fingerprint": cs.meta.get("fingerprint"),
                   "models": {"first_look": True, "line": first_look.get("line", "")},
                   "multi": {k: first_look.get(k) for k in ("coverage_single", "coverage_joint", "per_projector",
                                                            "black_uplift_sentence")}}
        reached = model.reached.any(axis=0) & cs.object_mask
        folder, summary = write_joint_result(inputs["results"], inputs["name"], look, surface, cs.names, cs.sizes,
                                             summary, reached)
        return {"folder": str(folder), "summary": summary, "summary_line": summary["summary_line"]}

    def show(self, job, output):
        show_projector_images(job.seams, output)


def show_projector_images(seams, output) -> None:
    """Each projector's image of a result of several to the sinks that take several projectors (Blender's
    lights; the live windows of a real rig, all at once): the pixels Export writes at the scene's bit depth.
    output: {"folder", "summary"}."""
    from ....lapig_core.multi.result_files import projector_images
    from ..ports import ProjectorFrame

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
    try:
        return json.loads((setup_dir / MODELS / FIRST_LOOK).read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return {}

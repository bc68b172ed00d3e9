"""Render Real Capture for a result of several projectors (issue 36): every projector shows its image of the
result (result.json's projectors[k].image, the refined one where Refine put it) at once, and the camera
captures them, once, on the rig's multi_capture_device (the virtual rig: one Cycles studio per projector,
their linear light added before the one camera response, as the capture and refinement do).

RenderResultJob takes this path when the scene's rig has more than one projector (the Render Real Capture
button, `stylize --render`). The rendered capture is in camera space, as the result's look and predicted
capture are: rendered.png (and rendered_nopsa.png from the images without PSA) go into the result folder, its
comparison sheet shows look, predicted and rendered side by side, and result.json's metrics get
rendered_psnr (against the look, on the object where some projector reaches) and rendered_vs_predicted_psnr
(against the joint model's predicted capture). result.json is written last.
"""
from __future__ import annotations

import re

import numpy as np

from ...lapig_core.capture.settings import CaptureError
from ...lapig_core.export.result_files import read_summary
from .refine_joint import multi_refine_inputs
from .pipeline_errors import PipelineError, hold_capture


def render_valid(capture: str) -> np.ndarray:
    """The camera pixels compared: the object where some projector of the capture's joint model reaches."""
    from ...lapig_core.multi.capture_set import load_multi_capture
    from ...lapig_core.multi.first_look import fit_joint_first_look, load_joint_model

    cs = load_multi_capture(capture, pairs=False)
    model = load_joint_model(cs.setup_dir)
    if model is None or model.count != cs.count:
        model = fit_joint_first_look(load_multi_capture(capture)).model
    return model.reached.any(axis=0) & np.asarray(cs.object_mask, bool)


def render_rounds(device, image_sets: list) -> "list[np.ndarray]":
    """A generator over an open MultiProjectorDevice: each set of K images shown together and captured once,
    at the exposure the capture fixed (every projector white together); its value is the float captures."""
    from ...lapig_core.refine.joint import device_capture

    capture = device_capture(device)
    device.lock_exposure([np.ones((m.shape[0], m.shape[1], 3), np.uint8) * 255 for m in image_sets[0]])
    captured = []
    for i, images in enumerate(image_sets):
        captured.append(capture(images, 1)[0])
        yield 0.1 + 0.8 * (i + 1) / len(image_sets), f"captured {i + 1}/{len(image_sets)}"
    return captured


def multi_render_steps(job):
    """The steps of RenderResultJob for a rig of several projectors; their value is the result's summary."""
    from ...lapig_core.multi.result_files import (nopsa_images, projector_images, rendered_metrics,
                                                   write_rendered)

    folder, capture = multi_refine_inputs(job.seams, "rendering")
    summary = read_summary(folder)
    if summary.get("capture") and summary["capture"] != capture:
        raise PipelineError("the result was made on another capture than the scene's: generate again first")
    yield 0.05, "projecting every projector's image on the rig"
    sets = {"rendered": [image for _, image in projector_images(folder)]}
    without = nopsa_images(folder)
    if without is not None:
        sets["rendered_nopsa"] = without
    devices = job.seams.devices
    capture_settings = job.seams.store.capture_settings()
    held = hold_capture(capture, job.title)

    def render():
        with devices.multi_capture_device(capture_settings) as device:
            return (yield from render_rounds(device, list(sets.values())))

    try:
        captured = yield from job.drive(render, devices.main_thread, holding=held)
    except CaptureError as exc:
        raise PipelineError(str(exc)) from None
    yield 0.9, "comparing with the look"
    rendered = dict(zip(sets, captured))
    summary.setdefault("metrics", {}).update(rendered_metrics(rendered, folder, render_valid(capture)))
    summary["rendered_bit_depth"] = 8  # the device's frames: refine/joint.device_capture's contract
    summary["summary_line"] = with_rendered(summary.get("summary_line") or summary.get("prompt") or "result",
                                            summary["metrics"]["rendered_psnr"])
    write_rendered(folder, rendered, summary)
    job.seams.store.record_result(folder, summary["summary_line"])  # the panel's line says it
    return summary


RENDERED = "; rendered in Cycles "


def with_rendered(line: str, psnr: float) -> str:
    """The result line with this render's figure in place of an earlier render's, before ' | ' (the panel shows
    what follows it on a line of its own)."""
    head, bar, missed = line.partition(" | ")
    head = re.sub(re.escape(RENDERED) + r"[^;]*", "", head)
    return head + f"{RENDERED}{psnr:.1f} dB against the look" + (bar + missed if bar else "")

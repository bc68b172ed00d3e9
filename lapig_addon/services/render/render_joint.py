"""Render Real Capture in camera space, for a result of several projectors (issue 36): every projector shows its
image of the result (result.json's projectors[k].image, the refined one where Refine put it) at once, and the
camera captures them, once, on the rig's multi_capture_device (the virtual rig: one Cycles studio per projector,
their linear light added before the one camera response, as the capture and refinement do).

RenderResultJob (services/render/render_job) takes this way when the scene's rig has more than one projector (the Render
Real Capture button, `stylize --render`). The rendered capture is in camera space, as the result's look and
predicted capture are: rendered.png (and rendered_nopsa.png from the images without PSA) go into the result
folder, its comparison sheet shows look, predicted and rendered side by side, and result.json's metrics get
rendered_psnr (against the look, on the object where some projector reaches) and rendered_vs_predicted_psnr
(against the joint model's predicted capture). result.json is written last.
"""
from __future__ import annotations

import re

import numpy as np

from ....lapig_core.common.steps import run_to_end
from ..pipeline_errors import summary_made_on
from ..generate.generate_joint import joint_model_steps
from ..refine.refine_joint import exposed_capture, joint_inputs


def render_valid(capture: str) -> np.ndarray:
    """The camera pixels compared: the object where some projector of the capture's joint model reaches."""
    cs, model = run_to_end(joint_model_steps(capture))
    return model.reached.any(axis=0) & np.asarray(cs.object_mask, bool)


class JointRenderWay:
    """RenderResultJob's steps for a rig of several projectors (see render_job.ProjectorRenderWay)."""

    projecting = 0.05, "projecting every projector's image on the rig"
    comparing = "comparing with the look"
    holds_capture = True

    def inputs(self, seams):
        """Every projector's image (the refined one where made), and the images without PSA where made."""
        from ....lapig_core.multi.result_files import nopsa_images, projector_images

        folder, capture = joint_inputs(seams, "rendering")
        summary = summary_made_on(folder, capture)
        sets = {"rendered": [image for _, image in projector_images(folder)]}
        without = nopsa_images(folder)
        if without is not None:
            sets["rendered_nopsa"] = without
        return folder, capture, summary, sets

    def rig_settings(self, store):
        return store.capture_settings()

    def rounds(self, devices, capture, image_sets, capture_settings):
        """Each set of K images shown together and captured once; the float captures."""
        with devices.multi_capture_device(capture_settings) as device:
            grab, captured = exposed_capture(device, [(m.shape[1], m.shape[0]) for m in image_sets[0]]), []
            for images in image_sets:
                captured.append(grab(images, 1)[0])
                yield len(captured) / len(image_sets)
            return captured

    def record(self, seams, folder, capture, summary, rendered, capture_settings):
        from ....lapig_core.multi.result_files import rendered_metrics, write_rendered

        summary.setdefault("metrics", {}).update(rendered_metrics(rendered, folder, render_valid(capture)))
        summary["rendered_bit_depth"] = 8  # the device's frames: refine/joint.device_capture's contract
        summary["summary_line"] = with_rendered(summary.get("summary_line") or summary.get("prompt") or "result",
                                                summary["metrics"]["rendered_psnr"])
        write_rendered(folder, rendered, summary)
        seams.store.record_result(folder, summary["summary_line"])  # the panel's line says it
        return summary


RENDERED = "; rendered in Cycles "


def with_rendered(line: str, psnr: float) -> str:
    """The result line with this render's figure in place of an earlier render's, before ' | ' (the panel shows
    what follows it on a line of its own)."""
    head, bar, missed = line.partition(" | ")
    head = re.sub(re.escape(RENDERED) + r"[^;]*", "", head)
    return head + f"{RENDERED}{psnr:.1f} dB against the look" + (bar + missed if bar else "")

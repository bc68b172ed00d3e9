"""Refine on the rig in camera space, for a result of several projectors (issue 36): every projector's image
projected at once, one camera capture per round, all images corrected together (lapig_core/refine/joint).

RefineResultJob (services/refine/refine_job) takes this way when the scene's rig has more than one projector (the Refine
button, `stylize --refine N`). As for one projector, nothing is written until the loop has
finished: the refined images go in as projector_1_refined.png .., then result.json (written last) points each
projector's entry at its refined image (`image`, the open-loop one kept as `image_open_loop`), which Export, the
lights and MPCDI read through multi/result_files.projector_images.
"""
from __future__ import annotations

import numpy as np

from ....lapig_core.export.result_files import read_result_image, write_result
from ....lapig_core.refine.loop import RefineError, RefineSettings
from ..panel import panel_state
from ..generate.generate_joint import joint_model_steps, show_projector_images
from ..pipeline_errors import PipelineError, joint_capture, summary_made_on
from .refine_lines import record_refinement, refine_line

REFINED_SUFFIX = "_refined"


def joint_inputs(seams, doing: str = "refinement") -> tuple[str, str]:
    """(the result folder, the capture) from the scene (the main thread), or PipelineError saying why not."""
    from ....lapig_core.multi.result_files import is_multi_result

    state = seams.store.read()
    blocker = panel_state.result_blocker(state) or panel_state.device_blocker(state.rig)
    if blocker:
        raise PipelineError(blocker)
    if seams.devices is None or not seams.devices.opens_several:
        raise PipelineError(f"{doing} of several projectors needs a rig that shows them all at once (the virtual "
                            f"rig, or a real one with a window on each projector's display)")
    capture = joint_capture(state)
    if not is_multi_result(state.result_dir):
        raise PipelineError("the scene's result is of one projector; the rig has several: generate again first")
    return state.result_dir, capture


def exposed_capture(device, sizes):
    """refine/joint.device_capture over an open MultiProjectorDevice, at the camera's exposure as the capture fixed
    it: every projector (sizes: (width, height) each) white together."""
    from ....lapig_core.refine.joint import device_capture

    device.lock_exposure([np.full((h, w, 3), 255, np.uint8) for w, h in sizes])
    return device_capture(device)


class JointRefineWay:
    """RefineResultJob's steps for a rig of several projectors (see refine_job.ProjectorRefineWay)."""

    inputs = staticmethod(joint_inputs)

    @staticmethod
    def prepared(folder: str, capture: str, settings: RefineSettings):
        """Steps whose value is (the result's summary, the JointRefinement of its projector images against its
        look on the capture's joint model)."""
        from ....lapig_core.refine.joint import JointRefinement
        from ....lapig_core.multi.result_files import projector_images

        yield 0.02, "reading the result and the joint model"
        summary = summary_made_on(folder, capture)
        cs, model = yield from joint_model_steps(capture)
        target = read_result_image(folder, "look")
        start = [image for _, image in projector_images(folder)]
        try:
            return summary, JointRefinement(model, target, model.reached.any(axis=0) & cs.object_mask, start,
                                            settings)
        except RefineError as exc:
            raise PipelineError(str(exc)) from None

    @staticmethod
    def rig_settings(store):
        return store.capture_settings()

    @staticmethod
    def rounds(devices, capture, refinement, capture_settings):
        """A generator of (progress, message) that runs `refinement` on the rig's MultiProjectorDevice."""
        with devices.multi_capture_device(capture_settings) as device:
            grab = exposed_capture(device, [m.projector_size for m in refinement.model.maps])
            vary = getattr(device, "vary_noise", None)
            cap, draws = refinement.settings.iterations, 0
            while not refinement.done:
                images, repeats = refinement.request()
                shots = []
                for _ in range(repeats):  # each grab a new noise draw, as a real camera's are
                    if vary is not None:
                        vary(draws)
                    draws += 1
                    shots.append(grab(images, 1)[0])
                refinement.take(np.stack(shots))
                rec = refinement.record
                yield 0.05 + 0.9 * min(rec.iterations, cap) / (cap + 1), \
                    f"refining {len(images)} projectors on the rig: step {rec.iterations}/{cap}, last capture " \
                    f"{rec.history[-1]:.1f} dB (noise floor {rec.noise_floor_psnr:.1f})"

    @staticmethod
    def write(folder: str, summary: dict, refinement):
        """Steps that write each projector's refined image, then result.json pointing at them; their value is (the
        summary written, the record, None)."""
        from ....lapig_core.multi.result_files import projector_image_name

        yield 0.96, "writing the refined result"
        record = refinement.record.to_dict()
        record["frame"] = "projectors"
        names = [projector_image_name(k) + REFINED_SUFFIX for k in range(len(refinement.images))]
        images = dict(zip(names, refinement.images))
        for entry, name in zip(summary.get("projectors") or [], names):
            entry.setdefault("image_open_loop", entry["image"])
            entry["image"] = f"{name}.png"
        record["images"] = {f"projector_{k + 1}": f"{n}.png" for k, n in enumerate(names)}
        record_refinement(summary, record)
        write_result(folder, images, summary)  # the images first, result.json last: it names them
        return summary, record, None

    @staticmethod
    def record(seams, folder: str, summary: dict, record: dict, image) -> dict:
        """The refined result into the scene (the main thread): its line, and each image to the sinks of several."""
        seams.store.record_result(folder, summary["summary_line"])
        show_projector_images(seams, {"folder": folder, "summary": summary})
        return {"folder": folder, "refine": record, "line": refine_line(record).lstrip("; ")}

"""Limit Look to the Dose for the joint strategy, a result of several projectors (issue 36). No bpy.

Light adds, so the dose on the marked region is that of every projector's look together plus the room's
(light_joint.joint_report over the rig camera's pixels). The cap is one factor on every projector's emitted
light (light_joint.joint_cap_factor): the sum scales by it, and the blend between the projectors, the look's
hue and its shading hold. Each projector's image is re-encoded through its own gamma and black level
(light_joint.scaled_frame). The limited look is a result of its own (the free one stays), whose projector images
the lights then show; its light report, of the limited look, goes into it. services/light/dose_cap.DoseCapJob takes this
way for the joint strategy; the renders are its main-thread steps (blender/light_plan_run.JointSceneLight), the
arithmetic and the files a worker's.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from . import light_report
from .light_joint import joint_cap_factor, joint_report, scaled_frame


def joint_cap_steps(job, folder: str, capture: str):
    """DoseCapJob's steps for several projectors (see dose_cap.projector_cap_steps); their value is what the cap
    did. The cap's cost in PSNR is one projector's (its frame projected twice on the rig)."""
    from ....lapig_core.multi.result_files import projector_images

    if job.measure_psnr:
        raise ValueError("measuring the cap's cost works with one projector; for several limit the look alone")
    job.plan.check()
    entries = projector_images(folder)
    maps, emitted = yield from job.light.steps([image for _, image in entries])
    bit_depth = job.seams.store.export_settings().bit_depth
    out = yield from job.drive(lambda: _work(job.plan, job.light, folder, entries, maps, emitted, bit_depth), False)
    if job.record:  # the main thread: the scene and the lights
        from ..generate.generate_joint import show_projector_images

        job.seams.store.record_result(out["folder"], out["summary"]["summary_line"])
        show_projector_images(job.seams, {"folder": out["folder"], "summary": out["summary"]})
    return out


def _work(plan, light, folder, entries, maps, emitted, bit_depth):
    """On a worker: the one factor, every projector's image scaled by it, the limited look a result of its own
    with the report of its light."""
    from ....lapig_core.export.result_files import read_result_image, read_summary, write_new_result
    from ....lapig_core.multi.result_files import projector_image_name

    yield 0.85, "limiting every projector's light"
    before, total, combined = joint_report(plan, maps, emitted, light.models, light.names, light.lumens)
    scale = joint_cap_factor(plan, total, combined)
    frames = [scaled_frame(image, m, scale, bit_depth) for (_, image), m in zip(entries, light.models)]
    # the limited look's light: each projector's emitted light scaled, never below its black level
    after_emitted = None if emitted is None else [np.maximum(np.where(m_.white_lux > 0, e * scale, 0.0),
                                                             np.where(m_.white_lux > 0, model.black_level, 0.0))
                                                  for e, m_, model in zip(emitted, maps, light.models)]
    after, _, after_combined = joint_report(plan, maps, after_emitted, light.models, light.names, light.lumens)
    yield 0.92, "writing the limited look"
    summary = read_summary(folder)
    folder = Path(folder)
    skip = {"rendered", "rendered_nopsa"} | {Path(e["image"]).stem for e, _ in entries}
    images = {p.stem: read_result_image(folder, p.stem) for p in folder.glob("*.png")
              if p.stem not in skip and not p.stem.startswith("light_")}
    names = [projector_image_name(k) for k in range(len(frames))]
    images.update(dict(zip(names, frames)))
    for entry, name in zip(summary.get("projectors") or [], names):
        entry["image"] = f"{name}.png"
        entry.pop("image_open_loop", None)
    summary.pop("refine", None)
    for key in [k for k in summary.get("metrics", {}) if k.startswith(("rendered", "refine"))]:
        summary["metrics"].pop(key)
    cap = {"scale": round(scale, 4), "limit_lux": plan.limit.limit_lux, "from": str(folder),
           "max_lux_before": before["dose"]["max_lux"], "max_lux_after": after["dose"]["max_lux"],
           "projectors": len(frames)}
    summary["dose_cap"] = cap
    summary["summary_line"] = (f"{summary.get('summary_line') or summary.get('prompt') or 'result'}; limited to "
                               f"the dose: every projector's light x{scale:.2f}")
    summary["notes"] = list(summary.get("notes", [])) + [
        "the look, predicted and comparison images are the free look's; the projector images are limited"]
    new = write_new_result(folder.parent, folder.name + "_dose", images, summary)
    after["result"] = str(new)
    after["frame"] = "camera"
    after["dose_cap_scale"] = 1.0
    after["report_file"] = light_report.write_report(str(new), after,
                                                     light_report.report_images(plan, total, after_combined))
    return {"folder": str(new), "summary": summary, "scale": scale, "predicted_max_lux": after["dose"]["max_lux"],
            "max_lux_before": before["dose"]["max_lux"], "report": after,
            "changed_pixel_share": round(float(np.mean([(np.abs(f - o) > 1e-9).any(-1).mean()
                                                        for f, (_, o) in zip(frames, entries)])), 4),
            "notes": []}


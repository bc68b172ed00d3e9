"""Limit Look to the Dose for a result of several projectors (issue 36). No bpy.

Light adds, so the dose on the marked region is that of every projector's look together plus the room's
(light_report.several_report over the rig camera's pixels). The cap is one factor on every projector's emitted
light (light_report.several_cap_factor): the sum scales by it, and the blend between the projectors, the look's
hue and its shading hold. Each projector's image is re-encoded through its own gamma and black level
(light_report.scaled_frame). The limited look is a result of its own (the free one stays), whose projector images
the lights then show; its light report, of the limited look, goes into it. The renders are the job's main-thread
steps (blender/light_plan_run.SeveralSceneLight), the arithmetic and the files a worker's.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from . import light_report
from .dose_cap import DoseCapJob
from .jobs import Job


class SeveralDoseCapJob(Job):
    title = DoseCapJob.title  # the panel's progress line is the one job's

    def __init__(self, seams, plan, light, folder: str, record: bool = True):
        super().__init__()
        self.seams, self.plan, self.light, self.folder, self.record = seams, plan, light, folder, record

    def steps(self):
        from ...lapig_core.multi.result_files import projector_images

        self.plan.check()
        if self.plan.limit is None:
            raise ValueError("limiting the look needs a conservation category")
        entries = projector_images(self.folder)
        frames = [image for _, image in entries]
        maps, emitted = yield from self.light.steps(frames)
        bit_depth = self.seams.store.export_settings().bit_depth if self.seams is not None else 16
        out = yield from self.drive(lambda: self._work(entries, maps, emitted, bit_depth), False)
        if self.record and self.seams is not None:  # the main thread: the scene and the lights
            from .multi_generate_job import show_projector_images

            self.seams.store.record_result(out["folder"], out["summary"]["summary_line"])
            show_projector_images(self.seams, {"folder": out["folder"], "summary": out["summary"]})
        self.result = out

    def _work(self, entries, maps, emitted, bit_depth):
        from ...lapig_core.export.result_files import read_result_image, read_summary, write_new_result
        from ...lapig_core.multi.result_files import projector_image_name

        yield 0.85, "limiting every projector's light"
        light, plan = self.light, self.plan
        before, total, combined = light_report.several_report(plan, maps, emitted, light.models, light.names,
                                                              light.lumens)
        scale = light_report.several_cap_factor(plan, total, combined)
        frames = [light_report.scaled_frame(image, m, scale, bit_depth) for (_, image), m in zip(entries, light.models)]
        # the limited look's light: each projector's emitted light scaled, never below its black level
        after_emitted = None if emitted is None else [np.maximum(np.where(m_.white_lux > 0, e * scale, 0.0),
                                                                 np.where(m_.white_lux > 0, model.black_level, 0.0))
                                                      for e, m_, model in zip(emitted, maps, light.models)]
        after, _, after_combined = light_report.several_report(plan, maps, after_emitted, light.models, light.names,
                                                               light.lumens)
        yield 0.92, "writing the limited look"
        summary = read_summary(self.folder)
        folder = Path(self.folder)
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


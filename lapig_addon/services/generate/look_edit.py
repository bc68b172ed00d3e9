"""The sliders of a world look (issue 50, item 4): one change re-makes the scene's result without a new prompt.

No capture, no Train, no prompt model and no PSA: the look is drawn again from its record (result.json's
lgst.look_record: the composition, its colours, texture and mood) with the edited parameters, theta and PSA's
tone field come from the result's look_state.npz, and the look is compensated at the working frame and at the
output size as Generate does. The result folder is updated in place (each file whole), so Export, a show and a
later Generate of the same prompt take the edited values (result.json's lgst.look_parameters).

    EditLookJob(seams, {"scale": 2.0}).run_to_completion()   # or reset=True: the plan's own values
"""
from __future__ import annotations

import re

from ....lapig_core.lgst import DEFAULT_BACKEND
from ....lapig_core.look_parameters import BY_NAME, PARAMETERS, LookParameters
from ..jobs import WorkerJob
from .look_record import parameters_for_generate, plan_parameters, world_record  # noqa: F401 (theirs to import)
from ..pipeline_errors import PipelineError, hold_capture
from ..ports import Seams


def edited_parameters(summary: dict, changes: dict | None, reset: bool = False) -> LookParameters:
    """The result's parameters with `changes`; PipelineError with one line for a look without sliders or a bad
    value."""
    found = world_record(summary)
    if found is None:
        raise PipelineError("the result's look has no sliders: they are for the looks of the world (a material, "
                            "a plant, water, fire, the sky); generate one first")
    record, current = found
    base = plan_parameters(record, int(summary.get("seed") or 0)) if reset else current
    try:
        return base.edited(dict(changes or {}))
    except ValueError as exc:
        raise PipelineError(str(exc)) from None


def edit_note(before: LookParameters, after: LookParameters) -> str:
    """'Scale 1 -> 2, Hue 0 -> 30' for the result line and notes ('' when nothing changed)."""
    def said(name, value):
        return str(int(value)) if BY_NAME[name].integer else f"{value:g}"
    return ", ".join(f"{BY_NAME[n].label} {said(n, getattr(before, n))} -> {said(n, getattr(after, n))}"
                     for n in after.changed(before))


def _models(capture: str, device):
    """The capture's models as Generate would use them: Train's, else the first look; never trained here."""
    from ....lapig_core import pipeline
    from ....lapig_core.capture.dataset import load_capture_set
    from ....lapig_core.photometric.first_look import load_first_look

    cs = load_capture_set(capture, pairs=False)
    problem, saved = pipeline.saved_models_problem(capture)
    if saved is not None and saved.choice is not None:
        return cs, pipeline.surface_models(cs, train_if_missing=False, saved=saved, device=device)
    look = load_first_look(capture, cs.meta.get("fingerprint"))
    if look is None:
        raise PipelineError("the capture has neither trained models nor a first look: capture it again")
    return cs, pipeline.first_look_models(cs, look.classical, device=device)


def remake(summary: dict, folder: str, cs, models, params: LookParameters, output_frame, geometry=None,
           dark_outside: bool = True) -> dict:
    """The look of `summary` drawn again with `params`, compensated; the images a result holds (name -> (H, W, 3))
    and the simulated PSNR. Worker-thread safe (torch and files only)."""
    import torch

    from ....lapig_core.common import metrics
    from ....lapig_core.lgst.styletransfer_backend import StyleTransferBackend
    from ....lapig_core.lgst.world.geometry import from_capture
    from ....lapig_core.native_output import native_output
    from ....lapig_core.pipeline import as_image, darkened_outside, on_object_mask
    from ....lapig_core.psa.adaptation import without_psa
    from ....lapig_core.psa.tone_field import AdaptedLook
    from ....lapig_core.show.look_state import load_look_state

    record, _ = world_record(summary)
    if geometry == "capture":
        geometry = from_capture(models.i_max[0].permute(1, 2, 0).cpu().numpy())
    lgst = StyleTransferBackend(geometry=geometry, look_parameters=params.to_dict())
    lgst.prepare_from_record(models.i_max, record, summary.get("prompt", ""), seed=int(summary.get("seed") or 0))
    adapted = AdaptedLook(lgst, models.i_min, models.i_max)
    state = load_look_state(folder)
    if state is not None:  # theta and the tone field as PSA left them (their shapes do not depend on the sliders)
        adapted.load_state({**lgst.state(), **{k: [t.to(models.device) for t in v] for k, v in state.items()}})
    with torch.no_grad():  # the look drawn once at the working frame; with and without the tone field
        base = lgst.forward()
        chosen = without_psa(_Drawn(adapted.field.apply(base), adapted), models)
        plain = without_psa(_Drawn(base, lgst), models)
        if dark_outside and cs.projector_valid is not None:
            mask = on_object_mask(cs.projector_valid).to(models.device)
            chosen, plain = darkened_outside(chosen, mask, models), darkened_outside(plain, mask, models)
    images = {"target": as_image(chosen.target), "projector": as_image(chosen.projector_image),
              "simulated": as_image(chosen.simulated), "target_nopsa": as_image(plain.target),
              "projector_nopsa": as_image(plain.projector_image), "simulated_nopsa": as_image(plain.simulated)}
    if tuple(output_frame) != tuple(cs.frame_size):
        native = native_output(folder_setup(cs), models, adapted, adapted.state(), *output_frame, dark_outside)
        images.update(target_native=as_image(native.target), projector_native=as_image(native.projector_image))
    return {"images": images, "simulated_psnr": metrics.psnr(images["simulated"], images["target"]),
            "simulated_psnr_nopsa": metrics.psnr(images["simulated_nopsa"], images["target_nopsa"])}


class _Drawn:
    """A look already drawn, as without_psa takes one (its image and its backend's state)."""

    def __init__(self, image, look):
        self.image, self.look = image, look

    def forward(self):
        return self.image

    def state(self):
        return self.look.state()


def folder_setup(cs):
    from ....lapig_core.capture.dataset import setup_dir_of

    return setup_dir_of(cs)


_FIGURE = re.compile(r"simulated( by the classical model)? [-\d.]+ dB")
_EDITED = re.compile(r" \(edited: [^)]*\)")


def edited_line(line: str, psnr: float, note: str) -> str:
    """The result line with the new figure and what was edited (before the ' | ' of the words not understood)."""
    line = _FIGURE.sub(lambda m: f"simulated{m.group(1) or ''} {psnr:.1f} dB", _EDITED.sub("", line))
    head, bar, tail = line.partition(" | ")
    return head + (f" (edited: {note})" if note else "") + bar + tail


class EditLookJob(WorkerJob):
    """The scene's world look drawn again with edited sliders; the result folder updated in place."""

    title = "LAPIG edit look"

    def __init__(self, seams: Seams, changes: dict | None = None, reset: bool = False, device: str | None = None):
        super().__init__()
        self.seams, self.changes, self.reset, self.device = seams, dict(changes or {}), reset, device

    def prepare(self):
        from ....lapig_core.export.result_files import capture_of_result, read_summary
        from ..panel import panel_state
        from .generate_job import look_geometry
        from ..train.train_job import device_choice

        store = self.seams.store
        state = store.read()
        blocker = panel_state.result_blocker(state)
        if blocker:
            raise PipelineError(blocker)
        folder = state.result_dir
        summary = read_summary(folder)
        params = edited_parameters(summary, self.changes, self.reset)  # a bad value: refused before any work
        before = world_record(summary)[1]
        capture = capture_of_result(folder, summary) or state.capture_dir
        if not capture:
            raise PipelineError("the result names no capture: generate it again")
        frame = (summary.get("native_output") or {}).get("frame")
        output = tuple(frame) if isinstance(frame, list) else None  # the size Generate made it at
        geometry = look_geometry(store, capture, DEFAULT_BACKEND, "", summary.get("prompt", "") or "look") \
            if (summary.get("lgst") or {}).get("geometry") else None
        return {"folder": folder, "summary": summary, "params": params, "before": before, "capture": capture,
                "output_frame": output, "geometry": geometry, "device": device_choice(store, self.device),
                "bit_depth": store.export_settings().bit_depth}

    def hold(self, job):
        return hold_capture(job["capture"], self.title)

    def work(self, job, report, cancel_event):
        from ....lapig_core.common import compute_device
        from ....lapig_core.export.result_files import as_stored, write_result

        report(0.05, "loading the models")
        cs, models = _models(job["capture"], compute_device.resolve(job["device"]))
        if cancel_event.is_set():
            return None
        report(0.3, "drawing the look again")
        summary = dict(job["summary"])
        made = remake(summary, job["folder"], cs, models, job["params"], job["output_frame"] or cs.frame_size,
                      job["geometry"], bool(summary.get("dark_outside", True)))
        if cancel_event.is_set():  # cancelled: the result stays as it was
            return None
        note = edit_note(job["before"], job["params"])
        lgst = {**summary.get("lgst", {}), "look_parameters": job["params"].to_dict()}
        metrics = {**summary.get("metrics", {}), "simulated_psnr": made["simulated_psnr"],
                   "simulated_psnr_nopsa": made["simulated_psnr_nopsa"]}
        summary.update(lgst=lgst, metrics=metrics)
        summary["summary_line"] = edited_line(summary.get("summary_line", ""), made["simulated_psnr"], note)
        report(0.9, "writing the result")
        write_result(job["folder"], made["images"], summary)
        projector = as_stored(made["images"].get("projector_native", made["images"]["projector"]))
        return {"folder": job["folder"], "summary": summary, "summary_line": summary["summary_line"],
                "projector": projector, "edited": note, "bit_depth": job["bit_depth"]}

    def finish(self, output):
        if output is None:
            return None
        from ..export.export_result import result_frame

        store = self.seams.store
        reach = output["summary"].get("surface_reach") or {}
        store.record_result(output["folder"], output["summary_line"], reach.get("message", ""))
        self.seams.show(result_frame(store, output["folder"], output["bit_depth"], output.pop("projector"),
                                     output["summary"]))
        return output


def node_recipe_of(summary: dict) -> dict:
    """The result's world look as a recipe of shader nodes (lgst/world/node_recipe) with its sliders; PipelineError
    for a look without sliders."""
    from ....lapig_core.lgst.world.catalog import by_name
    from ....lapig_core.lgst.world.node_recipe import node_recipe

    found = world_record(summary)
    if found is None:
        raise PipelineError("only a look of the world (a material, a plant, water, fire, the sky) becomes a node "
                            "group: generate one first")
    record, params = found
    material = by_name().get(record["world"]["base"])
    if material is None:
        raise PipelineError(f"the look names a material '{record['world']['base']}' this version does not have")
    named = (record.get("colour_layers") or {}).get("0")
    return node_recipe(material, params, named)


__all__ = ["EditLookJob", "PARAMETERS", "edited_parameters", "node_recipe_of", "parameters_for_generate", "remake",
           "world_record"]

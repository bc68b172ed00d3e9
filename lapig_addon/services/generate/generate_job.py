"""Generate: the prompt -> the look on the object -> the projector image(s) that show it, for K projectors.

One job (GenerateJob) for either model strategy (services/state.Rig.strategy): prepare() checks the request and
the capture on the main thread (a prompt of which nothing is understood is refused before any model loads), the
work runs on a worker thread under the capture's lock, finish() records the result in the scene and hands the
stored image(s) to the sinks. The way is chosen once, by the rig: one projector's look in its own pixels,
compensated by its models (ProjectorGenerateWay, below: trained on the way when the capture has none), or several
projectors' look in camera space, jointly compensated (services/generate/generate_joint).
"""
from __future__ import annotations

import datetime
import os
import shutil

from ....lapig_core.common import compute_device, metrics
from ....lapig_core.capture.dataset import DatasetError, frame_size_of, load_capture_set
from ....lapig_core.lgst import DEFAULT_BACKEND, backend_class
from ....lapig_core.lgst.prompt_mapping import validate_prompt
from ....lapig_core.native_output import OutputSizeError, output_frame, tile_for
from ....lapig_core.pipeline import (as_image, first_look_models, output_at, saved_models_problem, stylize, surface_models)
from ....lapig_core.photometric import first_look
from ....lapig_core.psa.adaptation import PSASettings, loss_maps
from ....lapig_core.export.result_files import (as_stored, folder_name, heat_overlay, read_summary, write_new_result)
from ....lapig_core.show.look_state import look_state_files
from ..panel import panel_state
from .. import warmup
from ..export.export_result import result_frame
from ..jobs import THREAD_PREFIX, WorkerJob
from ..pipeline_errors import PipelineError, capture_record, current_capture, hold_capture
from ..ports import Seams
from ..state import GenerateRequest
from ..train.train_job import TrainModelsJob, capture_first_look, device_choice
from ..ways import chosen_way


def check_style_images(specs) -> None:
    """Read every style image once: missing, not an image, too small -> PipelineError with its line.
    What was converted (grayscale, resized) the backend notes in the result."""
    from ....lapig_core.common.style_image import StyleImageError, load_style_image, parse_style_image_spec

    for spec in specs:
        try:
            load_style_image(parse_style_image_spec(spec)[0])
        except StyleImageError as exc:
            raise PipelineError(str(exc)) from None


def style_name(specs) -> str:
    """'style_<first image's name>' for the result folder of a look from style images alone."""
    if not specs:
        return ""
    from ....lapig_core.common.style_image import parse_style_image_spec

    return "style " + os.path.splitext(os.path.basename(parse_style_image_spec(specs[0])[0]))[0]


def look_geometry(store, capture: str, backend: str, mix: str, prompt: str, depth: bool = False):
    """What the looks of the world follow (on the main thread: Blender's ray casts): the object as the projector
    sees it at the capture's working frame, or "capture" (no 3D model: the captured surface stands in); None where
    the look reads no geometry (a style mix, another backend). depth: InstructPix2Pix with its depth adapter, which
    reads the object's depth."""
    if mix or not prompt or (backend != DEFAULT_BACKEND and not depth):
        return None
    reader = getattr(store, "look_geometry", None)
    if reader is None:
        return "capture"
    try:
        geometry = reader(*frame_size_of(capture))
    except ValueError:  # the rays land on nothing the scene can render: the captured surface then
        geometry = None
    return geometry if geometry is not None else "capture"


def kept_look_parameters(state, prompt: str, backend: str) -> dict | None:
    """The scene's result's edited sliders where Generate makes the same world look again (services/generate/look_edit)."""
    from .look_record import parameters_for_generate

    if not state.result_dir:
        return None
    try:
        summary = read_summary(state.result_dir)
    except (OSError, ValueError):
        return None
    return parameters_for_generate(summary, prompt, backend)


def geometry_files(geometry) -> dict:
    """look_geometry.npz, as write_new_result's files, where the look was shaped by the object's geometry ("capture"
    is not kept: the captured surface gives it again)."""
    from ....lapig_core.lgst.world.geometry import GEOMETRY_FILE, LookGeometry, geometry_bytes

    return {GEOMETRY_FILE: geometry_bytes(geometry)} if isinstance(geometry, LookGeometry) else {}


class GenerateJob(WorkerJob):
    """Prompt -> the look (with and without PSA) -> each projector's compensated image."""

    title = "LAPIG generate"

    def __init__(self, seams: Seams, request: GenerateRequest, iterations: int | None = None, result_root=None,
                 capture: str | None = None, device: str | None = None, working_size: int | None = None):
        """iterations: as TrainModelsJob's, for models trained on the way; capture, device: as TrainModelsJob's;
        working_size: the long side a look in camera space is made at (None: the scene's Working size; one
        projector's look is at its capture's working frame)."""
        super().__init__()
        self.seams, self.request, self.iterations = seams, request, iterations
        self.result_root, self.capture, self.device, self.working_size = result_root, capture, device, working_size
        self.way = None  # chosen by the rig, in prepare()

    def prepare(self):
        r = self.request
        store = self.seams.store
        state = store.read()
        self.way = generate_way(state.rig)
        folder = self.way.capture(self, state)  # and the way's own refusals, before the request's
        mix = r.mix.strip()
        # before r.problem(): an empty prompt is refused here with the longer reason
        style_only = bool(r.style_images) and not r.prompt.strip()  # a style image needs no prompt
        prompt, notes = validate_prompt(r.prompt) if not (mix or style_only) else (r.prompt.strip(), [])
        problem = r.problem()
        if problem:
            raise PipelineError(problem)
        backend = r.lgst_backend()
        backend_class(backend)  # an unknown name is refused now, not after the models are trained
        if r.style_images:
            check_style_images(r.style_images)  # a bad file is refused now too (its notes: in the result)
            if r.backend != backend:
                notes.append(f"a style image is chosen: the look comes from it ('{backend}' backend), "
                             f"not from '{r.backend}'")
        options = r.backend_options()
        kept = None if mix else kept_look_parameters(state, prompt, backend)
        if kept is not None:  # the same prompt again: the sliders as the artist left them
            options["look_parameters"] = kept
        job = {"capture": folder, "prompt": prompt, "notes": notes, "backend": backend,
               "backend_options": options, "mix": mix or None, "psa": r.psa, "seed": r.seed,
               "settings": PSASettings(adaptation=r.adaptation, seed=r.seed),
               "results": self.result_root or os.path.join(store.data_root(), "results"),
               "name": folder_name(prompt or mix or style_name(r.style_images), datetime.datetime.now())}
        return {**job, **self.way.inputs(self, state, job)}

    def hold(self, job):
        return hold_capture(job["capture"], self.title)

    def steps(self):
        """The prompt read first (a prompt of which nothing is understood: refused before any training), then the
        way's steps before the work (one projector: its models trained first when the capture has none)."""
        if self._inputs is self._NOT_PREPARED:
            self._inputs = self.prepare()
        yield from self._read_prompt()
        share = yield from self.way.before_work(self)
        for progress, message in super().steps():
            yield share + (1.0 - share) * progress, message

    def _read_prompt(self):
        """Plan the prompt on a thread (the text model may load: Blender's UI keeps its turns) and raise its one
        line when nothing of it is understood ('no look matched ...'), so a refused prompt changes nothing."""
        import threading

        job = self._inputs
        if job["mix"] or job["backend"] != DEFAULT_BACKEND or not job["prompt"]:
            return
        from ....lapig_core.lgst.not_understood import check_prompt

        box = {}

        def target():
            try:
                warmup.wait_for_warmup()  # the text model once, not loaded beside a warm-up under way
                check_prompt(job["prompt"])
            except BaseException as exc:  # handed to the main thread, raised there
                box["error"] = exc

        thread = threading.Thread(target=target, name=f"{THREAD_PREFIX}{self.title} prompt", daemon=True)
        thread.start()
        while thread.is_alive():
            thread.join(self.poll_timeout or 0.0)
            yield 0.0, "reading the prompt"
        if "error" in box:
            raise box["error"]

    def stop(self):
        super().stop()  # closes steps(), and with it a training's on the way, which tells its worker to stop
        if self.way is not None and self.way.training is not None:
            self.way.training.stop()  # then waits for that worker

    def work(self, job, report, cancel_event):
        if warmup.warmup_state()["running"]:  # the session's warm-up is loading the models: not twice
            report(0.01, "loading the text and style models")
            while not warmup.wait_for_warmup(0.1):
                if cancel_event.is_set():
                    return None
        return self.way.work(self, job, report, cancel_event)

    def finish(self, output):
        if output is None:
            return None
        store = self.seams.store
        blocker = panel_state.rig_blocker(store.read().rig)
        if blocker:  # the rig was deleted while the work ran: keep no result that no scene refers to
            shutil.rmtree(output["folder"], ignore_errors=True)
            raise PipelineError(f"{blocker}: the result was not kept")
        if self.capture and self.way.training is None:  # the named capture becomes the scene's
            store.record_capture(self._inputs["capture"], *capture_record(self._inputs["capture"]))
        compensator = output["summary"].get("compensator") or {}
        if not output["summary"]["models"]["first_look"]:  # a first look trained nothing: the step stays as it is
            store.record_models(output["summary"].get("fingerprint") or "",  # trained on the way
                                f"Fine-tuned; {compensator['line']}" if compensator.get("line") else None)
        reach = output["summary"].get("surface_reach") or {}
        store.record_result(output["folder"], output["summary_line"], reach.get("message", ""))
        self.way.show(self, output)  # the stored image(s), from memory: the sinks show the pixels Export will write
        return output


def generate_way(rig):
    """The one place Generate's way is chosen: several projectors' look is made in camera space and compensated
    jointly."""
    return chosen_way(rig, ProjectorGenerateWay, "generate.generate_joint:JointGenerateWay")()


class ProjectorGenerateWay:
    """GenerateJob's steps for one projector, in its own pixels: capture(job, state) and inputs(job, state,
    request inputs) on the main thread; before_work(job): steps whose value is the progress bar's share they took
    (the models trained first where the capture has none); work(job, inputs, report, cancel_event) on the worker
    -> {"folder", "summary", "summary_line", ...}; show(job, output) hands the stored image to the sinks."""

    training = None  # the TrainModelsJob run first when the capture has no models yet

    output = None  # the output's (width, height), checked with the capture

    def capture(self, job, state):
        """The capture (current_capture), and the output size, refused now, not after PSA: over native or over the
        memory budget."""
        folder = current_capture(state, job.capture)
        try:
            self.output = output_frame(job.request.output_size, *state.rig.projector_size)
            tile_for(*self.output)
        except OutputSizeError as exc:
            raise PipelineError(str(exc)) from None
        return folder

    def inputs(self, job, state, request_inputs):
        store, r = job.seams.store, job.request
        geometry = look_geometry(store, request_inputs["capture"], request_inputs["backend"],
                                 request_inputs["mix"] or "", request_inputs["prompt"],
                                 "depth_adapter" in r.backend_options())
        return {"geometry": geometry, "dark_outside": r.dark_outside, "output_frame": self.output,
                "bit_depth": store.export_settings().bit_depth, "device": device_choice(store, job.device)}

    def before_work(self, job):
        """Models first when there are none for this capture: Train's job, whose choice is measured by
        rendering (on the worker thread, surface_models could only ask PCNet)."""
        inputs = job._inputs
        problem, inputs["saved"] = saved_models_problem(inputs["capture"])  # each checkpoint read once
        if problem == "":  # never trained: the capture's first look, where Capture fitted one, works at once
            inputs["first_look"] = capture_first_look(inputs["capture"])
            if inputs["first_look"] is not None:
                problem = None
        if problem is None:
            return 0.0
        if problem:  # damaged (the same note as surface_models gives)
            inputs["notes"].append(f"the saved models could not be used ({problem}): fine-tuned them "
                                   f"again and saved over them")
        share = 0.5
        self.training = TrainModelsJob(job.seams, job.iterations, job.capture, job.device)
        self.training.poll_timeout = job.poll_timeout
        self.training.check()
        inner = self.training.steps()
        try:
            for progress, message in inner:
                yield share * progress, f"training: {message}"
        finally:
            inner.close()
        return share

    def work(self, job, inputs, report, cancel_event):
        saved, look = inputs.get("saved"), inputs.get("first_look")
        # with the models saved and their choice made (or a first look): the references, the valid map and the
        # metadata only
        cs = load_capture_set(inputs["capture"], pairs=look is None and (saved is None or saved.choice is None))
        report(0.02, "loading the models")
        notes = list(inputs["notes"])
        device = compute_device.resolve(inputs["device"])
        if look is not None:
            models = first_look_models(cs, look.classical, device=device)
        else:
            models = surface_models(cs, on_progress=lambda p, m: report(0.05 + 0.45 * p, m),
                                    cancel_event=cancel_event, iterations=job.iterations, notes=notes, saved=saved,
                                    device=device)
        if cancel_event.is_set():
            return None
        report(0.5, "stylizing")
        res = stylize(cs, models, inputs["prompt"], backend=inputs["backend"], seed=inputs["seed"], mix=inputs["mix"],
                      psa=inputs["psa"], settings=inputs["settings"], cancel_event=cancel_event,
                      on_progress=lambda p, m: report(0.55 + 0.4 * p, m), backend_options=inputs["backend_options"],
                      dark_outside=inputs["dark_outside"], geometry=inputs.get("geometry"))
        if cancel_event.is_set():  # cancelled: write nothing, the scene keeps its last result
            return None
        report(0.95, "the look and its compensation at %dx%d" % inputs["output_frame"])
        try:
            native = output_at(cs, models, res, *inputs["output_frame"])
        except DatasetError as exc:  # e.g. an imported set without registration: the working frame only
            native = str(exc)
        return save_stylize_result({**inputs, "notes": notes}, cs, models, res, native)

    def show(self, job, output):
        store = job.seams.store
        job.seams.show(result_frame(store, output["folder"], job._inputs["bit_depth"], output.pop("projector"),
                                    output["summary"]))


def result_notes(summary: dict) -> list[str]:
    """What the user should read about a result: the prompt's and the models' notes, then the backend's
    (a weak prompt match, a fallback), each once (a result of several lists the backend's among its own)."""
    return list(dict.fromkeys(list(summary.get("notes", [])) + list(summary.get("lgst", {}).get("notes", []))))

def _native_summary(native) -> dict:
    if native is None:
        return {"frame": "working frame"}
    if isinstance(native, str):
        return {"not_made": native}
    h, w = native.target.shape[-2:]
    return {"frame": [w, h], "seconds": round(native.seconds, 2), "tile": native.tile}


def reach_line(truth: dict | None) -> str:
    """'; surface shows 34% -> 88% of the look' for the panel's one result line ('' without figures)."""
    if not truth:
        return ""
    before, after = truth["before_psa"], truth.get("after_psa")
    shown = f"{before['reachability']:.0%}" + (f" -> {after['reachability']:.0%}" if after else "")
    return f"; surface shows {shown} of the look"


def _tone_field_summary(res) -> dict | None:
    field = getattr(getattr(res, "backend", None), "field", None)
    return field.summary() if field is not None and res.with_psa is not None else None



def save_stylize_result(job: dict, cs, models, res, native=None) -> dict:
    """Write the result folder (worker-thread safe: files only) and return a short summary.

    native: the output at the output size (pipeline.output_at), None at the working frame, or why
    it could not be made."""
    chosen = res.with_psa or res.without
    maps = loss_maps(chosen.target, models)
    problem = (maps["cs"] + maps["ps"]).numpy()
    images = {"target": as_image(chosen.target), "projector": as_image(chosen.projector_image),
              "simulated": as_image(chosen.simulated), "compensability": heat_overlay(cs.cam_white, problem),
              "target_nopsa": as_image(res.without.target), "projector_nopsa": as_image(res.without.projector_image),
              "simulated_nopsa": as_image(res.without.simulated)}
    if native is not None and not isinstance(native, str):
        images.update(target_native=as_image(native.target), projector_native=as_image(native.projector_image))
    summary = {"prompt": job["prompt"], "notes": job.get("notes", []), "backend": job["backend"], "seed": job["seed"],
               "style_mix_override": job.get("mix"), "lgst": res.describe, "psa": job["psa"],
               "psa_settings": res.settings.to_dict(), "dark_outside": res.dark_outside,
               "native_output": _native_summary(native), "capture": job["capture"],
               "device": res.device,  # which device ran the look, PSA and the compensation
               # what the surface can show of the look, before and after PSA, and the artist's message
               "surface_reach": res.truth,
               "tone_field": _tone_field_summary(res),
               "fingerprint": cs.meta.get("fingerprint"),
               "compensator": models.choice.to_dict() if getattr(models, "choice", None) else None,
               # which models made the look: the first look (the classical model), or Train's
               "models": first_look.first_look_record() if getattr(models, "first_look", False)
               else first_look.trained_record(getattr(models, "choice", None)),
               "metrics": {"simulated_psnr": metrics.psnr(images["simulated"], images["target"]),
                           "simulated_psnr_nopsa": metrics.psnr(images["simulated_nopsa"], images["target_nopsa"]),
                           "psa_iterations": res.with_psa.iterations if res.with_psa else 0,
                           "psa_warm_start_steps": res.with_psa.warm_start_steps if res.with_psa else 0,
                           "psa_seconds": round(res.with_psa.seconds, 2) if res.with_psa else 0.0,
                           "problem_area_fraction": float((problem > 1e-3).mean()),
                           **({"style_retention_" + k: v for k, v in res.style_retention().items()})},
               "created": datetime.datetime.now().isoformat(timespec="seconds")}
    if res.truth and res.truth.get("message"):
        summary["notes"] = list(summary["notes"]) + [res.truth["message"]]
    styles = ", ".join(f"{n} {w:.2f}" for n, w in res.describe.get("styles", [])[:3])
    # what the prompt was read as (medium; colours; mood | a word that matched nothing), then the figure
    understood, _, missed = (res.describe.get("understood_line") or styles or job["backend"]).partition(" | ")
    # a first look's simulator is the inverse of its compensator: its figure shows only what clipping loses, and
    # is no measure of the look on the rig (the line says whose simulation it is)
    sim_by = " by the classical model" if summary["models"]["first_look"] else ""
    line = f"{understood}; simulated{sim_by} {summary['metrics']['simulated_psnr']:.1f} dB"
    line += reach_line(res.truth)
    if summary["compensator"]:
        line += f"; compensated by {summary['compensator']['chosen']}"
    if summary["models"]["first_look"]:
        line += f"; {first_look.FIRST_LOOK_LINE}"
    if missed:  # last: the panel shows what follows " | " on a line of its own
        line += f" | {missed}"
    summary["summary_line"] = line  # Refine on the rig adds its figures to it
    files = look_state_files(chosen.state)
    if res.describe.get("geometry"):  # the object's geometry the look was shaped by: a show's look is shaped as this
        files.update(geometry_files(job.get("geometry")))
    folder = str(write_new_result(job["results"], job["name"], images, summary, files))
    # the finest projector image as the folder now holds it (read_output_image's values), for the sinks
    projector = as_stored(images.get("projector_native", images["projector"]))
    return {"folder": folder, "summary": summary, "summary_line": line, "projector": projector}


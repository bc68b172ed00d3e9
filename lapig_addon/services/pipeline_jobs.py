"""Jobs of the artist's path after the capture: train the models, generate the look (Render: services/render_job).

Training and generation run their torch work on a worker thread (jobs.WorkerJob).
"""
from __future__ import annotations

import datetime
import os
import shutil
import time

import numpy as np

from ...lapig_core.common import compute_device, metrics
from ...lapig_core.capture.dataset import (DatasetError, frame_size_of, load_capture_set, read_setup_json,
                                           resolve_setup, setup_dir_of)
from ...lapig_core.lgst import DEFAULT_BACKEND, backend_class
from ...lapig_core.optics.working_frame import WorkingFrameError, check_aspect
from ...lapig_core.lgst.prompt_mapping import validate_prompt
from ...lapig_core.native_output import OutputSizeError, output_frame, tile_for
from ...lapig_core.photometric import choice as compensator_choice
from ...lapig_core.pipeline import (as_image, first_look_models, output_at, saved_models_problem, stylize,
                                    surface_models, train_models)
from ...lapig_core.photometric import first_look
from ...lapig_core.psa.adaptation import PSASettings, loss_maps
from ...lapig_core.export.result_files import as_stored, folder_name, heat_overlay, write_new_result
from . import panel_state, warmup
from .capture_job import CaptureError
from .export_result import result_frame
from .jobs import THREAD_PREFIX, WorkerJob
from .pipeline_errors import PipelineError, hold_capture  # noqa: F401 (their home for the jobs that import them here)
from .ports import Seams
from .projection import project_and_capture, projection_steps
from .state import GenerateRequest, SceneState


def current_capture(state: SceneState, explicit: str | None = None) -> str:
    """The capture folder to work on, checked to exist, to match the rig as it is now and to cover the
    projector's frame (an imported data set of another aspect cannot): `explicit` (a pipeline naming
    one with --capture), else the scene's."""
    if explicit:
        folder = named_capture(state, explicit)
    else:
        blocker = panel_state.capture_blocker(state)
        if blocker:
            raise PipelineError(blocker)
        folder = state.capture_dir
    try:
        check_aspect(frame_size_of(folder), state.rig.projector_size, "the capture",
                     advice="capture this projector's surface, or set its resolution to the capture's aspect")
    except (DatasetError, WorkingFrameError) as exc:
        raise PipelineError(str(exc)) from None
    return folder


def named_capture(state: SceneState, folder: str) -> str:
    """A capture folder named explicitly, checked to be a data set this rig made as it is now (or one
    captured elsewhere, which is tied to no rig)."""
    blocker = panel_state.rig_blocker(state.rig)
    if blocker:
        raise PipelineError(blocker)
    try:
        meta = read_setup_json(resolve_setup(folder).setup_json)
    except (DatasetError, OSError, ValueError) as exc:
        raise PipelineError(f"--capture {folder}: {exc}") from None
    made_by = meta.get("fingerprint") or ""
    if made_by and state.rig.fingerprint and made_by != state.rig.fingerprint:
        raise PipelineError(f"{folder} was captured with the rig as it was then; the projector, camera or object "
                            f"changed since: capture again, or use the .blend it was captured with")
    return str(folder)


def capture_record(folder: str) -> tuple[str, str]:
    """(fingerprint, light transport label) a capture folder's setup.json records, for the scene store."""
    meta = read_setup_json(resolve_setup(folder).setup_json)
    return meta.get("fingerprint") or "", (meta.get("transport") or {}).get("label", "")


def capture_first_look(folder: str):
    """The capture's first look (photometric/first_look), or None where Capture fitted none for it."""
    meta = read_setup_json(resolve_setup(folder).setup_json)
    return first_look.load_first_look(setup_dir_of(resolve_setup(folder)), meta.get("fingerprint"))


def _setup_stamp(folder: str) -> tuple:
    """setup.json's identity on disk: a new capture swaps in a new file."""
    st = os.stat(resolve_setup(folder).setup_json)
    return st.st_ino, st.st_mtime_ns, st.st_size


def _why_not_measured(cs, verification, devices) -> str:
    """Why the rig cannot measure the choice, for the models line: a data set this rig did not capture
    (imported, or made on another rig); '' otherwise."""
    if verification is None or devices is None:
        return ""  # nothing to measure (the capture's test count), or no rig: PCNet's choice, as its line says
    if cs.meta.get("fingerprint") != devices.rig_identity().key():
        made_on = cs.meta.get("device") or "another rig"
        return f"not measured on the rig: the capture was made on '{made_on}', not on this rig"
    return ""


def device_choice(store, explicit: str | None) -> str:
    """'auto' or 'cpu': the command's, else the store's (the preference; read in prepare(), on the main thread)."""
    choice = explicit or store.compute_device()
    if choice not in compute_device.CHOICES:
        raise PipelineError(f"unknown device '{choice}': use {' or '.join(compute_device.CHOICES)}")
    return choice


class TrainModelsJob(WorkerJob):
    """Fine-tune the networks (worker thread), then choose the compensator by measurement: the rig renders
    both compensations of the held-back images, as it rendered the capture (main thread, bpy)."""

    title = "LAPIG training"
    TRAIN_SHARE = 0.9  # of the progress bar; the rest is the renders of the choice
    rig_in_use = None  # a Train in the background: a callable saying why it may not open the rig now ('' if it may)
    # a Train in the background: a main-thread device (Cycles' studio, a scene of its own that changes the
    # projector's image) is opened and closed within each render's step, so the artist's undo, save or edit
    # between two steps never meets it
    device_per_render = False
    choice_skipped = ""  # why the rig did not measure the choice, for the models line

    def __init__(self, seams: Seams, iterations: int | None = None, capture: str | None = None,
                 device: str | None = None):
        """iterations: fine-tuning iterations per network (None: the standard recipe); capture: a capture
        folder named explicitly (None: the scene's), recorded as the scene's when the models are; device:
        'auto' or 'cpu' (None: the store's, i.e. the add-on's preference)."""
        super().__init__()
        self.seams, self.iterations, self.capture, self.device = seams, iterations, capture, device

    def prepare(self):
        state = self.seams.store.read()
        if state.rig.projector_count > 1:  # their joint model is fitted at the capture: no networks for them
            raise PipelineError(panel_state.train_blocker(state))
        folder = current_capture(state, self.capture)
        self._stamp = _setup_stamp(folder)  # what a pause checks on resume: the same capture
        self._device_choice = device_choice(self.seams.store, self.device)
        return folder

    def hold(self, folder):
        return hold_capture(folder, self.title)

    def work(self, folder, report, cancel_event):
        cs = load_capture_set(folder)
        had_first_look = capture_first_look(folder) is not None
        device = compute_device.resolve(self._device_choice)
        trained = train_models(cs, on_progress=report, cancel_event=cancel_event, iterations=self.iterations,
                               device=device)
        # both compensations of the held-back images, here on the worker: CompenNeSt's forward pass would
        # otherwise hold Blender's main thread, where the rendered choice's steps run with Cycles
        phases = trained["phases"]
        with phases.timing("verification"):
            verification = compensator_choice.verification(cs, trained["CompenNeSt"], trained["classical"])
        return {"fingerprint": cs.meta.get("fingerprint", ""), "seconds": trained["seconds"], "folder": folder,
                "phases": phases,
                "choice": trained["choice"].line(), "capture_set": cs, "trained": trained,
                "verification": verification, "had_first_look": had_first_look, "device": trained["device"],
                "trained_on": compute_device.short_name(device), "threads": trained.get("threads", {})}

    def finish(self, output):
        store = self.seams.store
        if self.capture:  # the named capture becomes the scene's, so the models belong to it
            store.record_capture(output["folder"], *capture_record(output["folder"]))
        # PCNet's choice, saved with the models: it stands if the renders below cannot run or are cancelled
        store.record_models(output["fingerprint"], self._models_line(output, output["trained"]["choice"]))
        return output

    @property
    def in_use_note(self) -> str:
        """What a Generate uses meanwhile, for the panel's line on a Train in the background."""
        if self.result is None:  # the networks are not saved yet
            return "first look in use until it finishes"
        return "networks saved; choosing their compensator on the rig"

    @staticmethod
    def _models_line(out, chosen) -> str:
        """The models step's line: how long, the choice, and what it means for the capture's first look."""
        on = f" on {out['trained_on']}" if out.get("trained_on") else ""
        line = f"Fine-tuned in {out['seconds']:.0f} s{on}; {out['choice']}"
        note = first_look.after_train_note(chosen) if out.get("had_first_look") else ""
        return f"{line}; {note}" if note else line

    def steps(self):
        for progress, message in super().steps():
            yield self.TRAIN_SHARE * progress, ("models trained" if progress >= 1.0 else message)
        out = self.result
        t0 = time.perf_counter()
        chosen = yield from self._render_choice(out["capture_set"], out["trained"], out["folder"], out["verification"])
        out["seconds"] += time.perf_counter() - t0
        out["phases"].add("rendered_choice", time.perf_counter() - t0)
        if chosen is not None:
            out["choice"] = chosen.line()
            self.seams.store.record_models(out["fingerprint"], self._models_line(out, chosen))
        elif self.choice_skipped:
            out["choice"] = f"{out['choice']} ({self.choice_skipped})"
            self.seams.store.record_models(out["fingerprint"], self._models_line(out, out["trained"]["choice"]))
        # the result goes to the operator and the CLI: not the capture's arrays nor the networks
        self.result = {k: v for k, v in out.items() if k not in ("capture_set", "trained", "verification")}

    def _render_choice(self, cs, trained, folder, v):
        """Render both compensations of the held-back images (``v``, computed on the worker) and save the better
        one as the setup's choice; None when there are no held-back images to measure on. A pause (a job in the background) stops
        between renders: the device closes and the lock goes, and the renders go on from there on resume."""
        devices = self.seams.devices
        self.choice_skipped = _why_not_measured(cs, v, devices)
        if v is None or devices is None or self.choice_skipped:  # PCNet's choice stands
            return None
        images, share = v.images, self.TRAIN_SHARE
        count, captured = len(images), []

        def measure(first):
            if self.device_per_render and devices.main_thread:  # opened, rendered and closed in this one step
                one = project_and_capture(devices, folder, images[first:first + 1], seed=first, chunk=1)[0]
                done = (first + 1) / count
                yield share + (1 - share) * 0.99 * done, \
                    f"measuring both compensations on the rig: {first + 1}/{count} captured"
                return list(one)
            steps = projection_steps(devices, folder, images[first:], chunk=1, stop=lambda: self.pause_requested)
            while True:
                try:
                    part = next(steps)
                except StopIteration as end:
                    return list(end.value[0])
                done = (first + part * (count - first)) / count
                yield share + (1 - share) * 0.99 * done, \
                    f"measuring both compensations on the rig: {round(done * count)}/{count} captured"

        try:
            while len(captured) < count:
                progress = share + (1 - share) * 0.99 * len(captured) / count
                yield from self.pause_point(progress)
                devices = self.seams.devices  # as the job's owner has it now (a background job's: after an undo)
                in_use = self.rig_in_use() if self.rig_in_use is not None else ""
                if in_use:  # the artist's live window or camera view: the rig is theirs until closed
                    time.sleep(self.poll_timeout)
                    yield progress, f"waiting for the rig: {in_use}"
                    continue
                # no capture may replace the models while this runs
                held = yield from self._hold_when_free(folder, progress)
                if self.pause_requested:  # asked while the lock was taken: pause before opening the device
                    held.release()
                    continue
                first = len(captured)
                # the lock goes once the device is closed, on the camera's thread after a cancel
                captured += yield from self.drive(lambda: measure(first), devices.main_thread, holding=held)
            chosen = compensator_choice.choose_by_captures(v, np.stack(captured).astype(np.float32),
                                                           rig=devices.rig_identity().name)
            compensator_choice.save_choice(setup_dir_of(cs) / "models", chosen, trained["classical"])
        except CaptureError as exc:
            raise PipelineError(f"{exc} (the models are trained; {trained['choice'].line()})") from None
        return chosen

    def _hold_when_free(self, folder, progress):
        """The capture's lock, once the job that paused this one has let go of it; then the capture checked to
        be the one trained on (WorkerJob.retake)."""
        retake = self.retake(folder)
        while True:
            try:
                next(retake)
            except StopIteration as done:
                return done.value
            time.sleep(self.poll_timeout)
            yield progress, "waiting for the capture's folder"

    def resumed(self, folder):
        if _setup_stamp(folder) != self._stamp:
            raise PipelineError("the capture was replaced while the training was paused: train again")


def check_style_images(specs) -> None:
    """Read every style image once: missing, not an image, too small -> PipelineError with its line.
    What was converted (grayscale, resized) the backend notes in the result."""
    from ...lapig_core.common.style_image import StyleImageError, load_style_image, parse_style_image_spec

    for spec in specs:
        try:
            load_style_image(parse_style_image_spec(spec)[0])
        except StyleImageError as exc:
            raise PipelineError(str(exc)) from None


def style_name(specs) -> str:
    """'style_<first image's name>' for the result folder of a look from style images alone."""
    if not specs:
        return ""
    from ...lapig_core.common.style_image import parse_style_image_spec

    return "style " + os.path.splitext(os.path.basename(parse_style_image_spec(specs[0])[0]))[0]


def psa_settings_from(request: GenerateRequest) -> PSASettings:
    return PSASettings(adaptation=request.adaptation, seed=request.seed)


def look_geometry(store, capture: str, backend: str, mix: str, prompt: str):
    """What the looks of the world follow (on the main thread: Blender's ray casts): the object as the projector
    sees it at the capture's working frame, or "capture" (no 3D model: the captured surface stands in); None where
    the look reads no geometry (a style mix, another backend)."""
    if mix or backend != DEFAULT_BACKEND or not prompt:
        return None
    reader = getattr(store, "look_geometry", None)
    if reader is None:
        return "capture"
    try:
        geometry = reader(*frame_size_of(capture))
    except ValueError:  # the rays land on nothing the scene can render: the captured surface then
        geometry = None
    return geometry if geometry is not None else "capture"


def camera_look_geometry(store, backend: str, mix: str, prompt: str, long_side: int):
    """A rig of several projectors: the object as its camera sees it (on the main thread), for a look of the world
    made in the camera's space; None where the look reads none, or the store has no 3D model to cast."""
    reader = getattr(store, "camera_look_geometry", None)
    if mix or backend != DEFAULT_BACKEND or not prompt or reader is None:
        return None
    try:
        return reader(long_side)
    except ValueError:  # the rays land on nothing the scene can render
        return None


class GenerateJob(WorkerJob):
    """Prompt -> stylized target (with and without PSA) -> compensated projector image."""

    title = "LAPIG generate"

    def __init__(self, seams: Seams, request: GenerateRequest, iterations: int | None = None, result_root=None,
                 capture: str | None = None, device: str | None = None):
        """iterations: as TrainModelsJob's, for models trained on the way; capture, device: as TrainModelsJob's."""
        super().__init__()
        self.seams, self.request, self.iterations = seams, request, iterations
        self.result_root, self.capture, self.device = result_root, capture, device

    def prepare(self):
        r = self.request
        store = self.seams.store
        state = store.read()
        folder = current_capture(state, self.capture)
        try:  # refused now, not after PSA: an output over native or over the memory budget
            output = output_frame(r.output_size, *state.rig.projector_size)
            tile_for(*output)
        except OutputSizeError as exc:
            raise PipelineError(str(exc)) from None
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
        geometry = look_geometry(store, folder, backend, mix, prompt)
        return {"capture": folder, "prompt": prompt, "notes": notes, "backend": backend, "geometry": geometry,
                "backend_options": r.backend_options(), "mix": mix or None, "psa": r.psa, "seed": r.seed,
                "dark_outside": r.dark_outside, "output_frame": output,
                "settings": psa_settings_from(r),
                "results": self.result_root or os.path.join(store.data_root(), "results"),
                "bit_depth": store.export_settings().bit_depth,
                "device": device_choice(store, self.device),
                "name": folder_name(prompt or mix or style_name(r.style_images), datetime.datetime.now())}

    def hold(self, job):
        return hold_capture(job["capture"], self.title)

    _training = None  # the TrainModelsJob run first when this capture has no models yet

    def steps(self):
        """Models first when there are none for this capture: Train's job, whose choice is measured by
        rendering (on the worker thread, surface_models could only ask PCNet)."""
        if self._inputs is self._NOT_PREPARED:
            self._inputs = self.prepare()
        yield from self._read_prompt()  # a prompt of which nothing is understood: refused before any training
        share = 0.0
        problem, self._inputs["saved"] = saved_models_problem(self._inputs["capture"])  # each checkpoint read once
        if problem == "":  # never trained: the capture's first look, where Capture fitted one, works at once
            self._inputs["first_look"] = capture_first_look(self._inputs["capture"])
            if self._inputs["first_look"] is not None:
                problem = None
        if problem is not None:
            if problem:  # damaged (the same note as surface_models gives)
                self._inputs["notes"].append(f"the saved models could not be used ({problem}): fine-tuned them "
                                             f"again and saved over them")
            share = 0.5
            self._training = TrainModelsJob(self.seams, self.iterations, self.capture, self.device)
            self._training.poll_timeout = self.poll_timeout
            self._training.check()
            inner = self._training.steps()
            try:
                for progress, message in inner:
                    yield share * progress, f"training: {message}"
            finally:
                inner.close()
        for progress, message in super().steps():
            yield share + (1.0 - share) * progress, message

    def _read_prompt(self):
        """Plan the prompt on a thread (the text model may load: Blender's UI keeps its turns) and raise its one
        line when nothing of it is understood ('no look matched ...'), so a refused prompt changes nothing."""
        import threading

        job = self._inputs
        if job["mix"] or job["backend"] != DEFAULT_BACKEND or not job["prompt"]:
            return
        from ...lapig_core.lgst.not_understood import check_prompt

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
        super().stop()  # closes steps(), and with it the training's, which tells its worker to stop
        if self._training is not None:
            self._training.stop()  # then waits for that worker

    def work(self, job, report, cancel_event):
        if warmup.warmup_state()["running"]:  # the session's warm-up is loading the models: not twice
            report(0.01, "loading the text and style models")
            while not warmup.wait_for_warmup(0.1):
                if cancel_event.is_set():
                    return None
        saved, look = job.get("saved"), job.get("first_look")
        # with the models saved and their choice made (or a first look): the references, the valid map and the
        # metadata only
        cs = load_capture_set(job["capture"], pairs=look is None and (saved is None or saved.choice is None))
        report(0.02, "loading the models")
        notes = list(job["notes"])
        device = compute_device.resolve(job["device"])
        if look is not None:
            models = first_look_models(cs, look.classical, device=device)
        else:
            models = surface_models(cs, on_progress=lambda p, m: report(0.05 + 0.45 * p, m),
                                    cancel_event=cancel_event, iterations=self.iterations, notes=notes, saved=saved,
                                    device=device)
        if cancel_event.is_set():
            return None
        report(0.5, "stylizing")
        res = stylize(cs, models, job["prompt"], backend=job["backend"], seed=job["seed"], mix=job["mix"],
                      psa=job["psa"], settings=job["settings"], cancel_event=cancel_event,
                      on_progress=lambda p, m: report(0.55 + 0.4 * p, m), backend_options=job["backend_options"],
                      dark_outside=job["dark_outside"], geometry=job.get("geometry"))
        if cancel_event.is_set():  # cancelled: write nothing, the scene keeps its last result
            return None
        report(0.95, "the look and its compensation at %dx%d" % job["output_frame"])
        try:
            native = output_at(cs, models, res, *job["output_frame"])
        except DatasetError as exc:  # e.g. an imported set without registration: the working frame only
            native = str(exc)
        return save_stylize_result({**job, "notes": notes}, cs, models, res, native)

    def finish(self, output):
        if output is None:
            return None
        store = self.seams.store
        blocker = panel_state.rig_blocker(store.read().rig)
        if blocker:  # the rig was deleted while the work ran: keep no result that no scene refers to
            shutil.rmtree(output["folder"], ignore_errors=True)
            raise PipelineError(f"{blocker}: the result was not kept")
        if self.capture and self._training is None:  # the named capture becomes the scene's (Train's did)
            store.record_capture(self._inputs["capture"], *capture_record(self._inputs["capture"]))
        compensator = output["summary"].get("compensator") or {}
        if not output["summary"]["models"]["first_look"]:  # a first look trained nothing: the step stays as it is
            store.record_models(output["summary"].get("fingerprint") or "",  # trained on the way
                                f"Fine-tuned; {compensator['line']}" if compensator.get("line") else None)
        reach = output["summary"].get("surface_reach") or {}
        store.record_result(output["folder"], output["summary_line"], reach.get("message", ""))
        # the stored image, from memory: the sinks show the pixels Export will write
        frame = result_frame(store, output["folder"], self._inputs["bit_depth"], output.pop("projector"),
                             output["summary"])
        self.seams.show(frame)
        return output


def result_notes(summary: dict) -> list[str]:
    """What the user should read about a result: the prompt's and the models' notes, then the backend's
    (a weak prompt match, a fallback)."""
    return list(summary.get("notes", [])) + list(summary.get("lgst", {}).get("notes", []))


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


def _look_state_file(chosen, geometry=None) -> dict:
    """The look's theta and tone field as the result keeps them (look_state.npz): a show makes this very look
    again from it, not from the prompt and PSA run once more (lapig_core/show/look_state); and the object's
    geometry the look was shaped by (look_geometry.npz), so the show's look is shaped as this one."""
    from ...lapig_core.lgst.world.geometry import GEOMETRY_FILE, LookGeometry, geometry_bytes
    from ...lapig_core.show.look_state import LOOK_STATE_FILE, look_state_bytes

    files = {LOOK_STATE_FILE: look_state_bytes(chosen.state)} if chosen.state else {}
    if isinstance(geometry, LookGeometry):  # "capture" is not kept: the captured surface gives it again
        files[GEOMETRY_FILE] = geometry_bytes(geometry)
    return files


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
    folder = str(write_new_result(job["results"], job["name"], images, summary,
                                  _look_state_file(chosen, job.get("geometry") if res.describe.get("geometry") else None)))
    # the finest projector image as the folder now holds it (read_output_image's values), for the sinks
    projector = as_stored(images.get("projector_native", images["projector"]))
    return {"folder": folder, "summary": summary, "summary_line": line, "projector": projector}


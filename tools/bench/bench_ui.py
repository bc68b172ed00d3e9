"""`python -m lapig_addon bench ui --json`: how long Blender's main thread stalls while PSA runs, and while
the real rig's projector window opens from the panel.

A PSA job runs in the job engine exactly as the Generate operator runs it (jobs.WorkerJob: torch on
a worker thread, poll_timeout 0 as under the modal timer). The main thread plays Blender's event
loop: it wakes every 10 ms, and every 50 ms it steps the job like the modal timer does. A stall is
the lateness of a wake-up plus the time a step takes; the figure is the worst one over the job.

The projector window (`--parts window`): Show on Projector's job, made by the operator's make_job on a scene
with a real rig and a result at the display's size, stepped through the job slots as its modal timer steps it;
the window is a real helper process (lapig_core/rig/projector_window) on SDL's dummy video driver (no display
here: the helper starts, opens and shows as on the projector's computer, drawing nowhere). Then the panel's
Close. Beside it, the old path: the window opened and closed on the main thread (live_output.open_live).

The panels (`--parts panel`, no timing, no torch needed): `cut_lines`, the lines Blender would clip when the
LAPIG panels are drawn in several scene states at sidebar widths of 250, 350 and 500 px (tools/bench/panel_cuts).

The torch install (`--parts install`, no torch needed): `install_to_import_seconds`, from pressing the preferences'
Install torch to a fresh Python importing the torch installed (the job's own last check), with pip from a local
package index on 127.0.0.1 (tools/bench/fake_torch_index). The wheel is a FAKE torch of a few kB: the figure is
the button's own cost (pip's start, resolving, the check's Python), not a download of PyTorch's 200 MB to 3 GB;
the job runs as under the preferences' timer (poll_timeout 0), so its main-thread stall comes with it.
"""
from __future__ import annotations

import os
import platform
import shutil
import sys
import tempfile
import threading
import time
from types import SimpleNamespace

import numpy as np

from ...lapig_addon.services.jobs import WorkerJob

PARTS = ("psa", "window", "panel", "install")


class WarmupWatch:
    """The session's warm-up (services/warmup) seen as a job by drive_like_blender: the event loop runs while
    the models load on their worker thread."""

    message = "warm-up"
    state = "DONE"

    @property
    def finished(self):
        from ...lapig_addon.services import warmup

        return not warmup.warmup_state()["running"]

    def step(self):
        return not self.finished


class PSAJob(WorkerJob):
    title = "LAPIG PSA (benchmark)"

    def __init__(self, cs, prompt, backend, seed=0):
        super().__init__()
        self.cs, self.prompt, self.backend, self.seed = cs, prompt, backend, seed

    def work(self, inputs, report, cancel_event):
        from ...lapig_core.lgst import get_backend
        from ...lapig_core.photometric import checkpoints
        from ...lapig_core.photometric.surface_models import SurfaceModels
        from ...lapig_core.photometric.training_data import SurfaceTensors
        from ...lapig_core.psa.adaptation import PSASettings, run_psa

        surf = SurfaceTensors.from_capture_set(self.cs)
        comp, _ = checkpoints.load_pretrained("CompenNeSt", "compensation")
        sim, _ = checkpoints.load_pretrained("PCNet", "simulation")
        models = SurfaceModels(comp, sim, surf.s, surf.i_min, surf.i_max)
        lgst = get_backend(self.backend)
        lgst.prepare(surf.i_max, self.prompt, seed=self.seed)
        return run_psa(lgst, models, PSASettings(seed=self.seed, stop_ratio=0.0, max_iterations=20),
                       on_progress=report, cancel_event=cancel_event)


def drive_like_blender(job, tick=0.010, timer=0.050) -> dict:
    job.poll_timeout = 0
    stalls, steps, where = [], [], []
    next_timer = time.perf_counter() + timer
    expected = time.perf_counter() + tick
    while not job.finished:
        time.sleep(max(0.0, expected - time.perf_counter()))
        now = time.perf_counter()
        stalls.append(now - expected)  # the event loop woke late: the UI could not redraw
        where.append(job.message)
        if now >= next_timer:
            t = time.perf_counter()
            job.step()
            steps.append(time.perf_counter() - t)
            next_timer = now + timer
        expected = time.perf_counter() + tick
    stalls = stalls or [0.0]
    return {"max_wakeup_lateness_ms": 1000 * max(stalls), "max_step_ms": 1000 * max(steps, default=0.0),
            "p99_wakeup_lateness_ms": 1000 * float(np.percentile(stalls, 99)),
            "steps": len(steps), "state": job.state,
            "worst_stalls": [(round(1000 * stalls[i], 1), where[i]) for i in np.argsort(stalls)[-3:][::-1]]}


def run(args) -> dict:
    t0 = time.perf_counter()
    parts = [p.strip() for p in (getattr(args, "parts", "") or ",".join(PARTS)).split(",") if p.strip()]
    unknown = sorted(set(parts) - set(PARTS))
    if unknown:
        raise ValueError(f"bench ui --parts: unknown {', '.join(unknown)}: use {', '.join(PARTS)}")
    summary = psa_stalls(args) if "psa" in parts else {}
    if "window" in parts:
        window = projector_window_stalls(os.path.abspath(args.out))
        summary["max_main_thread_stall_ms_projector_window"] = window["max_main_thread_stall_ms"]
        summary["projector_window"] = window
    if "panel" in parts:
        from .panel_cuts import cut_lines

        summary.update(cut_lines(os.path.abspath(args.out)))
    if "install" in parts:
        summary.update(install_to_import(os.path.abspath(args.out)))
    return {**summary, "bench_total_s": round(time.perf_counter() - t0, 1), "loadavg": list(os.getloadavg()),
            "machine": platform.processor() or platform.machine()}


def psa_stalls(args) -> dict:
    import torch

    from .. import synthetic_setups as syn

    spec = syn.BENCH_SETUPS[0]
    data = os.path.abspath(args.data)
    syn.render_synthetic_setups([spec], data, train=125, test=30, seed=500, skip_existing=True)
    cs = syn.load_setup(data, spec.name)
    from ...lapig_core.common.embedding_mode import set_embedding_mode
    from ...lapig_core.lgst import prompt_mapping

    # as in Blender's UI (addon.register): the prompt model runs in a helper process
    set_embedding_mode("subprocess")
    warmed = None
    if getattr(args, "warmup", True):  # as the add-on does when it is first used (blender/warm_start)
        from ...lapig_addon.services import warmup

        warmup.start_warmup(args.backend)
        warmed = drive_like_blender(WarmupWatch())
        warmed["seconds"] = warmup.warmup_state()["seconds"]
        warmed["error"] = warmup.warmup_state()["error"]
    runs = []
    # twice: the first job of a session also loads the text and style models, the second finds them loaded
    for prompt in ("Make it a stained glass artwork", "Render it in the style of a Van Gogh oil painting"):
        job = PSAJob(cs, prompt, args.backend, args.seed)
        figures = drive_like_blender(job)
        if job.state != "DONE":
            raise RuntimeError(f"the PSA job ended {job.state}: {job.message}")
        figures["max_main_thread_stall_ms"] = max(figures["max_wakeup_lateness_ms"], figures["max_step_ms"])
        runs.append((figures, job.result))
    prompt_mapping.shutdown_embedding_process()
    set_embedding_mode("inprocess")
    (cold, result), (warm, _) = runs
    return {"max_main_thread_stall_ms": round(cold["max_main_thread_stall_ms"], 2),
            "max_main_thread_stall_ms_warm": round(warm["max_main_thread_stall_ms"], 2),
            **{k: round(v, 2) if isinstance(v, float) else v for k, v in cold.items() if k != "max_main_thread_stall_ms"},
            "warm_worst_stalls": warm["worst_stalls"], "p99_wakeup_lateness_ms_warm": round(warm["p99_wakeup_lateness_ms"], 2),
            "warmup": None if warmed is None else {
                "max_main_thread_stall_ms": round(max(warmed["max_wakeup_lateness_ms"], warmed["max_step_ms"]), 2),
                "p99_wakeup_lateness_ms": round(warmed["p99_wakeup_lateness_ms"], 2), "seconds": warmed["seconds"],
                "worst_stalls": warmed["worst_stalls"], "error": warmed["error"]},
            "psa_iterations": result.iterations, "psa_seconds": round(result.seconds, 2),
            "torch_threads": torch.get_num_threads()}


# ------------------------------------------------------------------------ the projector window, from the panel

class ForegroundSlot:
    """A job in the foreground slot, stepped as JobRunnerMixin's modal timer steps it (once the background job,
    if any, has paused)."""

    def __init__(self, slots, job):
        self.slots, self.job = slots, job

    @property
    def message(self):
        return self.job.message

    @property
    def finished(self):
        return self.job.finished

    @property
    def state(self):
        return self.job.state

    def step(self):
        if self.slots.foreground_may_step():
            self.job.step()
        return not self.job.finished


class ThreadWatch:
    """A worker thread seen as a job by drive_like_blender: the event loop runs until it ends."""

    state = "DONE"

    def __init__(self, thread, message):
        self.thread, self.message = thread, message

    @property
    def finished(self):
        return self.thread is None or not self.thread.is_alive()

    def step(self):
        return not self.finished


def _stall(figures: dict) -> float:
    return round(max(figures["max_wakeup_lateness_ms"], figures["max_step_ms"]), 2)


def _real_rig_scene(folder: str, display: dict):
    """A demo scene with a real rig on `display` (camera 0, never opened here) and a result at its size."""
    import bpy

    from ...lapig_addon.blender import rig, scene_state
    from ...lapig_addon.cli import headless
    from ...lapig_core.export.result_files import write_result

    scene, projector, camera, target = headless.build_demo_setup("panel", "sakura", folder=folder,
                                                                 camera_resolution=(160, 120))
    w, h = display["width"], display["height"]
    projector.lapig_projector.resolution_x, projector.lapig_projector.resolution_y = w, h
    rig.add_rig(bpy.context, target, projector, camera)
    s = scene.lapig
    s.rig_kind, s.real.display, s.real.camera, s.real.camera_source = "REAL", str(display["index"]), "0", "DEVICE"
    ramp = np.broadcast_to(np.linspace(0, 1, w, dtype=np.float32)[None, :, None], (h, w, 3)).copy()
    result = write_result(os.path.join(folder, "result"), {"projector": ramp, "target": ramp}, {"prompt": "bench"})
    scene_state.record_result(scene, str(result), "bench")
    return scene


def _closing_thread():
    return next((t for t in threading.enumerate() if t.name == "LAPIG: closing the projector window"), None)


def projector_window_stalls(out: str) -> dict:
    """Show on Projector as the panel runs it, then its Close, and the old synchronous open and close."""
    from ...lapig_addon.blender import live_devices
    from ...lapig_addon.blender.modal_runner import SLOTS
    from ...lapig_addon.rigs import live_output
    from ...lapig_core.rig.projector_window import list_displays
    from ...operators.real_rig_ops import LAPIG_OT_show_on_projector

    before = os.environ.get("SDL_VIDEODRIVER")
    os.environ["SDL_VIDEODRIVER"] = "dummy"  # no display here: SDL's driver that draws nowhere, asked by name
    try:
        display = list_displays()[0]
        scene = _real_rig_scene(os.path.join(out, "window_scene"), display)
        # the operator's path: its make_job, the job in the foreground slot, stepped by the modal timer
        job = LAPIG_OT_show_on_projector.make_job(None, SimpleNamespace(scene=scene))
        job.poll_timeout = 0
        refusal = SLOTS.start_foreground(job)
        if refusal:
            raise RuntimeError(refusal)
        t = time.perf_counter()
        try:
            opening = drive_like_blender(ForegroundSlot(SLOTS, job))
        finally:
            SLOTS.end_foreground(job)
        open_s = time.perf_counter() - t
        if job.state != "DONE":
            raise RuntimeError(f"the projector window's job ended {job.state}: {job.message}")
        live_devices.projector_opened()  # the operator's on_done
        sink = job.result
        shown = {"size": list(sink.window.size), "problem": sink.problem,
                 "helper": {k: sink.window.describe().get(k) for k in ("video_driver", "sdl_version", "helper_pid")}}
        # the panel's Close (the operator's toggle): the helper ends on a worker thread
        t = time.perf_counter()
        live_devices.close_projector(wait=False)
        close_call_ms = 1000 * (time.perf_counter() - t)
        closing = drive_like_blender(ThreadWatch(_closing_thread(), "closing"))
        # the old path, for comparison: the window opened and closed on the main thread
        t = time.perf_counter()
        old = live_output.open_live(str(display["index"]))
        old_open_ms = 1000 * (time.perf_counter() - t)
        old.window.show(live_output.identification_frame(old.window.size))
        t = time.perf_counter()
        live_output.close_live()
        old_close_ms = 1000 * (time.perf_counter() - t)
    finally:
        live_output.close_live()
        if before is None:
            os.environ.pop("SDL_VIDEODRIVER", None)
        else:
            os.environ["SDL_VIDEODRIVER"] = before
    closing_stall = max(_stall(closing), round(close_call_ms, 2))  # the Close call itself runs on the main thread
    return {"max_main_thread_stall_ms": max(_stall(opening), closing_stall),
            "opening": {"max_main_thread_stall_ms": _stall(opening), "seconds": round(open_s, 3),
                        "p99_wakeup_lateness_ms": round(opening["p99_wakeup_lateness_ms"], 2),
                        "steps": opening["steps"], "worst_stalls": opening["worst_stalls"]},
            "closing": {"max_main_thread_stall_ms": closing_stall,
                        "call_ms": round(close_call_ms, 2), "worst_stalls": closing["worst_stalls"]},
            "before_on_main_thread": {"open_ms": round(old_open_ms, 1), "close_ms": round(old_close_ms, 1)},
            "window": shown, "display": {k: display.get(k) for k in ("index", "name", "width", "height")}}


# ------------------------------------------------------------------------ the preferences' Install torch

def install_to_import(out: str) -> dict:
    """Install torch as the button does (CPU build, the index replaced by a local one with a fake torch wheel)
    into a fresh folder, stepped as the preferences' timer steps it: the seconds until torch imports."""
    from ...lapig_addon.services.install import torch_builds
    from ...lapig_addon.services.install.torch_install import TorchInstallJob, plan_from_index
    from .fake_torch_index import LocalIndex, isolated_pip_env, make_fake_torch_wheel

    os.makedirs(out, exist_ok=True)
    folder = tempfile.mkdtemp(prefix="install_", dir=out)
    try:
        wheel = make_fake_torch_wheel(os.path.join(folder, "wheels"))
        env = isolated_pip_env(os.path.join(folder, "pip-cache"))
        with LocalIndex(wheel) as index:
            env[torch_builds.INDEX_ENV] = index.url
            plan = plan_from_index(sys.executable, os.path.join(folder, "modules"), torch_builds.build("CPU"), env)
            plan.activate = False  # this process keeps its own torch (psa imported it): the check's Python imports
            job = TorchInstallJob(plan)
            pressed = time.perf_counter()
            figures = drive_like_blender(job)
            seconds = time.perf_counter() - pressed
        if job.state != "DONE":
            raise RuntimeError(f"the torch install ended {job.state}: {job.message}")
    finally:
        shutil.rmtree(folder, ignore_errors=True)
    return {"install_to_import_seconds": round(seconds, 2),
            "install": {"what": "fake torch wheel from a local index (not PyTorch's download)",
                        "version": job.result.version, "max_main_thread_stall_ms": _stall(figures),
                        "steps": figures["steps"]}}

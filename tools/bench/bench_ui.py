"""`python -m lapig_addon bench ui --json`: how long Blender's main thread stalls while PSA runs.

A PSA job runs in the job engine exactly as the Generate operator runs it (jobs.WorkerJob: torch on
a worker thread, poll_timeout 0 as under the modal timer). The main thread plays Blender's event
loop: it wakes every 10 ms, and every 50 ms it steps the job like the modal timer does. A stall is
the lateness of a wake-up plus the time a step takes; the figure is the worst one over the job.
"""
from __future__ import annotations

import os
import platform
import time

import numpy as np
import torch

from ...lapig_core.photometric import checkpoints
from ...lapig_core.lgst import get_backend
from ...lapig_core.photometric.surface_models import SurfaceModels
from ...lapig_core.psa.adaptation import PSASettings, run_psa
from ...lapig_core.photometric.training_data import SurfaceTensors
from .. import synthetic_setups as syn
from ...lapig_addon.services.jobs import WorkerJob


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
            "torch_threads": torch.get_num_threads(), "bench_total_s": round(time.perf_counter() - t0, 1),
            "machine": platform.processor() or platform.machine()}

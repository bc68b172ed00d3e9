"""`python -m lapig_addon bench train-step --json [--capture DIR] [--iterations N]`: Train's cost per fine-tuning
iteration against a bare step of the same network, and where the rest of Train's worker time goes.

Per network (CompenNeSt with the app's camera-space loss, PCNet with the paper's loss), in one process and
with the same torch threads:
  * the app's iteration: Trainer.steps() as Train runs it (sampling from the capture's pairs, a random crop,
    the recipe's loss, Adam, the bookkeeping), timed between its yields (report_every 1);
  * a bare step: the same network from the same weights, batch 8 of 64 px crops already in memory
    (contiguous, the surface as 8 copies), l1 loss, backward, Adam: nothing else.
The two alternate in blocks of 5, so a machine whose load changes shifts both alike; the figures are medians.
Then Train's fixed work, timed as train_models does it: the classical fit, loading the pretrained weights and
building the pairs, and the choice (fit_and_choose). The rendered choice (Cycles) is not included.
"""
from __future__ import annotations

import os
import statistics
import time

import torch

from ...lapig_core.capture.dataset import load_capture_set
from ...lapig_core.photometric import choice as compensator_choice
from ...lapig_core.photometric.classical import ClassicalModel
from ...lapig_core.photometric.finetune import camera_space_loss, cpu_recipe, start_model
from ...lapig_core.photometric.training import Trainer, apply_model
from ...lapig_core.photometric.training_data import pairs_from_capture_sets

NETWORKS = (("CompenNeSt", "compensation"), ("PCNet", "simulation"))
BLOCK = 5


def app_trainer(cs, classical, arch: str, role: str, iterations: int, pairs=None, model=None,
                tune_threads: bool = False) -> Trainer:
    """A Trainer of the app's iterations as Train runs them (the CPU recipe's start: its loss, no lr step reached
    within `iterations`; the camera-space loss where the recipe asks for it), reporting every iteration and never
    validating, for timing. pairs, model: the role's pairs and the start (default: built here, the pretrained
    weights); tune_threads: False times at the thread count as it is."""
    pairs = pairs if pairs is not None else pairs_from_capture_sets([cs], role)
    recipe = cpu_recipe(arch, role, iterations)
    camera = camera_space_loss(cs, classical) if recipe.needs_camera_loss else None
    return Trainer(model if model is not None else start_model(arch, role), pairs, recipe, camera_loss=camera,
                   report_every=1, eval_every=10**9, tune_threads=tune_threads)


def _bare_step(model, pairs, crop: int):
    """One bare training step's closure: fixed batch 8 of crop-px crops, l1, Adam."""
    model.train()
    opt = torch.optim.Adam(model.parameters(), lr=1e-3)
    n = min(8, len(pairs))
    x = pairs.x[:n, :, :crop, :crop].contiguous()
    y = pairs.y[:n, :, :crop, :crop].contiguous()
    s = pairs.surfaces[0].s[..., :crop, :crop].expand(n, -1, -1, -1).contiguous()
    lo, hi = float(pairs.y.min()), float(pairs.y.max())

    def step():
        opt.zero_grad(set_to_none=True)
        loss = (apply_model(model, x, s, lo, hi) - y).abs().mean()
        loss.backward()
        opt.step()
    return step


def phase_profile(trainer, iterations: int = 10) -> dict:
    """Medians (ms) of the parts of the app's iteration, as Trainer.steps() runs them: sampling the batch and its
    crop, forward, the recipe's loss, backward, Adam."""
    from ...lapig_core.photometric.training import apply_model

    gen = torch.Generator().manual_seed(1)
    opt = torch.optim.Adam(trainer.model.parameters(), lr=1e-4)
    trainer.model.train()
    name = trainer.recipe.loss_at(0)
    parts = {k: [] for k in ("sample", "forward", "loss", "backward", "adam")}
    for i in range(iterations + 1):
        t0 = time.perf_counter()
        x, s, y, crop = trainer._sample(gen)
        t1 = time.perf_counter()
        pred = apply_model(trainer.model, x, s, trainer._y_min, trainer._y_max)
        t2 = time.perf_counter()
        loss = trainer._loss(name, pred, y, crop)
        t3 = time.perf_counter()
        opt.zero_grad(set_to_none=True)
        loss.backward()
        t4 = time.perf_counter()
        opt.step()
        t5 = time.perf_counter()
        if i:  # the first is the warm-up
            for key, value in zip(parts, (t1 - t0, t2 - t1, t3 - t2, t4 - t3, t5 - t4)):
                parts[key].append(value)
    return {k: round(1000 * statistics.median(v), 1) for k, v in parts.items()}


def time_network(cs, classical, arch: str, role: str, iterations: int) -> dict:
    pairs = pairs_from_capture_sets([cs], role)
    # the app's loop against a bare step, both at the same thread count
    trainer = app_trainer(cs, classical, arch, role, max(iterations * 4, 100), pairs=pairs)
    recipe, camera = trainer.recipe, trainer.camera_loss
    app_steps = trainer.steps()
    bare = _bare_step(start_model(arch, role), pairs, recipe.crop)
    next(app_steps), bare()  # warm-up: first-touch pages, kernel selection
    app, plain = [], []
    while len(app) < iterations:
        for _ in range(BLOCK):
            t = time.perf_counter()
            next(app_steps)
            app.append(time.perf_counter() - t)
        for _ in range(BLOCK):
            t = time.perf_counter()
            bare()
            plain.append(time.perf_counter() - t)
    app_steps.close()
    profile = phase_profile(Trainer(start_model(arch, role), pairs, recipe, camera_loss=camera))
    a, b = statistics.median(app), statistics.median(plain)
    return {"train_ms_per_iteration": round(1000 * a, 1), "bare_step_ms": round(1000 * b, 1),
            "ratio": round(a / b, 3), "train_ms_mean": round(1000 * statistics.mean(app), 1),
            "bare_ms_mean": round(1000 * statistics.mean(plain), 1), "iterations_timed": len(app),
            "loss": recipe.loss_at(0), "crop": recipe.crop, "batch": recipe.batch_size, "app_profile_ms": profile}


def on_a_worker(jobs: dict) -> dict:
    """Run each timing on a worker thread while this thread polls every 50 ms, as Train runs under the job
    engine (WorkerJob, headless poll_timeout): both the app's iterations and the bare steps see the same."""
    import queue
    import threading

    out, done = {}, queue.Queue()

    def target():
        try:
            from ...lapig_core.common import denormals

            denormals.flush_in_this_thread()  # as the job engine's worker threads do
            for name, job in jobs.items():
                out[name] = job()
        finally:
            done.put(True)

    threading.Thread(target=target, name="LAPIG: bench train-step", daemon=True).start()
    while True:
        try:
            done.get(timeout=0.05)
            break
        except queue.Empty:
            pass
    if len(out) != len(jobs):
        raise RuntimeError("the timing thread stopped early")
    return out


def fixed_costs(cs, iterations_per_network: int, per_iteration_s: float) -> dict:
    """Train's work besides its iterations, as train_models does it (the rendered choice aside)."""
    t = time.perf_counter()
    classical = ClassicalModel.fit(cs.prj_train, cs.cam_train)
    fit_s = time.perf_counter() - t
    t = time.perf_counter()
    models = {}
    for arch, role in NETWORKS:
        pairs_from_capture_sets([cs], role)
        models[arch] = start_model(arch, role)
    setup_s = time.perf_counter() - t
    t = time.perf_counter()
    compensator_choice.fit_and_choose(cs, models["CompenNeSt"], models["PCNet"], classical)
    choice_s = time.perf_counter() - t
    iterations_s = 2 * iterations_per_network * per_iteration_s
    total = fit_s + setup_s + choice_s + iterations_s
    return {"classical_fit_s": round(fit_s, 2), "load_and_pairs_s": round(setup_s, 2),
            "choice_by_simulation_s": round(choice_s, 2),
            "iterations_s_estimated": round(iterations_s, 1), "train_worker_s_estimated": round(total, 1),
            "worker_ms_per_iteration_estimated": round(1000 * total / (2 * iterations_per_network), 1)}


def run(args) -> dict:
    t0 = time.perf_counter()
    if not args.capture:
        raise ValueError("bench train-step needs --capture DIR: a captured setup (e.g. the demo's, "
                         "out/demo/demo_lapig/LAPIG_demo_panel)")
    cs = load_capture_set(os.path.abspath(args.capture))
    classical = ClassicalModel.fit(cs.prj_train, cs.cam_train)
    iterations = args.iterations or 40
    per_network = on_a_worker({arch: (lambda a=arch, r=role: time_network(cs, classical, a, r, iterations))
                               for arch, role in NETWORKS})
    app = statistics.mean(v["train_ms_per_iteration"] for v in per_network.values())
    bare = statistics.mean(v["bare_step_ms"] for v in per_network.values())
    # what a Train of the demo's recipe would spend besides its iterations (CompenNeSt's 1000, PCNet's 300)
    recipe_iterations = (cpu_recipe("CompenNeSt", "compensation").iterations + cpu_recipe("PCNet", "simulation").iterations) // 2
    return {"train_ms_per_iteration": round(app, 1), "bare_step_ms": round(bare, 1), "ratio": round(app / bare, 3),
            "per_network": per_network,
            "fixed_costs": fixed_costs(cs, recipe_iterations, app / 1000), "capture": args.capture,
            "frame": list(cs.frame_size), "training_pairs": len(cs.prj_train), "torch_threads": torch.get_num_threads(),
            "loadavg_1m": round(os.getloadavg()[0], 2), "bench_total_s": round(time.perf_counter() - t0, 1)}

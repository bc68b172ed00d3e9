# SPDX-License-Identifier: GPL-3.0-or-later
"""`python -m lapig_addon bench threads --json [--capture DIR] [--iterations N]`: Train's steps at a fixed torch
thread count (before) against the thread tuner (now: lapig_core/common/thread_tuner), idle and beside other work.

Train runs CompenNeSt's app iterations (Trainer.steps(), the CPU recipe) on a worker thread with flush-to-zero, as
the add-on's job does, for N iterations per run, the tuner's trials included. Three conditions:
  * idle: nothing else runs;
  * beside_train: a second process runs the same Train for the whole run (a second Blender's, a headless
    pipeline's), with the tuner as this run's: before, neither tunes; now, both do;
  * beside_cycles: this process's main thread renders Cycles with all cores while Train runs on the worker (an
    artist's F12 render, or the viewport in Rendered mode, while Train runs in the background); only where bpy
    imports.
For each: the seconds per iteration at the fixed count and with the tuner, and how much work the other party got
done meanwhile (its steps or renders per second), since fewer threads for Train also leave it more of the cores.
Runs go fixed, tuned, tuned, fixed per condition (ABBA), so a drift falls on both alike; the figures are means.
"""
from __future__ import annotations

import os
import statistics
import subprocess
import sys
import tempfile
import threading
import time
from contextlib import nullcontext
from pathlib import Path

import torch

from .device_fixture import FIXTURE

ROUNDS = ("fixed", "tuned", "tuned", "fixed")

# the second process: a second Train (another Blender's, or a headless pipeline's): CompenNeSt's app iterations on
# the same pairs, with the thread tuner as this run's (before: neither tunes; now: both do); it counts its steps
COMPETITOR = r"""
import sys
sys.path.insert(0, sys.argv[1])
import lapig_addon.__main__ as entry
entry._load_extension_package()
from lapig.tools.bench.bench_threads import trainer_factory
steps = trainer_factory(sys.argv[2])(sys.argv[3] == "tuned", iterations=10**7).steps()
n, path = 0, sys.argv[4]
for _ in steps:
    n += 1
    with open(path, "w") as f:
        f.write(str(n))
"""
ROOT = Path(__file__).resolve().parents[2]


class SecondTrain:
    """The second process, started before a run and stopped after it; `count()` reads its steps so far."""

    def __init__(self, capture: str, tuned: bool):
        self.capture, self.tuned = capture, tuned

    def __enter__(self):
        self._dir = tempfile.TemporaryDirectory()
        self.path = Path(self._dir.name) / "steps"
        env = {k: v for k, v in os.environ.items() if not k.startswith(("OMP_", "GOMP_", "MKL_"))}
        self.proc = subprocess.Popen([sys.executable, "-c", COMPETITOR, str(ROOT), self.capture,
                                      "tuned" if self.tuned else "fixed", str(self.path)], env=env,
                                     stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        deadline = time.time() + 120
        while self.count() < 3:  # running, past its first steps
            if self.proc.poll() is not None or time.time() > deadline:
                raise RuntimeError("the second Train did not start")
            time.sleep(0.1)
        return self

    def count(self) -> int:
        try:
            return int(self.path.read_text() or 0)
        except (OSError, ValueError):
            return 0

    def __exit__(self, *exc):
        self.proc.kill()
        self.proc.wait()
        self._dir.cleanup()


def _cycles_scene():
    import bpy

    scene = bpy.context.scene
    scene.render.engine = "CYCLES"
    scene.cycles.device = "CPU"
    scene.cycles.samples = 256
    scene.cycles.use_denoising = False
    scene.render.resolution_x, scene.render.resolution_y = 320, 240
    scene.render.filepath = str(Path(tempfile.gettempdir()) / "lapig_bench_threads_render.png")
    return bpy


def run_train(trainer_of, iterations: int, tuned: bool, beside=None, capture: str = "") -> dict:
    """Train's iterations on a worker thread; the main thread polls, or renders Cycles when beside == 'cycles'.
    Returns seconds per iteration and the other party's work per second (the tuner's summary is the trainer's
    result.threads)."""
    from ...lapig_core.common import denormals

    out, done = {}, threading.Event()

    def worker():
        try:
            denormals.flush_in_this_thread()
            steps = trainer_of(tuned).steps()
            next(steps)  # warm-up, untimed: first-touch pages, kernel selection (the tuner's first step)
            t = time.perf_counter()
            for _ in range(iterations):
                next(steps)
            out["seconds"] = time.perf_counter() - t
            steps.close()
        except BaseException as exc:  # noqa: BLE001 (reported on the main thread)
            out["error"] = exc
        finally:
            done.set()

    renders = 0
    with SecondTrain(capture, tuned) if beside == "train" else nullcontext() as other:
        before = other.count() if other is not None else 0
        t0 = time.perf_counter()
        thread = threading.Thread(target=worker, name="LAPIG: bench threads", daemon=True)
        thread.start()
        if beside == "cycles":
            bpy = _cycles_scene()
            while not done.is_set():
                bpy.ops.render.render(write_still=False)
                renders += 1
        done.wait()
        wall = time.perf_counter() - t0
        after = other.count() if other is not None else 0
    thread.join()
    if "error" in out:
        raise out["error"]
    result = {"s_per_iteration": out["seconds"] / iterations}
    if beside == "train":
        result["other_steps_per_s"] = (after - before) / wall
    elif beside == "cycles":
        result["renders_per_s"] = renders / wall
    return result


def trainer_factory(folder: str):
    """(tuned, iterations) -> a Trainer of CompenNeSt's app iterations on the capture at `folder` (the CPU recipe,
    from the pretrained weights, reporting every iteration)."""
    from ...lapig_core.capture.dataset import load_capture_set
    from ...lapig_core.photometric.classical import ClassicalModel
    from ...lapig_core.photometric.training_data import pairs_from_capture_sets
    from .bench_train_step import app_trainer

    cs = load_capture_set(folder)
    pairs = pairs_from_capture_sets([cs], "compensation")
    classical = ClassicalModel.fit(cs.prj_train, cs.cam_train)

    def make(tuned: bool, iterations: int):
        return app_trainer(cs, classical, "CompenNeSt", "compensation", iterations + 10, pairs=pairs,
                           tune_threads=tuned)
    make.frame_size = cs.frame_size
    return make


def measure(capture=None, iterations: int = 300, conditions=("idle", "train", "cycles")) -> dict:
    folder = os.path.abspath(capture or str(FIXTURE / "setups" / "device_check"))
    make = trainer_factory(folder)
    trainers = []

    def trainer_of(tuned: bool):
        trainers.append(make(tuned, iterations))
        return trainers[-1]

    if "cycles" in conditions:
        try:
            import bpy  # noqa: F401
        except ImportError:
            conditions = tuple(c for c in conditions if c != "cycles")
    figures = {}
    for condition in conditions:
        beside = None if condition == "idle" else condition
        runs = {"fixed": [], "tuned": []}
        summaries = []
        for mode in ROUNDS:
            runs[mode].append(run_train(trainer_of, iterations, mode == "tuned", beside, folder))
            if mode == "tuned":
                summaries.append(trainers[-1].result.threads)
        figures[condition if condition == "idle" else f"beside_{condition}"] = _compare(runs, summaries)
    return {"figures": figures, "iterations_per_run": iterations, "capture": folder,
            "frame": list(make.frame_size), "torch_threads": torch.get_num_threads(), "cpu_count": os.cpu_count()}


def _compare(runs: dict, summaries: list) -> dict:
    mean = lambda mode, key: statistics.mean(r[key] for r in runs[mode])  # noqa: E731
    fixed, tuned = mean("fixed", "s_per_iteration"), mean("tuned", "s_per_iteration")
    out = {"fixed_ms_per_iteration": round(1000 * fixed, 1), "tuned_ms_per_iteration": round(1000 * tuned, 1),
           "tuned_over_fixed": round(tuned / fixed, 3),
           "runs_ms": {m: [round(1000 * r["s_per_iteration"], 1) for r in v] for m, v in runs.items()},
           "tuner": summaries}
    for key in ("other_steps_per_s", "renders_per_s"):
        if key in runs["fixed"][0]:
            out[f"{key}_fixed"] = round(mean("fixed", key), 3)
            out[f"{key}_tuned"] = round(mean("tuned", key), 3)
    return out


def run(args) -> dict:
    t0 = time.perf_counter()
    out = measure(args.capture, args.iterations or 300)
    out["bench_total_s"] = round(time.perf_counter() - t0, 1)
    return out

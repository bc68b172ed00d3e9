# SPDX-License-Identifier: GPL-3.0-or-later
"""`python -m lapig_addon bench denormals --json` (also part of `tools/device_check.sh`): what subnormal floats cost
Train's step on this CPU, and what the remedies of lapig_core/common/denormals give back.

Issue 37: on an idle 2-core Intel Xeon, Train took 2,050-2,300 reference steps (`torch_step_s` 0.115-0.13,
256-265 s), against about 860 on the AMD EPYC host. The reference step's network is freshly initialised; Train's
and PSA's start from the shipped pretrained weights, of which 0.03-0.16 % are subnormal, and PCNet's fine-tune
(weight decay) makes more and leaves thousands of subnormal Adam moments. Many Intel cores take a microcode assist
on each vector instruction with a subnormal operand; AMD's Zen cores do not.

Per network (CompenNeSt, PCNet), one training step as Train takes it (batch 8 of 64 px crops of the device
check's fixture, its surface, l1, our Adam with the recipe's weight decay), from the shipped weights:
  * before: the weights as the file holds them (subnormals included), no flush-to-zero: Train before this change;
  * scrubbed: the subnormal weights set to zero at load, no flush-to-zero (a thread that has not set the mode);
  * flush: flush-to-zero and denormals-are-zero on the thread and its torch team, the weights as the file has them;
  * now: both, as the add-on's worker threads train now.
Each condition runs in a new thread (the CPU's mode is per thread, and torch's team copies it when the thread
starts it), from a copy of its start weights, blocks of STEPS after a warm-up step, the conditions alternating,
so a machine whose load changes shifts them alike. The figures are medians. A CPU that pays nothing for
subnormals shows ratios near 1.
"""
from __future__ import annotations

import copy
import platform
import statistics
import threading
import time

import torch

from .device_fixture import FIXTURE

NETWORKS = (("CompenNeSt", "compensation"), ("PCNet", "simulation"))
CONDITIONS = ("before", "scrubbed", "flush", "now")
STEPS, ROUNDS, CROP, BATCH = 8, 3, 64, 8


def _raw_model(arch: str, role: str):
    """The shipped pretrained network as its file holds it: load_checkpoint's scrub bypassed."""
    from ...lapig_core.photometric import checkpoints

    model, _ = checkpoints.load_checkpoint(checkpoints.pretrained_path(arch, role), arch, role, scrub=False)
    return model


def _batch(cs, role: str):
    from ...lapig_core.photometric.training_data import pairs_from_capture_sets

    pairs = pairs_from_capture_sets([cs], role)
    n = min(BATCH, len(pairs))
    x, s, y = pairs.batch(torch.arange(n))
    return (x[..., :CROP, :CROP].contiguous(), s[..., :CROP, :CROP].contiguous(), y[..., :CROP, :CROP].contiguous())


def _time_block(start_model, batch, weight_decay: float, flush: bool) -> tuple[list, int, bool]:
    """In a new thread: (seconds of STEPS training steps after a warm-up one, subnormal moments after them,
    whether the thread flushed)."""
    from ...lapig_core.common import denormals
    from ...lapig_core.common.adam import Adam
    from ...lapig_core.photometric.training import apply_model

    out = {}

    def run():
        try:
            # both ways, explicitly: a new thread copies the mode of the thread that starts it
            out["flushed"] = bool(torch.set_flush_denormal(flush)) and flush
            model = copy.deepcopy(start_model).train()
            opt = Adam(model.parameters(), lr=1e-4, weight_decay=weight_decay)
            x, s, y = batch
            lo, hi = float(y.min()), float(y.max())
            times = []
            for i in range(STEPS + 1):
                t = time.perf_counter()
                opt.zero_grad(set_to_none=True)
                (apply_model(model, x, s, lo, hi) - y).abs().mean().backward()
                opt.step()
                if i:
                    times.append(time.perf_counter() - t)
            out["times"], out["moments"] = times, denormals.count(opt.moments())
        except BaseException as exc:  # handed to the caller
            out["error"] = exc

    thread = threading.Thread(target=run, name="LAPIG: bench denormals")
    thread.start()
    thread.join()
    if "error" in out:
        raise out["error"]
    return out["times"], out["moments"], out["flushed"]


def time_network(cs, arch: str, role: str) -> dict:
    from ...lapig_core.common import denormals
    from ...lapig_core.photometric.finetune import cpu_recipe

    raw = _raw_model(arch, role)
    clean = copy.deepcopy(raw)
    scrubbed = denormals.scrub_module(clean)
    starts = {"before": raw, "scrubbed": clean, "flush": raw, "now": clean}
    decay = cpu_recipe(arch, role).weight_decay
    batch = _batch(cs, role)
    times = {c: [] for c in CONDITIONS}
    moments, flushed = {}, {}
    for _ in range(ROUNDS):
        for condition in CONDITIONS:
            t, m, f = _time_block(starts[condition], batch, decay, flush=condition in ("flush", "now"))
            times[condition] += t
            moments[condition], flushed[condition] = m, f
    ms = {c: round(1000 * statistics.median(v), 1) for c, v in times.items()}
    return {"step_ms": ms, "before_over_now": round(ms["before"] / ms["now"], 3),
            "scrubbed_over_now": round(ms["scrubbed"] / ms["now"], 3),
            "flush_over_now": round(ms["flush"] / ms["now"], 3),
            "flush_supported": flushed["now"], "subnormal_weights_shipped": scrubbed,
            "weights": sum(p.numel() for p in raw.parameters()),
            f"subnormal_moments_after_{STEPS + 1}_steps": moments, "weight_decay": decay}


def _cpu_name() -> str:
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                if line.startswith("model name"):
                    return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or platform.machine()


def measure() -> dict:
    from ...lapig_core.capture.dataset import load_capture_set

    t0 = time.perf_counter()
    cs = load_capture_set(FIXTURE)
    nets = {arch: time_network(cs, arch, role) for arch, role in NETWORKS}
    both = {c: round(sum(n["step_ms"][c] for n in nets.values()), 1) for c in CONDITIONS}
    return {"cpu": _cpu_name(), "torch_threads": torch.get_num_threads(), "networks": nets,
            "step_ms_both": both, "subnormal_cost_ratio": round(both["before"] / both["now"], 3),
            "steps_per_condition": STEPS * ROUNDS, "crop": CROP, "batch": BATCH,
            "seconds": round(time.perf_counter() - t0, 1)}


def run(args) -> dict:
    """`python -m lapig_addon bench denormals` (tools/dev_commands)."""
    return measure()

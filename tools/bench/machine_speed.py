#!/usr/bin/env python3
"""A fixed CPU workload, so that a timing taken on one machine can be compared with one taken on another.

Run it with the project's interpreter, on the idle machine, just before or after a timed benchmark:

    .venv/bin/python tools/bench/machine_speed.py

(the same workload as the team's ../shared/machine_speed.py, kept here so that every `bench` command can
print its `torch_step_s`: tools/dev_commands.cmd_bench runs it in a subprocess after the benchmark.)

It prints one JSON line: the median seconds of a fixed torch training step (a small conv net at 256 px, the
shape of the photometric networks' work) and of a fixed numpy matrix product, each over several repeats.
Divide a benchmark's seconds by `torch_step_s` to get a figure in "reference steps", which holds across
machines far better than seconds do. Nothing is written to disk.
"""
import json
import os
import platform
import statistics
import time

import numpy as np


def _median_seconds(fn, repeats):
    fn()  # warm-up: first-touch pages, kernel selection
    times = []
    for _ in range(repeats):
        t = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t)
    return statistics.median(times)


def torch_step_seconds(threads=2, repeats=7):
    import torch
    torch.manual_seed(0)
    torch.set_num_threads(threads)
    net = torch.nn.Sequential(
        torch.nn.Conv2d(3, 32, 3, 2, 1), torch.nn.ReLU(),
        torch.nn.Conv2d(32, 64, 3, 2, 1), torch.nn.ReLU(),
        torch.nn.Conv2d(64, 64, 3, 1, 1), torch.nn.ReLU(),
        torch.nn.ConvTranspose2d(64, 32, 2, 2), torch.nn.ReLU(),
        torch.nn.ConvTranspose2d(32, 3, 2, 2),
    )
    opt = torch.optim.Adam(net.parameters(), 1e-3)
    x = torch.rand(8, 3, 256, 256)

    def step():
        opt.zero_grad()
        loss = (net(x) - x).abs().mean()
        loss.backward()
        opt.step()
    return _median_seconds(step, repeats), torch.__version__


def numpy_matmul_seconds(repeats=7):
    rng = np.random.default_rng(0)
    a = rng.random((1024, 1024), dtype=np.float32)
    return _median_seconds(lambda: a @ a, repeats)


def main():
    out = {"cpu": platform.processor() or platform.machine(), "cores": os.cpu_count(),
           "loadavg_1m": os.getloadavg()[0]}
    try:
        step, version = torch_step_seconds()
        out.update(torch_step_s=round(step, 4), torch=version)
    except ImportError:
        out["torch_step_s"] = None
    out["numpy_matmul_s"] = round(numpy_matmul_seconds(), 5)
    try:
        with open("/proc/cpuinfo") as f:
            names = [l.split(":", 1)[1].strip() for l in f if l.startswith("model name")]
        if names:
            out["cpu"] = names[0]
    except OSError:
        pass
    print(json.dumps(out))


if __name__ == "__main__":
    main()

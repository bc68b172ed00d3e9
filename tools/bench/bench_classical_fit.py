"""`python -m lapig_addon bench classical-fit --json --capture DIR [--repeats N]`: the classical model's fit (the
first look after Capture, and Train's camera-space loss) with its per-pixel systems solved by numpy's LAPACK
(np.linalg.inv / solve, as before) and by lapig_core.common.small_spd (Cholesky in array arithmetic, now).

The two alternate, `--repeats` times each, on the same captured pairs, so a change in the machine's load shifts
both alike; the figures are each path's median and worst seconds, with the load average beside them. The
difference is largest on a busy machine (numpy's OpenBLAS synchronises its threads on every small matrix), so the
benchmark is meant to be run both idle and beside other work, and says which it was.
"""
from __future__ import annotations

import os
import statistics
import time
from contextlib import contextmanager

import numpy as np

from ...lapig_core.capture.dataset import load_capture_set
from ...lapig_core.photometric import classical


@contextmanager
def lapack_path():
    """The fit as it was: numpy's batched LAPACK for the per-pixel normal equations."""
    saved = classical.spd_inverse, classical.spd_solve
    classical.spd_inverse, classical.spd_solve = np.linalg.inv, np.linalg.solve
    try:
        yield
    finally:
        classical.spd_inverse, classical.spd_solve = saved


def _fit_seconds(cs) -> tuple[float, classical.ClassicalModel]:
    t = time.perf_counter()
    model = classical.ClassicalModel.fit(cs.prj_train, cs.cam_train)
    return time.perf_counter() - t, model


def run(args) -> dict:
    if not args.capture:
        raise ValueError("bench classical-fit needs --capture DIR: a captured setup (e.g. the demo's, "
                         "out/demo/demo_lapig/LAPIG_demo_panel)")
    cs = load_capture_set(os.path.abspath(args.capture))
    repeats = max(1, getattr(args, "repeats", 3) or 3)
    seconds = {"lapack": [], "small_spd": []}
    models = {}
    loads = [os.getloadavg()[0]]
    for _ in range(repeats):
        with lapack_path():
            s, models["lapack"] = _fit_seconds(cs)
        seconds["lapack"].append(s)
        s, models["small_spd"] = _fit_seconds(cs)
        seconds["small_spd"].append(s)
        loads.append(os.getloadavg()[0])
    a, b = models["lapack"], models["small_spd"]
    out = {"benchmark": "classical-fit", "pairs": len(cs.prj_train), "frame": list(cs.frame_size),
           "repeats": repeats, "loadavg_1m": [round(x, 2) for x in loads],
           "same_gammas": (a.gamma_c, a.gamma_p) == (b.gamma_c, b.gamma_p),
           "max_abs_difference_M": float(np.abs(a.M - b.M).max()),
           "residual": [round(a.residual, 6), round(b.residual, 6)]}
    for name, values in seconds.items():
        out[f"fit_seconds_{name}"] = round(statistics.median(values), 3)
        out[f"fit_seconds_{name}_worst"] = round(max(values), 3)
    out["speedup"] = round(out["fit_seconds_lapack"] / max(out["fit_seconds_small_spd"], 1e-9), 2)
    return out

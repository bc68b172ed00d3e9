"""The machine's speed beside a benchmark's seconds: machine_speed.py's fixed torch step, run in a subprocess
(its own torch threads, nothing shared with the benchmark), so that a timing can be read in reference steps
(seconds / torch_step_s) on any CPU."""
from __future__ import annotations

import json
import os
import subprocess
import sys

SCRIPT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "machine_speed.py")


def machine_speed(timeout_s: float = 300.0) -> dict:
    """machine_speed.py's JSON (torch_step_s, numpy_matmul_s, cpu, cores, loadavg_1m); on a failure
    {"torch_step_s": None, "machine_speed_error": why}, never an exception: the benchmark's figures stand."""
    try:
        done = subprocess.run([sys.executable, SCRIPT], capture_output=True, text=True, timeout=timeout_s)
        lines = [line for line in done.stdout.splitlines() if line.strip().startswith("{")]
        if done.returncode != 0 or not lines:
            why = (done.stderr.strip().splitlines() or [f"exit status {done.returncode}"])[-1]
            return {"torch_step_s": None, "machine_speed_error": why}
        return json.loads(lines[-1])
    except (OSError, subprocess.SubprocessError, ValueError) as exc:
        return {"torch_step_s": None, "machine_speed_error": str(exc)}


def with_machine_figures(summary: dict, speed: dict) -> dict:
    """The summary with torch_step_s (and the machine) beside its timings, and every *_s / *_seconds timing
    also in reference steps (`<name>_steps`) where the step was measured."""
    out = dict(summary)
    step = speed.get("torch_step_s")
    out["torch_step_s"] = step
    out["machine_speed"] = speed
    if step:
        for key, value in summary.items():
            if isinstance(value, (int, float)) and not isinstance(value, bool) and \
                    (key.endswith("_s") or key.endswith("_seconds")) and f"{key}_steps" not in summary:
                out[f"{key}_steps"] = round(value / step, 1)
    return out

"""The machine's speed beside a benchmark's seconds: machine_speed.py's fixed torch step, run in a subprocess
(its own torch threads, nothing shared with the benchmark), so that a timing can be read in reference steps
(seconds / torch_step_s) on any CPU; and the CPU's topology, since two logical CPUs may be one core's two
hyperthreads (Train's small steps on two threads then gain little, where machine_speed's large one still does)."""
from __future__ import annotations

import glob
import json
import os
import subprocess
import sys

SCRIPT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "machine_speed.py")


def cpu_topology(sys_cpu: str = "/sys/devices/system/cpu", cpuinfo: str = "/proc/cpuinfo") -> dict:
    """{"logical_cpus", "physical_cores", "threads_per_core", "model"} from Linux's sysfs and cpuinfo; {} where
    they cannot be read (other systems)."""
    cores, logical = set(), 0
    for topology in sorted(glob.glob(os.path.join(sys_cpu, "cpu[0-9]*", "topology"))):
        try:
            with open(os.path.join(topology, "core_id")) as f:
                core = f.read().strip()
            with open(os.path.join(topology, "physical_package_id")) as f:
                package = f.read().strip()
        except OSError:
            continue
        logical += 1
        cores.add((package, core))
    if not logical:
        return {}
    out = {"logical_cpus": logical, "physical_cores": len(cores), "threads_per_core": round(logical / len(cores), 2)}
    try:
        with open(cpuinfo) as f:
            models = [line.split(":", 1)[1].strip() for line in f if line.lower().startswith("model name")]
        if models:
            out["model"] = models[0]
    except OSError:
        pass
    return out


def machine_speed(timeout_s: float = 300.0) -> dict:
    """machine_speed.py's JSON (torch_step_s, numpy_matmul_s, cpu, cores, loadavg_1m) and the CPU's topology
    (cpu_topology); on a failure {"torch_step_s": None, "machine_speed_error": why}, never an exception: the
    benchmark's figures stand."""
    topology = cpu_topology()
    try:
        done = subprocess.run([sys.executable, SCRIPT], capture_output=True, text=True, timeout=timeout_s)
        lines = [line for line in done.stdout.splitlines() if line.strip().startswith("{")]
        if done.returncode != 0 or not lines:
            why = (done.stderr.strip().splitlines() or [f"exit status {done.returncode}"])[-1]
            return {"torch_step_s": None, "machine_speed_error": why, "topology": topology}
        return {**json.loads(lines[-1]), "topology": topology}
    except (OSError, subprocess.SubprocessError, ValueError) as exc:
        return {"torch_step_s": None, "machine_speed_error": str(exc), "topology": topology}


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

"""Flush-to-zero on the add-on's worker threads, set before their first torch operation.

Subnormal floats in the networks' weights and Adam's moments cost some CPUs (many Intel cores) a microcode assist
on every vector instruction that meets one; lapig_core/common/denormals says why and how much. The CPU's mode is
per thread, and torch's OpenMP team copies it from the thread that starts it, when it starts: so each worker
thread sets it first thing. Blender's main thread keeps its own mode.
"""
from __future__ import annotations

import sys


def flush_denormals_here() -> None:
    """On a worker thread, before it runs anything: flush-to-zero for it and the torch threads it starts.

    Only where torch is loaded already: the jobs that run torch load it with their module (train_job and
    generate_job import lapig_core.pipeline), on the main thread, before their worker starts; a job that needs no
    torch does not load it here. Never fails: the mode only saves time (weights are scrubbed of subnormals anyway)."""
    if "torch" not in sys.modules:
        return
    try:
        from ...lapig_core.common import denormals

        denormals.flush_in_this_thread()
    except Exception:  # noqa: BLE001 (a torch that half-loaded: the work reports it, not this)
        pass

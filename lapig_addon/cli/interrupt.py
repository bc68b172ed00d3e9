"""Ctrl-C in a headless run: one line and exit status 130, never an abort of the interpreter."""
from __future__ import annotations

import os
import sys
import threading


def exit_interrupted() -> int:
    """The exit status after KeyboardInterrupt (jobs.Job.run has cancelled the job and joined its worker)."""
    print("interrupted", file=sys.stderr, flush=True)
    if any(t.is_alive() for t in threading.enumerate() if t.daemon):
        # a second Ctrl-C while the worker was stopping: torch still runs on that thread, and the
        # interpreter's shutdown under it aborts ("terminate called without an active exception", 134)
        sys.stdout.flush()
        os._exit(130)
    return 130

"""The pipeline jobs' refusal and the capture's lock, below every job module (the jobs of several projectors take
them without importing pipeline_jobs, which dispatches to them)."""
from __future__ import annotations

from ...lapig_core.capture.dataset import resolve_setup
from ...lapig_core.capture.staging import hold_root


class PipelineError(ValueError):
    """A step that cannot run yet; the message says which step to do first."""


def hold_capture(folder: str, title: str):
    """The lock of the capture's data set root, where the models are written and which a capture
    must not replace meanwhile."""
    return hold_root(resolve_setup(folder).root, title)

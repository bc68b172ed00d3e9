"""The pipeline jobs' refusal, the capture's lock and the result's summary, below every job module (the jobs of
several projectors take them without importing pipeline_jobs)."""
from __future__ import annotations

from ...lapig_core.capture.dataset import resolve_setup
from ...lapig_core.capture.staging import hold_root
from ...lapig_core.export.result_files import read_summary


class PipelineError(ValueError):
    """A step that cannot run yet; the message says which step to do first."""


def hold_capture(folder: str, title: str):
    """The lock of the capture's data set root, where the models are written and which a capture
    must not replace meanwhile."""
    return hold_root(resolve_setup(folder).root, title)


def summary_made_on(folder: str, capture: str) -> dict:
    """The result's summary (result.json), refused where the result was made on another capture than `capture`."""
    summary = read_summary(folder)
    if summary.get("capture") and summary["capture"] != capture:
        raise PipelineError("the result was made on another capture than the scene's: generate again first")
    return summary

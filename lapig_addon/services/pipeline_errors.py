"""What every pipeline job shares, below every job module: the refusal, the capture a job works on (checked
against the rig as it is now), the capture's lock and the result's summary."""
from __future__ import annotations

import os

from ...lapig_core.capture.dataset import DatasetError, frame_size_of, read_setup_json, resolve_setup
from ...lapig_core.capture.staging import hold_root
from ...lapig_core.export.result_files import capture_of_result, read_summary
from ...lapig_core.optics.working_frame import WorkingFrameError, check_aspect
from .panel import panel_state


class PipelineError(ValueError):
    """A step that cannot run yet; the message says which step to do first."""


def chosen_capture(state, explicit: str | None = None) -> str:
    """The capture folder to work on: `explicit` (a pipeline naming one with --capture), checked to be a data set
    this rig made as it is now (or one captured elsewhere, which is tied to no rig), else the scene's."""
    if not explicit:
        blocker = panel_state.capture_blocker(state)
        if blocker:
            raise PipelineError(blocker)
        return state.capture_dir
    blocker = panel_state.rig_blocker(state.rig)
    if blocker:
        raise PipelineError(blocker)
    try:
        meta = read_setup_json(resolve_setup(explicit).setup_json)
    except (DatasetError, OSError, ValueError) as exc:
        raise PipelineError(f"--capture {explicit}: {exc}") from None
    made_by = meta.get("fingerprint") or ""
    if made_by and state.rig.fingerprint and made_by != state.rig.fingerprint:
        raise PipelineError(f"{explicit} was captured with the rig as it was then; the projectors, camera or object "
                            f"changed since: capture again, or use the .blend it was captured with")
    return str(explicit)


def current_capture(state, explicit: str | None = None) -> str:
    """One projector's capture (chosen_capture), checked to cover the projector's frame (an imported data set of
    another aspect cannot)."""
    folder = chosen_capture(state, explicit)
    try:
        check_aspect(frame_size_of(folder), state.rig.projector_size, "the capture",
                     advice="capture this projector's surface, or set its resolution to the capture's aspect")
    except (DatasetError, WorkingFrameError) as exc:
        raise PipelineError(str(exc)) from None
    return folder


def joint_capture(state, explicit: str | None = None) -> str:
    """The capture of several projectors (chosen_capture), checked to be one of several."""
    from ...lapig_core.multi.capture_set import is_multi

    folder = chosen_capture(state, explicit)
    if not is_multi(folder):
        raise PipelineError(f"the capture is of one projector; the rig has {state.rig.projector_count}: capture "
                            f"again")
    return folder


def capture_record(folder: str) -> tuple[str, str]:
    """(fingerprint, light transport label) a capture folder's setup.json records, for the scene store."""
    meta = read_setup_json(resolve_setup(folder).setup_json)
    return meta.get("fingerprint") or "", (meta.get("transport") or {}).get("label", "")


def hold_capture(folder: str, title: str):
    """The lock of the capture's data set root, where the models are written and which a capture
    must not replace meanwhile."""
    return hold_root(resolve_setup(folder).root, title)


def summary_made_on(folder: str, capture: str) -> dict:
    """The result's summary (result.json), refused where the result was made on another capture than `capture`."""
    summary = read_summary(folder)
    made_on = capture_of_result(folder, summary)  # found again where the project was moved
    if made_on and os.path.normpath(made_on) != os.path.normpath(capture):
        raise PipelineError("the result was made on another capture than the scene's: generate again first")
    return summary

"""Capture a rig of several projectors, then fit their first look (issue 36).

As CaptureJob for one projector: the settings and the rig are checked first, the device factory opens the
device (its multi_capture_device: every projector and the camera) on the thread it needs, and the capture
sequence (lapig_core/multi/capture) runs through it. Then, on a worker thread, the joint classical model is
fitted on the capture and saved in its models folder (lapig_core/multi/first_look), so Generate works at
once; a failure there keeps the capture, as one projector's first look does.
"""
from __future__ import annotations

import time

from ...lapig_core.capture.settings import CaptureError, CaptureSettings
from ...lapig_core.multi.capture import run_multi_capture
from .capture_job import check_settings
from .jobs import Job
from .panel_state import device_blocker
from .ports import Seams


def fit_joint_first_look_steps(setup_dir, holder: str):
    """Steps that fit and save the capture's joint first look under the capture's lock; their value is the
    JointFirstLook, or why it could not be fitted (a string)."""
    from ...lapig_core.capture.dataset import resolve_setup
    from ...lapig_core.capture.staging import hold_root
    from ...lapig_core.multi.capture_set import load_multi_capture
    from ...lapig_core.multi.first_look import fit_joint_first_look

    yield 0.99, "fitting the first look (the joint classical model)"
    try:
        held = hold_root(resolve_setup(setup_dir).root, holder)
        try:
            return fit_joint_first_look(load_multi_capture(setup_dir))
        finally:
            held.release()
    except Exception as exc:  # the capture stands without it
        return str(exc) or type(exc).__name__


class MultiCaptureJob(Job):
    """record: write the capture, its coverage and its first look's line into the scene store."""

    title = "LAPIG capture"

    def __init__(self, seams: Seams, settings: CaptureSettings, record: bool = True):
        super().__init__()
        self.seams, self.settings, self.record = seams, settings, record

    def _open(self):
        devices = self.seams.devices
        opener = getattr(devices, "multi_capture_device", None)
        if opener is None:
            name = getattr(devices.rig_identity(), "name", "this rig")
            raise CaptureError(f"{name} cannot capture several projectors yet: remove the other projectors, or "
                               f"capture them with the virtual rig")
        return opener(self.settings)

    def _capture(self, names, fingerprint):
        devices = self.seams.devices
        with self._open() as device:
            identity = devices.rig_identity()
            meta = {"fingerprint": fingerprint, "rig": {**identity.to_dict(), "key": fingerprint}}
            return (yield from run_multi_capture(device, self.settings, names, extra_meta=meta, holder=self.title))

    def steps(self):
        check_settings(self.settings)
        rig = self.seams.store.read().rig
        blocker = device_blocker(rig)
        if blocker:
            raise CaptureError(blocker)
        if rig.projector_count < 2:
            raise CaptureError("the rig has one projector: capture it with Capture as ever")
        names, fingerprint = rig.projectors, rig.fingerprint
        self.result = yield from self.drive(lambda: self._capture(names, fingerprint), self.seams.devices.main_thread)
        meta, setup_dir = self.result["meta"], str(self.result["setup_dir"])
        ended = time.perf_counter()
        store = self.seams.store
        if self.record:
            store.record_capture(setup_dir, fingerprint, meta.get("transport", {}).get("label", ""))
            cover = meta["coverage"]
            store.record_coverage(names, cover["per_projector"], cover["reached"])
        look = yield from self.drive(lambda: fit_joint_first_look_steps(setup_dir, self.title), False)
        if isinstance(look, str):
            self.result["first_look_error"] = look
            return
        self.result["first_look"] = look.to_dict()
        self.result["first_look_seconds"] = round(time.perf_counter() - ended, 2)  # capture end -> first look
        if self.record:
            store.record_models("", look.status_line())

    def line(self) -> str:
        """The capture's one line: where it went, coverage alone and together, the black level's cost."""
        folder = self.result["setup_dir"]
        look = self.result.get("first_look")
        if look is None:
            return f"Captured {len(self.seams.store.read().rig.projectors)} projectors into {folder}; no first look: " \
                   f"{self.result.get('first_look_error', '')}"
        return f"Captured into {folder}. {look['line']}"

"""Capture a complete, registered data set of one projector-camera setup.

The job checks the settings and the rig, opens the rig's capture device from the device factory
(ports.DeviceFactory: the Cycles studio, or a real projector and camera) and runs the capture sequence
of lapig_core.capture.sequence through it, on the thread the device needs; then it records the capture
in the scene store.
"""
from __future__ import annotations

from ...lapig_core.capture.sequence import run_capture
from ...lapig_core.capture.settings import CaptureError, CaptureSettings  # noqa: F401 (re-exported)
from .jobs import Job
from .limits import first_problem
from .panel_state import device_blocker
from .ports import Seams


def check_rig(store):
    """CaptureError unless the scene's rig can be captured (a real rig: its display and camera chosen)."""
    blocker = device_blocker(store.read().rig)
    if blocker:
        raise CaptureError(blocker)


def check_settings(settings: CaptureSettings):
    """CaptureError unless every count and size is within the panel's range: checked before any image is
    allocated (a working size of 100000 would ask for 112 GiB per image)."""
    problem = first_problem({name: getattr(settings, name)
                             for name in ("train_count", "test_count", "working_size", "samples", "seed")})
    if problem:
        raise CaptureError(problem)


class CaptureJob(Job):
    """record: write the capture into the scene store when it completes (False: a script capturing rig
    objects other than the scene's own, which must leave the scene as it was)."""

    title = "LAPIG capture"

    def __init__(self, seams: Seams, settings: CaptureSettings, record: bool = True):
        super().__init__()
        self.seams, self.settings, self.record = seams, settings, record

    def _capture(self):
        s, devices = self.settings, self.seams.devices
        with devices.capture_device(s) as device:
            # once the device is open (Cycles: the scene evaluated, the rig where it is now)
            identity = devices.rig_identity()
            rig_meta = {"fingerprint": identity.key(), "rig": identity.to_dict(), "objects": identity.devices}
            return (yield from run_capture(device, s, extra_meta=rig_meta, holder=self.title))

    def steps(self):
        check_settings(self.settings)
        if self.record:
            check_rig(self.seams.store)
        self.result = yield from self.drive(self._capture, self.seams.devices.main_thread)
        if self.record:
            meta = self.result["meta"]
            self.seams.store.record_capture(str(self.result["setup_dir"]), meta["fingerprint"],
                                            meta.get("transport", {}).get("label", ""))

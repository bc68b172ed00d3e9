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


def fit_first_look_steps(setup_dir, holder: str):
    """Steps that fit and save the capture's first look (photometric/first_look) under the capture's lock;
    their value is the FirstLook."""
    from ...lapig_core.capture.dataset import load_capture_set, resolve_setup
    from ...lapig_core.capture.staging import hold_root
    from ...lapig_core.photometric.first_look import fit_first_look

    yield 0.99, "fitting the first look (the classical model)"
    try:
        held = hold_root(resolve_setup(setup_dir).root, holder)
        try:
            return fit_first_look(load_capture_set(setup_dir), setup_dir)
        finally:
            held.release()
    except Exception as exc:  # the capture stands without it: Generate trains the networks first, as before
        return str(exc) or type(exc).__name__


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
        # the first look: the classical model, fitted now (seconds, on a worker thread), so that Generate works
        # at once; a cancel or a failure here keeps the capture, and Generate then trains the networks first
        look = yield from self.drive(lambda: fit_first_look_steps(self.result["setup_dir"], self.title), False)
        if isinstance(look, str):
            self.result["first_look_error"] = look
        else:
            self.result["first_look_seconds"] = round(look.fit_seconds, 2)
            if self.record:
                self.seams.store.record_models("", look.status_line())

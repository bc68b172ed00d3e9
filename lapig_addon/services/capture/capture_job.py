"""Capture a complete, registered data set of the scene's rig, then fit its first look.

The job checks the settings and the rig, opens the rig's capture device from the device factory
(ports.DeviceFactory: the Cycles studio, or real projectors and a camera) and runs the capture sequence through
it, on the thread the device needs; then it records the capture in the scene store and fits the first look on a
worker thread, so Generate works at once (a failure there keeps the capture). The way is chosen once, by the rig:
one projector's sequence and classical model (ProjectorCaptureWay, below), or several projectors' sequence and
joint classical model (services/capture/capture_joint); the job's steps are the same for both.
"""
from __future__ import annotations

import time

from ....lapig_core.capture.sequence import run_capture
from ....lapig_core.capture.settings import CaptureError, CaptureSettings  # noqa: F401 (re-exported)
from ..jobs import Job
from ..limits import first_problem
from ..panel.panel_state import device_blocker
from ..ports import Seams
from ..ways import chosen_way


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


def fit_first_look_steps(setup_dir, holder: str, way):
    """Steps that fit and save the capture's first look (way.fit_first_look) under the capture's lock; their
    value is the first look, or why it could not be fitted (a string)."""
    from ....lapig_core.capture.dataset import resolve_setup
    from ....lapig_core.capture.staging import hold_root

    yield 0.99, f"fitting the first look ({way.first_look_model})"
    try:
        held = hold_root(resolve_setup(setup_dir).root, holder)
        try:
            return way.fit_first_look(setup_dir)
        finally:
            held.release()
    except Exception as exc:  # the capture stands without it: Generate trains the networks first, as before
        return str(exc) or type(exc).__name__


class CaptureJob(Job):
    """record: write the capture (and its first look's line) into the scene store when it completes (False: a
    script capturing rig objects other than the scene's own, which must leave the scene as it was)."""

    title = "LAPIG capture"

    def __init__(self, seams: Seams, settings: CaptureSettings, record: bool = True):
        super().__init__()
        self.seams, self.settings, self.record = seams, settings, record
        self.way = None  # chosen once the settings and the rig are checked

    def steps(self):
        check_settings(self.settings)
        if self.record:
            check_rig(self.seams.store)
        self.way = capture_way(self.seams, self.record)
        opened = self.way.opened(self.seams, self.settings, self.title)  # the store reads bpy: here
        self.result = yield from self.drive(opened, self.seams.devices.main_thread)
        ended = time.perf_counter()
        if self.record:
            self.way.record(self.seams.store, self.result)
        look = yield from self.drive(lambda: fit_first_look_steps(self.result["setup_dir"], self.title, self.way),
                                     False)
        if isinstance(look, str):
            self.result["first_look_error"] = look
            return
        self.way.add_first_look(self.result, look, ended)
        if self.record:
            self.seams.store.record_models("", look.status_line())

    def line(self) -> str:
        """The capture's one line, for the operator's report."""
        return self.way.line(self.seams, self.result)


def capture_way(seams: Seams, record: bool):
    """The one place the capture's way is chosen: the scene's own rig of several projectors (`record`) is
    captured in camera space, for their joint model."""
    if not record:  # a capture that is not the scene's own (not recorded) is one projector's, as before
        return ProjectorCaptureWay()
    return chosen_way(seams.store.read().rig, ProjectorCaptureWay, "capture.capture_joint:JointCaptureWay")()


class ProjectorCaptureWay:
    """CaptureJob's steps for one projector: opened(seams, settings, holder) -> the capture's steps (a callable
    for Job.drive); record(store, result) and add_first_look(result, look, capture's end) on the main thread;
    fit_first_look(setup_dir) on a worker; line(seams, result); trains_networks: Train follows in the background."""

    first_look_model = "the classical model"
    trains_networks = True

    def opened(self, seams, settings, holder):
        def capture():
            devices = seams.devices
            with devices.capture_device(settings) as device:
                # once the device is open (Cycles: the scene evaluated, the rig where it is now)
                identity = devices.rig_identity()
                rig_meta = {"fingerprint": identity.key(), "rig": identity.to_dict(), "objects": identity.devices}
                return (yield from run_capture(device, settings, extra_meta=rig_meta, holder=holder))
        return capture

    def record(self, store, result):
        meta = result["meta"]
        store.record_capture(str(result["setup_dir"]), meta["fingerprint"], meta.get("transport", {}).get("label", ""))

    def fit_first_look(self, setup_dir):
        from ....lapig_core.capture.dataset import load_capture_set
        from ....lapig_core.photometric.first_look import fit_first_look

        return fit_first_look(load_capture_set(setup_dir), setup_dir)

    def add_first_look(self, result, look, ended):
        result["first_look_seconds"] = round(look.fit_seconds, 2)

    def line(self, seams, result):
        err = result["meta"]["registration"].get("registration_error_px_median")
        extra = f", registration error {err:.2f} px" if err is not None else ""
        return f"Captured into {result['setup_dir']}{extra}"

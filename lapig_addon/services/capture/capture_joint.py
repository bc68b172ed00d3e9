"""Capture a rig of several projectors, for their joint model (issue 36).

CaptureJob (services/capture/capture_job) takes this way for the scene's rig of more than one projector: the device
factory opens its multi_capture_device (every projector and the camera) on the thread it needs, and the capture
sequence of several (lapig_core/multi/capture) runs through it; the store records the capture and each
projector's coverage. The first look is the joint classical model, fitted on the capture and saved in its models
folder (lapig_core/multi/first_look).
"""
from __future__ import annotations

import time

from ....lapig_core.capture.settings import CaptureError
from ....lapig_core.multi.capture import run_multi_capture


class JointCaptureWay:
    """CaptureJob's steps for a rig of several projectors (see capture_job.ProjectorCaptureWay)."""

    first_look_model = "the joint classical model"
    trains_networks = False  # their joint model is the first look: there are no networks to train

    def opened(self, seams, settings, holder):
        devices, rig = seams.devices, seams.store.read().rig
        names = self.names = rig.projectors  # the store's coverage is recorded under these names
        fingerprint = rig.fingerprint

        def capture():
            if not devices.opens_several:
                name = getattr(devices.rig_identity(), "name", "this rig")
                raise CaptureError(f"{name} cannot capture several projectors yet: remove the other projectors, or "
                                   f"capture them with the virtual rig")
            with devices.multi_capture_device(settings) as device:
                identity = devices.rig_identity()
                meta = {"fingerprint": fingerprint, "rig": {**identity.to_dict(), "key": fingerprint}}
                return (yield from run_multi_capture(device, settings, names, extra_meta=meta, holder=holder))
        return capture

    def record(self, store, result):
        meta = result["meta"]
        store.record_capture(str(result["setup_dir"]), meta["fingerprint"], meta.get("transport", {}).get("label", ""))
        cover = meta["coverage"]
        store.record_coverage(self.names, cover["per_projector"], cover["reached"])

    def fit_first_look(self, setup_dir):
        from ....lapig_core.multi.capture_set import load_multi_capture
        from ....lapig_core.multi.first_look import fit_joint_first_look

        return fit_joint_first_look(load_multi_capture(setup_dir))

    def add_first_look(self, result, look, ended):
        result["first_look"] = look.to_dict()
        result["first_look_seconds"] = round(time.perf_counter() - ended, 2)  # capture end -> first look

    def line(self, seams, result):
        """Where the capture went, coverage alone and together, the black level's cost."""
        look = result.get("first_look")
        if look is None:
            return f"Captured {len(seams.store.read().rig.projectors)} projectors into {result['setup_dir']}; no " \
                   f"first look: {result.get('first_look_error', '')}"
        return f"Captured into {result['setup_dir']}. {look['line']}"

"""Capture a complete, registered data set of one projector-camera setup with Cycles.

The job checks the rig, opens the Cycles capture device and runs the capture sequence of
lapig_core.capture.sequence through it, with the viewport preview off so Cycles sees the real
surface.
"""
from __future__ import annotations

from ...lapig_core.capture.sequence import run_capture
from ...lapig_core.capture.settings import CaptureError, CaptureSettings  # noqa: F401 (re-exported)
from ..blender import preview
from ..blender.cycles_device import CyclesCaptureDevice
from .jobs import Job
from ..blender.scene_state import read_rig, rig_fingerprint
from .limits import first_problem
from .panel_state import rig_blocker


def check_rig(scene, projector=None, camera=None, target=None):
    """CaptureError unless the rig of these objects (None: the scene's own) can be captured."""
    blocker = rig_blocker(read_rig(scene, projector, camera, target))
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
    title = "LAPIG capture"

    def __init__(self, scene, projector, camera, target, settings: CaptureSettings):
        super().__init__()
        self.scene, self.projector, self.camera, self.target = scene, projector, camera, target
        self.settings = settings

    def steps(self):
        s = self.settings
        check_settings(s)
        check_rig(self.scene, self.projector, self.camera, self.target)
        # the viewport preview tints the object's materials: capture the real surface
        with preview.real_surface(self.target, self.projector), \
                CyclesCaptureDevice(self.scene, self.projector, self.camera, self.target, samples=s.samples,
                                    ambient=s.ambient, seed=s.seed) as device:
            # once the device has evaluated the scene: matrix_world is current
            rig_meta = {"fingerprint": rig_fingerprint(self.projector, self.camera, self.target),
                        "transport": device.transport.to_dict(),
                        "objects": {"projector": self.projector.name, "camera": self.camera.name,
                                    "target": self.target.name}}
            self.result = yield from run_capture(device, s, device.geometry_checks(), rig_meta, self.title)

"""Fakes of the three seams (services/ports.py), for driving the jobs end to end with bpy blocked.

- FakeStore: the scene's settings and what the jobs record, in memory.
- FakeFactory: the numpy fake projector and camera (lapig_core.capture.fake_device) as a rig; by
  default off the main thread, like a real camera, optionally slow to settle, and held at each grab
  (grab_gate) as a real camera's blocking grab.
- FakeSink: keeps every frame it is shown.
The modules under test are passed in (they are imported afresh with bpy blocked by conftest)."""
from __future__ import annotations

import contextlib
import os
import threading
from dataclasses import replace

from lapig.lapig_core.capture.fake_device import FakeDevice
from lapig.lapig_core.capture.settings import CaptureSettings
from lapig.lapig_core.optics.projector_model import ProjectorModel

PROJECTOR_SIZE = (64, 48)


class FakeFactory:
    opens_several = False  # the fake rig of one projector
    def __init__(self, ports, main_thread=False, settle_s=0.0, name="site rig"):
        self.ports, self.main_thread, self.settle_s, self.name = ports, main_thread, settle_s, name
        self.opened, self.closed, self.threads = 0, 0, set()
        self.moved = False  # the rig's identity changes, as a moved real camera's would
        self.grab_gate = None  # a threading.Event: the devices opened from now on grab only while it is set

    def rig_identity(self):
        devices = {"projector": "fake projector 64x48", "camera": "fake camera 160x120" + (" moved" if self.moved else "")}
        return self.ports.RigIdentity(self.name, devices)

    @contextlib.contextmanager
    def _device(self):
        device = SettlingFakeDevice(self.settle_s, projector_size=PROJECTOR_SIZE, camera_size=(160, 120), seed=1,
                                    gate=self.grab_gate)
        self.opened += 1
        self.threads.add(threading.current_thread().name)
        try:
            yield device
        finally:
            self.closed += 1

    def capture_device(self, settings):
        return self._device()

    def setup_device(self, setup_meta, seed=0):
        return self._device()


class SettlingFakeDevice(FakeDevice):
    def __init__(self, settle_s=0.0, gate=None, **kw):
        super().__init__(**kw)
        self.settle_s, self.gate = settle_s, gate

    def describe(self):
        return replace(super().describe(), settle_s=self.settle_s, latency_s=0.0)

    def grab(self):
        if self.gate is not None and not self.gate.wait(30):  # as a real camera's grab blocks
            raise TimeoutError("the test never opened the grab gate")
        return super().grab()


class FakeStore:
    def __init__(self, state_module, root, factory, iterations=2):
        self.s, self.root, self.factory, self.iterations = state_module, str(root), factory, iterations
        self.capture_dir = self.capture_fingerprint = self.capture_transport = ""
        self.models = ("", "")
        self.result = ("", "", "")
        self.rig_present = True
        self.recorded = []  # what the jobs recorded, in order

    def read(self):
        s = self.s
        rig = s.Rig(projector="Projector", camera="Camera", target="Wall", scene="Scene",
                    fingerprint=self.factory.rig_identity().key(), projector_size=PROJECTOR_SIZE) \
            if self.rig_present else s.Rig()
        return s.SceneState(rig=rig, capture_dir=self.capture_dir if os.path.isdir(self.capture_dir) else "",
                            capture_fingerprint=self.capture_fingerprint, capture_transport=self.capture_transport,
                            capture_projector_size=PROJECTOR_SIZE if self.capture_fingerprint else None,
                            models_fingerprint=self.models[0], models_status=self.models[1],
                            result_dir=self.result[0], result_fingerprint=rig.fingerprint if self.result[0] else "")

    def capture_settings(self, **overrides):
        settings = CaptureSettings(out_dir=os.path.join(self.root, "Wall"), setup_name="Wall", train_count=8,
                                   test_count=2, working_size=32, chunk=4)
        return self.s.overridden(settings, **overrides)

    def generate_request(self, **overrides):
        request = self.s.GenerateRequest(prompt="Make it a charcoal sketch", backend="styletransfer", mix="",
                                         psa=True, adaptation=0.5, seed=0)
        return self.s.overridden(request, **overrides)

    def export_settings(self, **overrides):
        return self.s.overridden(self.s.ExportSettings(path=os.path.join(self.root, "out.png"), bit_depth=8,
                                                       crossfade_frames=4), **overrides)

    def finetune_iterations(self):
        return self.iterations

    def compute_device(self):
        return "auto"  # the preference's default: the CPU on a machine without a GPU

    def projector_model(self):
        return ProjectorModel(width=PROJECTOR_SIZE[0], height=PROJECTOR_SIZE[1])

    def rig_metadata(self):
        return {"projector": {"object": "Projector"}, "camera": None, "surface_object": "Wall"}

    def software(self):
        return {"software_host": "tests"}

    def data_root(self):
        return self.root

    def record_capture(self, folder, fingerprint, transport=""):
        self.capture_dir, self.capture_fingerprint, self.capture_transport = str(folder), fingerprint, transport
        self.recorded.append("capture")

    def record_models(self, fingerprint, status=None):
        self.models = (fingerprint, self.models[1] if status is None else status)
        self.recorded.append("models")

    def record_result(self, folder, summary_line, reach_message=""):
        self.result = (str(folder), summary_line, reach_message)
        self.recorded.append("result")


class FakeSink:
    def __init__(self):
        self.frames = []

    def show(self, frame):
        self.frames.append(frame)

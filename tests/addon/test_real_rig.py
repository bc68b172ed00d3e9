"""A real rig behind the seams, with bpy blocked: the real-rig device factory over simulated hardware
(a screen and a camera with latency and faults, lapig_core.rig.simulated) drives Capture on a worker
thread; staleness follows the rig's identity; looks play on a live window sink."""
import importlib
import threading

import numpy as np
import pytest

from lapig.lapig_core.capture.fake_device import FakeDevice
from lapig.lapig_core.rig.clock import VirtualClock
from lapig.lapig_core.rig.simulated import CameraFaults, SimulatedCamera, SimulatedScreen

from job_fakes import PROJECTOR_SIZE, FakeSink, FakeStore

ADDON = "lapig.lapig_addon"


def _module(name):
    return importlib.import_module(f"{ADDON}.{name}")


class SimulatedHardware:
    """The window and camera factories of a RealRigFactory, over the numpy fake's optics."""

    def __init__(self, faults=None, window_size=PROJECTOR_SIZE):
        self.clock = VirtualClock()
        self.faults = faults or CameraFaults(latency_s=0.1, jitter_s=0.02, drop_rate=0.05, repeat_rate=0.05,
                                             torn_rate=0.05)
        self.window_size, self.threads = window_size, set()
        self.screen = self.camera = None

    def window(self, display):
        self.threads.add(threading.current_thread().name)
        self.screen = SimulatedScreen(self.window_size, self.clock)
        return self.screen

    def camera_of(self, spec):
        optics = FakeDevice(projector_size=self.window_size, camera_size=(160, 120), seed=1)
        self.camera = SimulatedCamera(self.screen, optics, self.faults, clock=self.clock)
        return self.camera


@pytest.fixture
def rig(tmp_path, state):
    real_rig, ports = _module("rigs.real_rig"), _module("services.ports")
    hardware = SimulatedHardware()
    spec = real_rig.RigSpec(name="gallery rig", display="1", camera="0")
    factory = real_rig.RealRigFactory(spec, hardware.window, hardware.camera_of, expected_size=PROJECTOR_SIZE,
                                      clock=hardware.clock)
    store = FakeStore(state, tmp_path / "data", factory)
    return ports.Seams(store, factory, (FakeSink(),)), hardware


def test_a_real_rig_captures_on_a_worker_thread_and_records_what_it_measured(rig):
    seams, hardware = rig
    job = _module("services.capture.capture_job").CaptureJob(seams, seams.store.capture_settings())
    meta = job.run_to_completion()["meta"]
    assert threading.main_thread().name not in hardware.threads  # Blender stays responsive
    assert meta["rig"]["name"] == "gallery rig" and meta["rig"]["devices"]["camera"] == "camera 0 (auto)"
    assert meta["fingerprint"] == seams.devices.rig_identity().key() == seams.store.capture_fingerprint
    assert meta["sync"]["frame_code"].startswith("verified") and meta["sync"]["rejected"]
    assert meta["device_timing"]["latency_s"] >= 0.1 and meta["health"]["problems"] == []
    from lapig.lapig_core.rig.simulated import sync_outcome

    got = sync_outcome(seams.devices.last_device, hardware.screen, hardware.camera)
    assert got["caught"] == got["bad"] > 0 and got["false_alarms"] == 0


@pytest.mark.torch
def test_another_camera_is_another_rig_so_the_capture_is_stale(rig):
    seams, hardware = rig
    real_rig, pipeline_errors = _module("rigs.real_rig"), _module("services.pipeline_errors")
    folder = str(_module("services.capture.capture_job").CaptureJob(seams, seams.store.capture_settings(
        train_count=2, test_count=0)).run_to_completion()["setup_dir"])
    assert pipeline_errors.current_capture(seams.store.read(), folder) == folder
    seams.store.factory = real_rig.RealRigFactory(real_rig.RigSpec(name="gallery rig", display="1", camera="2"))
    with pytest.raises(pipeline_errors.PipelineError, match="changed since: capture again"):
        pipeline_errors.current_capture(seams.store.read(), folder)


def test_a_display_of_another_resolution_is_refused_before_any_frame(tmp_path, state):
    real_rig, capture_job, ports = _module("rigs.real_rig"), _module("services.capture.capture_job"), _module("services.ports")
    hardware = SimulatedHardware(window_size=(80, 60))
    factory = real_rig.RealRigFactory(real_rig.RigSpec(), hardware.window, hardware.camera_of,
                                      expected_size=PROJECTOR_SIZE, clock=hardware.clock)
    job = capture_job.CaptureJob(ports.Seams(FakeStore(state, tmp_path, factory), factory), FakeStore(
        state, tmp_path, factory).capture_settings())
    assert job.run() == "FAILED"
    assert "display is 80x60 but the scene's projector is 64x48" in str(job.error)
    assert hardware.screen.timeline == []


def test_the_rig_spec_is_data_and_says_what_is_wrong():
    RigSpec = _module("rigs.real_rig").RigSpec
    spec = RigSpec(name="lobby", display="HDMI", camera="rtsp://cam/stream", camera_settings={"exposure": -6.0})
    assert RigSpec.from_json(spec.to_json()) == spec
    for text, said in [("{", "not readable"), ("[1]", "not readable"), ('{"command": "rm"}', "unknown settings"),
                       ('{"camera_settings": {"iso": 100}}', "camera settings must be among")]:
        with pytest.raises(ValueError, match=said):
            RigSpec.from_json(text)


class FakeWindow:
    def __init__(self, size=PROJECTOR_SIZE):
        self.size, self.shown, self.is_open, self.t = size, [], True, 0.0

    def show(self, pixels):
        if not self.is_open:
            raise _module("rigs.live_output").RigError("the projector window was closed (Esc)")
        self.shown.append(pixels)
        self.t += 0.01
        return self.t

    def close(self):
        self.is_open = False


def test_the_live_window_shows_the_pixels_export_writes_and_survives_an_esc(state):
    live, ports = _module("rigs.live_output"), _module("services.ports")
    window = FakeWindow()
    sink = live.open_live(1, window_factory=lambda display: window)
    try:
        image = np.random.default_rng(0).random((24, 32, 3)).astype(np.float32)
        frame = ports.ProjectorFrame(image, *PROJECTOR_SIZE, bit_depth=16)
        assert live.open_sinks() == (sink,)
        sink.show(frame)
        expected = ((frame.pixels.astype(np.uint32) + 128) // 257).astype(np.uint8)
        np.testing.assert_array_equal(window.shown[-1], expected)
        sink.show(ports.ProjectorFrame(image, 80, 60, bit_depth=8))
        assert "the look is 80x60 but the projector's display is 64x48" in sink.problem
        window.is_open = False  # Esc
        sink.show(frame)
        assert "closed" in sink.problem and live.open_sinks() == ()
    finally:
        live.close_live()


def test_a_crossfade_plays_at_its_frame_rate():
    live = _module("rigs.live_output")
    from lapig.lapig_core.export.projector_image import crossfade_frames

    class Clock:
        now = 0.0

        def perf_counter(self):
            return self.now

        def sleep(self, s):
            self.now += s

    clock, window = Clock(), FakeWindow()
    window.show = lambda pixels: (window.shown.append(pixels), clock.now)[1]
    a, b = np.zeros((48, 64, 3), np.float32), np.ones((48, 64, 3), np.float32)
    played = live.play(window, crossfade_frames(a, b, 10, width=64, height=48), fps=25, clock=clock)
    assert played == {"frames": 10, "seconds": 0.36, "late_frames": 0}
    means = [float(p.mean()) for p in window.shown]
    assert means[0] == 0 and means[-1] == 255 and means == sorted(means)


def test_a_projection_on_the_real_rig_is_calibrated_and_verified_like_a_capture(rig):
    """Train's rendered choice and Render Real Capture project through setup_device: the rig measures its
    latency and finds its code again (no health checks), 16-bit frames go out as 8-bit."""
    seams, hardware = rig
    projection = _module("services.capture.projection")
    folder = str(_module("services.capture.capture_job").CaptureJob(seams, seams.store.capture_settings(
        train_count=2, test_count=0)).run_to_completion()["setup_dir"])
    images = np.random.default_rng(2).random((3, 24, 32, 3)).astype(np.float32)
    registered, raw = projection.project_and_capture(seams.devices, folder, images, bit_depth=16)
    assert registered.shape == (3, 24, 32, 3) and raw.shape[0] == 3
    device = seams.devices.last_device
    assert device.sync.verifies and device.health == {} and device.sync.stats.shots == 3

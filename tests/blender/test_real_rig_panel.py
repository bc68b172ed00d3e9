"""The real rig in Blender's panel and operators: the panel in both rig kinds and every state, the
refusals of an incomplete rig (one line each), Check the Rig and a capture through the operators on
simulated hardware (the rig's window and camera hooks replaced by a simulated screen and camera over the
numpy fake's optics, on a virtual clock), the camera view's image, and the live projector window on the
virtual two-monitor screen of tools/virtual_screens (marker `display`)."""
import json
import os
import subprocess
import threading
import time

import numpy as np
import pytest

bpy = pytest.importorskip("bpy")

from test_existing_result import write_fake_result  # noqa: E402
from test_panels import draw_panels  # noqa: E402

pytestmark = [pytest.mark.blender]


class Hardware:
    """The real rig's window and camera hooks, over the numpy fake's optics, on one virtual clock."""

    def __init__(self, faults=None):
        from lapig.lapig_core.rig.clock import VirtualClock
        from lapig.lapig_core.rig.simulated import CameraFaults

        self.clock = VirtualClock()
        self.faults = faults or CameraFaults(latency_s=0.08, jitter_s=0.01, drop_rate=0.03, repeat_rate=0.03)
        self.screen = self.camera = None
        self.opened = []  # the displays asked for
        self.noise = 0.003  # the optics' sensor noise

    def window(self, display):
        from lapig.lapig_core.rig.simulated import SimulatedScreen

        scene = bpy.context.scene  # the scene's projector: the display has its resolution
        p = scene.lapig.projector.lapig_projector
        self.opened.append(display)
        self.screen = SimulatedScreen((p.resolution_x, p.resolution_y), self.clock)
        return self.screen

    def camera_of(self, spec):
        from lapig.lapig_core.capture.fake_device import FakeDevice
        from lapig.lapig_core.rig.simulated import SimulatedCamera

        optics = FakeDevice(projector_size=self.screen.size, camera_size=(160, 120), noise=self.noise, seed=1)
        self.camera = SimulatedCamera(self.screen, optics, self.faults, clock=self.clock)
        return self.camera


@pytest.fixture
def hardware(monkeypatch):
    from lapig.lapig_addon.rigs import real_rig

    hw = Hardware()
    monkeypatch.setattr(real_rig, "_projector_window", hw.window)
    monkeypatch.setattr(real_rig, "_camera", hw.camera_of)
    monkeypatch.setattr(real_rig, "_clock", lambda: hw.clock)
    return hw


@pytest.fixture(autouse=True)
def nothing_left_open():
    yield
    from lapig.lapig_addon.blender import live_devices

    live_devices.stop_all()


def _real(scene, display="1", camera="0", name="gallery rig"):
    s = scene.lapig
    s.rig_kind = "REAL"
    s.real.display, s.real.camera, s.real.name = display, camera, name
    s.real.camera_source = "DEVICE"


def _texts(log):
    """The labels, a wrapped line whole again (its continuations are drawn with the BLANK1 icon)."""
    texts = []
    for entry in log:
        if entry[0] == "label":
            if entry[2] == "BLANK1" and texts:
                texts[-1] += " " + entry[1]
            else:
                texts.append(entry[1])
    return texts


def _ops(log):
    return [entry[1] for entry in log if entry[0] == "operator"]


def test_the_panel_draws_both_rig_kinds_in_every_state(small_setup, monkeypatch, tmp_path):
    from lapig.lapig_addon.blender import live_devices
    from lapig.lapig_addon.rigs import camera_view, device_list, live_output

    scene = small_setup[0]
    log = draw_panels(bpy.context, [])
    assert ("prop", "rig_kind") in log and ("prop", "transport_mode") in log and ("prop", "ambient") in log
    assert "lapig.check_rig" not in _ops(log)  # the virtual rig: no real-rig section

    _real(scene, display="", camera="")
    log = draw_panels(bpy.context, [])
    ops, texts = _ops(log), _texts(log)
    for op in ("lapig.find_devices", "lapig.choose_display", "lapig.choose_camera", "lapig.check_rig",
               "lapig.camera_view", "lapig.show_on_projector", "lapig.play_crossfade", "lapig.capture"):
        assert op in ops
    assert ("prop", "transport_mode") not in log and ("prop", "ambient") not in log  # Cycles' settings
    assert ("prop", "display") in log and ("prop", "camera_backend") in log and ("prop", "use_exposure") in log
    assert "Choose the projector's display: an index or a part of its name (Find Displays and Cameras lists them)" \
        in texts  # the rig's and the Capture panel's reason
    scene.lapig.real.camera_source = "TETHERED"
    log = draw_panels(bpy.context, [])
    assert ("prop", "tethered_folder") in log and ("prop", "camera_backend") not in log

    # found devices, a checked rig, the camera view and the live window: each says its line
    _real(scene)
    monkeypatch.setattr(device_list, "_list_displays", lambda: [
        {"index": 1, "name": "EPSON PJ", "x": 1920, "y": 0, "width": 800, "height": 600}])
    monkeypatch.setattr(device_list, "_list_cameras", lambda n: [])
    assert bpy.ops.lapig.find_devices() == {"FINISHED"}

    class Camera:
        def grab(self):
            return np.zeros((12, 16, 3), np.uint8), 0.0

        def describe(self):
            return {}

        def close(self):
            pass

    view = camera_view.start_view(live_devices.scene_state.real_rig_spec(scene), camera_factory=lambda spec: Camera())

    class Window:
        size, is_open = (160, 120), True

        def show(self, pixels):
            return 0.0

        def close(self):
            self.is_open = False

    live_output.open_live("1", window_factory=lambda display: Window())
    live_output.open_sinks()[0].problem = "the look is 80x60 but the projector's display is 160x120: set it"
    try:
        deadline = time.monotonic() + 10
        while view.latest()[0] is None:
            assert time.monotonic() < deadline
            time.sleep(0.01)
        texts = _texts(draw_panels(bpy.context, []))
    finally:
        live_devices.stop_all()
    assert "Found 1 display and 0 cameras" in texts and "Display 1 'EPSON PJ': 800x600" in texts
    assert "The projector is 160x120: set its resolution to 800x600" in texts
    assert any(t.startswith("Camera view: 16x12, ") for t in texts)
    assert "Showing on the projector, 160x120 (Esc closes it)" in texts
    assert any(t.startswith("the look is 80x60") for t in texts)


@pytest.mark.parametrize("op, said", [
    ("capture", "Choose the projector's display"),
    ("check_rig", "Choose the projector's display"),
    ("show_on_projector", "Choose the projector's display"),
    ("camera_view", "Choose the camera"),
    ("play_crossfade", "Show on Projector first"),
    ("choose_display", "Find the displays first"),
])
def test_an_incomplete_real_rig_is_refused_in_one_line(small_setup, op, said):
    from lapig.lapig_addon.rigs import device_list

    scene = small_setup[0]
    _real(scene, display="", camera="")
    device_list._FOUND["devices"] = None
    with pytest.raises(RuntimeError, match=f"^Error: {said}") as refused:
        getattr(bpy.ops.lapig, op)()
    assert "Traceback" not in str(refused.value) and len(str(refused.value).strip().splitlines()) == 1


@pytest.mark.parametrize("op", ["check_rig", "camera_view", "show_on_projector"])
def test_the_real_rigs_tools_say_so_on_a_virtual_rig(small_setup, op):
    with pytest.raises(RuntimeError, match="set Rig to Real rig"):
        getattr(bpy.ops.lapig, op)()


def test_check_and_capture_through_the_operators_on_simulated_hardware(small_setup, hardware):
    from lapig.lapig_addon.blender import scene_state
    from lapig.lapig_addon.services.panel import panel_state
    from lapig.lapig_addon.services.capture.rig_check import last_check

    scene = small_setup[0]
    s = scene.lapig
    _real(scene)
    key = scene_state.read(scene).rig.fingerprint
    assert bpy.ops.lapig.check_rig() == {"FINISHED"}
    check = last_check(key)
    assert check is not None and check.ok, check.problems
    assert [line.name for line in check.lines] == ["Latency", "Frame code", "Exposure", "Gray ramp", "Gamma"]
    texts = _texts(draw_panels(bpy.context, []))
    assert any(t.startswith("Latency: ") and t.endswith(" ms from display to camera") for t in texts)
    assert "Frame code: verified, top and bottom bands" in texts

    s.train_count, s.test_count, s.working_size = 4, 0, 128
    assert bpy.ops.lapig.capture() == {"FINISHED"}
    state = scene_state.read(scene)
    assert state.capture_fingerprint == key and state.capture_rig == "the real rig 'gallery rig'"
    assert panel_state.capture_status(state).state == "DONE" and hardware.opened == ["1", "1"]
    meta = json.load(open(os.path.join(state.capture_dir, "setup.json"), encoding="utf-8"))
    assert meta["rig"]["name"] == "gallery rig" and meta["rig"]["devices"]["camera"] == "camera 0 (auto)"
    assert meta["sync"]["frame_code"].startswith("verified") and meta["health"]["problems"] == []

    # the capture follows the rig, not the objects
    s.rig_kind = "VIRTUAL"
    state = scene_state.read(scene)
    assert panel_state.capture_status(state).text == \
        "Captured with the real rig 'gallery rig'; the scene now uses the virtual rig"
    assert panel_state.capture_blocker(state) == "Captured with another rig: capture again"
    s.rig_kind = "REAL"
    assert panel_state.capture_status(scene_state.read(scene)).state == "DONE"
    s.real.camera = "2"
    assert panel_state.capture_blocker(scene_state.read(scene)) == \
        "The real rig's display or camera changed: capture again"
    assert last_check(scene_state.read(scene).rig.fingerprint) is None  # another rig: its check is not shown


def test_a_camera_that_does_not_open_is_the_checks_one_sentence(small_setup, monkeypatch, tmp_path):
    from lapig.lapig_addon.blender import scene_state
    from lapig.lapig_addon.rigs import real_rig
    from lapig.lapig_addon.services.capture.rig_check import last_check

    hw = Hardware()  # the simulated window; the camera is the rig's own (OpenCV), on a file that is not there
    monkeypatch.setattr(real_rig, "_projector_window", hw.window)
    monkeypatch.setattr(real_rig, "_clock", lambda: hw.clock)
    scene = small_setup[0]
    missing = str(tmp_path / "missing.avi")
    _real(scene, camera=missing)
    assert bpy.ops.lapig.check_rig() == {"FINISHED"}  # the check ran: what it found is in the report area
    check = last_check(scene_state.read(scene).rig.fingerprint)
    assert check.problems == (f"no video file at {missing}: check the path",)
    assert [line.ok for line in check.lines] == [None] * 5
    # a path wider than the sidebar shows its tail ("…/missing.avi: check the path")
    said = [text for text in _texts(draw_panels(bpy.context, [])) if text.startswith("no video file at ")]
    assert said and said[0].endswith("/missing.avi: check the path")


@pytest.mark.torch  # without torch the panel names the missing package first
def test_the_virtual_capture_goes_stale_when_the_scene_switches_to_a_real_rig(small_setup, tmp_path):
    from lapig.lapig_addon.blender import scene_state
    from lapig.lapig_addon.services.panel import panel_state

    scene = small_setup[0]
    rig = scene_state.read(scene).rig
    scene_state.record_capture(scene, str(tmp_path), rig.fingerprint, rig.transport)
    assert scene.lapig.last_capture_rig == "the virtual rig"
    assert panel_state.capture_status(scene_state.read(scene)).state == "DONE"
    _real(scene)
    state = scene_state.read(scene)
    assert panel_state.capture_status(state).text == \
        "Captured with the virtual rig; the scene now uses the real rig 'gallery rig'"
    assert panel_state.capture_blocker(state) == "Captured with another rig: capture again"
    assert "Captured with another rig: capture again" in _texts(draw_panels(bpy.context, []))


def test_the_spec_is_built_from_the_panel_and_recorded_back(small_setup, tmp_path):
    from lapig.lapig_addon.blender import scene_state
    from lapig.lapig_addon.rigs.real_rig import RigSpec
    from lapig.lapig_core.rig.camera_sources import BACKENDS

    scene = small_setup[0]
    assert scene_state.real_rig_spec(scene) is None
    items = [item.identifier for item in scene.lapig.real.bl_rna.properties["camera_backend"].enum_items]
    assert sorted(items) == sorted(["auto", *BACKENDS])  # the panel offers what the cameras take
    spec = RigSpec(name="lobby", display="EPSON", camera="rtsp://cam/stream", camera_backend="FFMPEG",
                   camera_settings={"exposure": -5.0, "width": 1280, "height": 720}, frame_code=False)
    scene_state.record_real_rig(scene, spec)
    r = scene.lapig.real
    assert scene.lapig.rig_kind == "REAL" and r.use_exposure and not r.use_gain and r.camera_width == 1280
    assert scene_state.real_rig_spec(scene) == RigSpec(**{**spec.__dict__, "camera_backend": "ffmpeg"})
    scene_state.record_real_rig(scene, RigSpec(display="1", camera="", tethered_folder=str(tmp_path)))
    assert r.camera_source == "TETHERED" and scene_state.real_rig_spec(scene).tethered_folder == str(tmp_path)
    r.camera_source = "DEVICE"  # the folder stays for later, but the spec is the camera's
    assert scene_state.real_rig_spec(scene).tethered_folder == ""
    with pytest.raises(ValueError, match="unknown camera backend 'gstreamer': use one of auto, "):
        scene_state.record_real_rig(scene, RigSpec(camera_backend="gstreamer"))
    scene_state.record_real_rig(scene, None)
    assert scene.lapig.rig_kind == "VIRTUAL" and r.display == "1"  # kept for the next time


def test_the_camera_view_fills_its_image_and_stops_on_toggle_error_and_file_load(small_setup, hardware, tmp_path):
    from lapig.lapig_addon.blender import live_devices
    from lapig.lapig_addon.rigs import camera_view

    from lapig.lapig_core.rig.simulated import CameraFaults

    scene = small_setup[0]
    _real(scene, display="")  # the camera view needs no display
    hardware.faults, hardware.noise = CameraFaults(latency_s=0.05), 0.0  # every picture alike, once late enough
    hardware.window("1")  # the simulated camera looks at a screen
    hardware.screen.show(np.full((120, 160, 3), 200, np.uint8))
    assert bpy.ops.lapig.camera_view() == {"FINISHED"}
    view = camera_view.current_view()
    deadline = time.monotonic() + 20
    while view.latest()[1] < 8:  # past the latency: the screen's frame
        assert time.monotonic() < deadline and not view.error, view.error
        time.sleep(0.01)
    assert live_devices.refresh_camera_view() == live_devices.CAMERA_PERIOD_S
    picture = view.latest()[0]
    image = bpy.data.images[live_devices.IMAGE_NAME]
    assert tuple(image.size) == (160, 120)
    pixels = np.empty(160 * 120 * 4, np.float32)
    image.pixels.foreach_get(pixels)
    shown = np.round(pixels.reshape(120, 160, 4)[::-1, :, :3] * 255).astype(np.uint8)
    assert picture.mean() > 20 and np.abs(shown.astype(int) - picture).max() <= 1  # the picture, top row first
    assert bpy.ops.lapig.camera_view() == {"FINISHED"}  # toggled off
    assert camera_view.current_view() is None and not view.running
    assert live_devices.refresh_camera_view() is None  # the timer ends

    # a camera that fails: the view stops, and the panel says why
    hardware.faults.unplug_after = 3
    assert bpy.ops.lapig.camera_view() == {"FINISHED"}
    view = camera_view.current_view()
    deadline = time.monotonic() + 20
    while view.running:
        assert time.monotonic() < deadline
        time.sleep(0.01)
    assert live_devices.refresh_camera_view() is None and camera_view.current_view() is None
    said = "Camera view stopped: the camera stopped answering (unplugged?): check its cable and capture again"
    assert said in _texts(draw_panels(bpy.context, []))

    # another file: the view stops
    hardware.faults.unplug_after = None
    assert bpy.ops.lapig.camera_view() == {"FINISHED"}
    view = camera_view.current_view()
    path = str(tmp_path / "other.blend")
    bpy.ops.wm.save_as_mainfile(filepath=path, copy=True)
    bpy.ops.wm.open_mainfile(filepath=path)
    assert camera_view.current_view() is None and not view.running


class _StartingWindows:
    """ProjectorWindow as the operator reaches it: the window of a helper process that starts when the test
    says so (up to 20 s for a real one), or fails to; which thread opened each."""

    def __init__(self, fails: str = ""):
        self.started, self.release, self.fails = threading.Event(), threading.Event(), fails
        self.threads, self.windows = [], []

    def __call__(self, display, **kwargs):
        from lapig.lapig_core.rig import RigError

        self.started.set()
        assert self.release.wait(20)
        self.threads.append(threading.current_thread())
        if self.fails:
            raise RigError(self.fails)

        class Window:
            size, is_open, shown = (160, 120), True, []

            def show(self, pixels):
                self.shown.append(pixels)
                return time.perf_counter()

            def close(self):
                self.is_open = False

        self.windows.append(Window())
        return self.windows[-1]


@pytest.fixture
def starting_windows(monkeypatch):
    from lapig.lapig_core.rig import projector_window

    windows = _StartingWindows()
    monkeypatch.setattr(projector_window, "ProjectorWindow", windows)
    return windows


def test_show_on_projector_starts_the_windows_helper_off_the_main_thread(small_setup, starting_windows):
    from lapig.lapig_addon.rigs import live_output

    _real(small_setup[0])
    starting_windows.release.set()
    assert bpy.ops.lapig.show_on_projector() == {"FINISHED"}
    assert starting_windows.threads, "no window was opened"
    assert threading.main_thread() not in starting_windows.threads, "the window's helper started on Blender's main thread"
    assert live_output.open_sinks()[0].window is starting_windows.windows[0]
    assert bpy.ops.lapig.show_on_projector() == {"FINISHED"}  # again: closed
    assert not live_output.open_sinks()


def test_the_panel_says_the_window_is_opening_esc_cancels_and_a_failure_is_one_line(small_setup, starting_windows):
    from lapig.lapig_addon.blender import live_devices
    from lapig.lapig_addon.blender.modal_runner import SLOTS
    from lapig.lapig_addon.rigs import live_output

    _real(small_setup[0])
    job = live_devices.projector_job(small_setup[0])  # what the operator runs, stepped as its timer does
    job.poll_timeout = 0
    assert SLOTS.start_foreground(job) is None
    try:
        deadline = time.monotonic() + 20
        while not job.message.startswith("opening"):
            assert time.monotonic() < deadline, job.message
            job.step()
            time.sleep(0.01)
        log = draw_panels(bpy.context, [])
        opening = ("progress", "opening the projector window on display 1 (Esc to cancel)")
        assert log[log.index(("operator", "lapig.show_on_projector")) - 1] == opening  # above the window's button
        job.cancel()  # Esc
        assert job.state == "CANCELLED"
    finally:
        SLOTS.end_foreground(job)
        starting_windows.release.set()
        job.stop()
    assert not live_output.open_sinks() and not starting_windows.windows[0].is_open
    assert not [e for e in draw_panels(bpy.context, []) if e[0] == "progress"]

    starting_windows.fails = "the projector window did not open on display '1': the helper did not start within 20 s"
    with pytest.raises(RuntimeError) as failed:
        bpy.ops.lapig.show_on_projector()
    said = str(failed.value).strip()
    assert said == ("Error: LAPIG projector window failed: the projector window did not open on display '1': the "
                    "helper did not start within 20 s") and not live_output.open_sinks()


# ------------------------------------------------------------------ the live window on a virtual screen

@pytest.fixture(scope="module")
def two_monitors():
    from lapig.tools import virtual_screens

    if virtual_screens.missing_tools():
        pytest.skip("needs " + "; ".join(virtual_screens.missing_tools()))
    with virtual_screens.two_monitors() as env:
        yield env


@pytest.mark.display
def test_show_on_projector_shows_the_result_every_generate_and_the_crossfade(small_setup, two_monitors, monkeypatch,
                                                                             tmp_path):
    from lapig.lapig_addon.blender import scene_store
    from lapig.lapig_addon.rigs import live_output
    from lapig.lapig_addon.services.ports import ProjectorFrame
    from lapig.tools.virtual_screens import region, screenshot

    for name in ("WAYLAND_DISPLAY", "SDL_VIDEODRIVER"):
        monkeypatch.delenv(name, raising=False)
    monkeypatch.setenv("DISPLAY", two_monitors["DISPLAY"])
    scene, projector = small_setup[0], small_setup[1]
    projector.lapig_projector.resolution_x, projector.lapig_projector.resolution_y = 800, 600  # display 1's
    _real(scene, display="1")
    s = scene.lapig
    s.result_dir = write_fake_result(tmp_path / "result")

    assert bpy.ops.lapig.show_on_projector() == {"FINISHED"}
    sinks = live_output.open_sinks()
    assert len(sinks) == 1 and sinks[0].problem == ""
    frame = scene_store.scene_result_frame(scene)
    assert frame.pixels.shape == (600, 800, 3) and frame.pixels.dtype == np.uint8
    assert np.array_equal(region(screenshot(two_monitors), 1), frame.pixels)  # the look Export writes, 1:1
    texts = _texts(draw_panels(bpy.context, []))
    assert "Showing on display 1 'VNC-1', 800x600 (Esc closes it)" in texts

    # a Generate shows its look through the scene's seams
    look = ProjectorFrame(np.random.default_rng(3).random((48, 64, 3)).astype(np.float32), 800, 600, 8)
    scene_store.scene_seams(scene).show(look)
    assert np.array_equal(region(screenshot(two_monitors), 1), look.pixels)

    # the crossfade ends on the result's look with PSA
    s.crossfade_frames, s.crossfade_fps = 6, 60.0
    assert bpy.ops.lapig.play_crossfade() == {"FINISHED"}
    assert np.array_equal(region(screenshot(two_monitors), 1), frame.pixels)

    # a look of another size: the window keeps its picture and the panel says why
    scene_store.scene_seams(scene).show(ProjectorFrame(look.image, 640, 480, 8))
    texts = _texts(draw_panels(bpy.context, []))
    assert any(t.startswith("the look is 640x480 but the projector's display is 800x600") for t in texts)

    # Esc in the window closes it; the panel follows
    info = sinks[0].window.describe()
    press = subprocess.run(["xdotool", "windowfocus", "--sync", str(info["x11_window"]), "key", "Escape"],
                           env=two_monitors, capture_output=True, text=True, timeout=30)
    assert press.returncode == 0, press.stderr
    deadline = time.monotonic() + 10
    while live_output.open_sinks():
        assert time.monotonic() < deadline, "the window did not close on Esc"
        time.sleep(0.05)
    texts = _texts(draw_panels(bpy.context, []))
    assert not any(t.startswith("Showing on") for t in texts)
    assert "The projector window was closed (Esc or its close button)" in texts
    with pytest.raises(RuntimeError, match="Show on Projector first"):
        bpy.ops.lapig.play_crossfade()


def test_rig_real_on_the_command_line_over_a_scene_rig_without_a_display_says_what_to_pass(small_setup):
    import argparse

    from lapig.lapig_addon.cli import rig_choice

    scene = small_setup[0]
    _real(scene, display="", camera="0")
    args = argparse.Namespace(rig="real", display=None, camera_source=None, tethered=None, camera_backend=None,
                              rig_name=None, frame_code=None, exposure=None, gain=None, focus=None,
                              white_balance=None)
    with pytest.raises(ValueError, match=r"^--rig real needs --display and --camera \(or --tethered DIR\)"):
        rig_choice.apply(args, scene)
    args.display, args.exposure = "EPSON", -5.0
    assert rig_choice.apply(args, scene) is None
    r = scene.lapig.real
    assert r.display == "EPSON" and r.camera == "0" and r.use_exposure and r.exposure == -5.0  # the panel shows it


@pytest.mark.torch
def test_capture_train_generate_refine_and_export_through_the_operators_on_simulated_hardware(small_setup, hardware,
                                                                                          tmp_path):
    """The real rig's whole chain as the artist runs it: Train's rendered choice projects and captures on the
    rig (as Refine does), Generate, Refine on the rig and Export after it."""
    from lapig.lapig_addon.blender import scene_state

    scene = small_setup[0]
    s = scene.lapig
    _real(scene)
    s.train_count, s.test_count, s.working_size, s.finetune_iterations = 10, 2, 64, 3
    assert bpy.ops.lapig.capture() == {"FINISHED"}
    assert bpy.ops.lapig.train_models() == {"FINISHED"}
    assert "in captures on the rig 'gallery rig' of 2 held-back images" in s.models_status, s.models_status
    s.prompt = "charcoal"
    assert bpy.ops.lapig.generate() == {"FINISHED"}
    assert bpy.ops.lapig.refine_result() == {"FINISHED"}
    result = json.load(open(os.path.join(bpy.path.abspath(s.result_dir), "result.json"), encoding="utf-8"))
    assert 1 <= result["refine"]["iterations"] and result["refine"]["images"]["projector"].startswith("projector_refined")
    out = str(tmp_path / "projector.png")
    assert bpy.ops.lapig.export_image(filepath=out) == {"FINISHED"}
    assert os.path.isfile(out) and os.path.isfile(str(tmp_path / "projector.json"))
    assert scene_state.read(scene).rig.kind == "REAL"

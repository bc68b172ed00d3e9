"""The installer's tools of a real rig, with bpy blocked: what an incomplete rig says, the rig check (its
lines and problems) on simulated hardware on a worker thread, the camera view's worker, the device search,
the crossfade played on a live window, and what the panel says when the rig changes."""
import importlib
import threading
import time

import numpy as np
import pytest

from lapig.lapig_core.rig.simulated import CameraFaults

from job_fakes import PROJECTOR_SIZE, FakeSink, FakeStore
from test_real_rig import FakeWindow, SimulatedHardware

ADDON = "lapig.lapig_addon"


def _module(name):
    return importlib.import_module(f"{ADDON}.{name}")


def _rig(tmp_path, state, hardware, spec=None):
    real_rig, ports = _module("rigs.real_rig"), _module("services.ports")
    spec = spec or real_rig.RigSpec(name="gallery rig", display="1", camera="0")
    factory = real_rig.RealRigFactory(spec, hardware.window, hardware.camera_of, expected_size=PROJECTOR_SIZE,
                                      clock=hardware.clock)
    return ports.Seams(FakeStore(state, tmp_path / "data", factory), factory, (FakeSink(),))


def _check(seams):
    job = _module("services.capture.rig_check").RigCheckJob(seams, seams.store.capture_settings())
    return job.run_to_completion()


# ------------------------------------------------------------------------------- an incomplete rig

def test_an_incomplete_rig_says_what_to_choose_and_opens_nothing(tmp_path, state):
    real_rig = _module("rigs.real_rig")
    RigSpec = real_rig.RigSpec
    assert "Choose the projector's display" in RigSpec(display="", camera="0").problem()
    assert "Choose the camera" in RigSpec(display="1", camera=" ").problem()
    assert RigSpec(display="1", camera="", tethered_folder="/shots").problem() == ""
    assert RigSpec(display="", camera="0").problem(display=False) == ""  # the camera view needs no display
    assert RigSpec(display="1", camera="").problem(camera=False) == ""  # nor the live window a camera
    hardware = SimulatedHardware()
    seams = _rig(tmp_path, state, hardware, RigSpec(display="", camera="0"))
    job = _module("services.capture.capture_job").CaptureJob(seams, seams.store.capture_settings())
    assert job.run() == "FAILED" and "Choose the projector's display" in str(job.error)
    assert hardware.screen is None  # no window was opened
    assert _check(seams).problems[0].startswith("Choose the projector's display")


def test_the_capture_blocker_of_a_real_rig_names_the_missing_device(state, panel_state):
    rig = state.Rig(projector="P", camera="C", target="T", scene="S", fingerprint="abc", kind="REAL",
                    label="the real rig 'x'", devices_problem="Choose the camera: an index")
    assert panel_state.rig_blocker(rig) == ""  # the objects are there: preview and export still work
    assert panel_state.device_blocker(rig) == "Choose the camera: an index"
    with pytest.raises(Exception, match="Choose the camera"):
        _module("services.capture.capture_job").check_rig(type("Store", (), {"read": lambda self: state.SceneState(rig=rig)})())


# ------------------------------------------------------------------------------------ the rig check

def test_the_rig_check_measures_on_a_worker_thread_and_says_a_line_per_check(tmp_path, state):
    hardware = SimulatedHardware()
    seams = _rig(tmp_path, state, hardware)
    check = _check(seams)
    assert threading.main_thread().name not in hardware.threads
    assert check.ok and check.rig_key == seams.devices.rig_identity().key()
    lines = {line.name: line for line in check.lines}
    assert list(lines) == ["Latency", "Frame code", "Exposure", "Gray ramp", "Gamma"]
    assert all(line.ok for line in check.lines), [line.label() for line in check.lines]
    latency_ms = float(lines["Latency"].text.split()[0])
    assert 100 <= latency_ms < 300  # the simulated camera's 0.1 s and its jitter, at its frame pace
    assert lines["Frame code"].text == "verified, top and bottom bands"
    assert lines["Gamma"].text.startswith(("1.", "2.", "3.", "4."))
    rig_check = _module("services.capture.rig_check")
    assert rig_check.last_check(check.rig_key) is check and rig_check.last_check("another rig") is None
    assert hardware.screen.timeline  # it showed frames, and captured nothing: no data set was written
    assert not (tmp_path / "data").exists()


def test_a_drifting_auto_exposure_fails_the_ramp_and_says_what_to_change(tmp_path, state):
    hardware = SimulatedHardware(CameraFaults(latency_s=0.05, auto_exposure=True, exposure_lockable=False))
    check = _check(_rig(tmp_path, state, hardware))
    lines = {line.name: line for line in check.lines}
    assert not check.ok and lines["Gray ramp"].ok is False
    assert any("auto exposure" in problem and "lock" in problem for problem in check.problems)


def test_a_camera_that_does_not_see_the_projection_is_one_sentence_and_the_rest_unmeasured(tmp_path, state):
    class Blind(SimulatedHardware):
        def camera_of(self, spec):
            camera = super().camera_of(spec)
            camera.optics.gain = 0.0  # the lens cap is on
            camera.optics.ambient = 0.0
            return camera

    check = _check(_rig(tmp_path, state, Blind(CameraFaults(latency_s=0.05))))
    assert len(check.problems) == 1 and "does not see the projector change from black to white" in check.problems[0]
    assert [(line.name, line.ok) for line in check.lines] == [
        ("Latency", None), ("Frame code", None), ("Exposure", None), ("Gray ramp", None), ("Gamma", None)]


def test_opening_the_rig_lets_go_of_the_live_window_and_the_camera_view(tmp_path, state):
    live, view = _module("rigs.live_output"), _module("rigs.camera_view")
    window = FakeWindow()
    live.open_live(1, window_factory=lambda display: window)
    hardware = SimulatedHardware()
    seams = _rig(tmp_path, state, hardware)
    view.start_view(seams.devices.spec, camera_factory=lambda spec: _StillCamera())
    try:
        assert _check(seams).ok
        assert not window.is_open and live.open_sinks() == () and view.current_view() is None
    finally:
        view.stop_view()
        live.close_live()


# ------------------------------------------------------------------------------------ the camera view

def _addon_rig_error(message):
    """The add-on's own RigError (lapig.lapig_core, not the top-level lapig_core), as its cameras raise it."""
    return importlib.import_module("lapig.lapig_core.rig").RigError(message)


class _StillCamera:
    """A camera that answers at once with a numbered gray picture; fails after ``fail_after`` grabs."""

    def __init__(self, fail_after=None):
        self.grabs, self.fail_after, self.closed = 0, fail_after, False
        self.thread = None

    def grab(self):
        self.thread = threading.current_thread().name
        self.grabs += 1
        if self.fail_after is not None and self.grabs > self.fail_after:
            raise _addon_rig_error("the camera stopped answering (unplugged?): check its cable")
        return np.full((30, 40, 3), self.grabs % 256, np.uint8), time.perf_counter()

    def describe(self):
        return {"kind": "still camera"}

    def close(self):
        self.closed = True


def _wait(condition, timeout_s=10.0):
    deadline = time.monotonic() + timeout_s
    while not condition():
        assert time.monotonic() < deadline, "timed out"
        time.sleep(0.01)


def test_the_camera_view_grabs_on_its_own_thread_until_stopped():
    view_module, RigSpec = _module("rigs.camera_view"), _module("rigs.real_rig").RigSpec
    camera = _StillCamera()
    view = view_module.start_view(RigSpec(display="", camera="0"), camera_factory=lambda spec: camera)
    try:
        _wait(lambda: view.latest()[1] >= 3)
        image, frames = view.latest()
        assert image.shape == (30, 40, 3) and camera.thread.startswith("LAPIG: ")
        text, ok = view_module.status()
        assert ok and text.startswith("Camera view: 40x30, ") and text.endswith(" pictures")
        # no faster than MIN_PERIOD_S: a camera that answers at once is not read in a busy loop
        time.sleep(0.2)
        assert view.latest()[1] - frames < 0.2 / view_module.MIN_PERIOD_S + 3
    finally:
        view_module.stop_view()
    assert not view.running and camera.closed and view_module.current_view() is None


def test_a_failing_camera_ends_the_view_with_its_sentence():
    view_module, RigSpec = _module("rigs.camera_view"), _module("rigs.real_rig").RigSpec
    camera = _StillCamera(fail_after=2)
    view = view_module.start_view(RigSpec(camera="0"), camera_factory=lambda spec: camera)
    _wait(lambda: not view.running)
    assert view.error == "the camera stopped answering (unplugged?): check its cable" and camera.closed
    view_module.stop_view(view.error)  # what Blender's timer does
    assert view_module.status() == ("Camera view stopped: the camera stopped answering (unplugged?): check its cable",
                                    False)


def test_the_camera_view_refuses_a_tethered_folder_or_no_camera():
    view_module, RigSpec = _module("rigs.camera_view"), _module("rigs.real_rig").RigSpec
    with pytest.raises(ValueError, match="needs a live camera"):
        view_module.start_view(RigSpec(camera="", tethered_folder="/shots"))
    with pytest.raises(ValueError, match="Choose the camera"):
        view_module.start_view(RigSpec(camera=""))
    assert view_module.current_view() is None


# --------------------------------------------------------------------------------- the device search

def test_the_device_search_keeps_both_lists_and_says_why_one_failed(monkeypatch):
    device_list = _module("rigs.device_list")
    displays = [{"index": 0, "name": "DELL", "x": 0, "y": 0, "width": 1920, "height": 1080},
                {"index": 1, "name": "EPSON PJ", "x": 1920, "y": 0, "width": 800, "height": 600}]
    monkeypatch.setattr(device_list, "_list_displays", lambda: displays)
    monkeypatch.setattr(device_list, "_list_cameras", lambda n: [{"index": 0, "backend": "V4L2", "width": 640,
                                                                  "height": 480}])
    job = device_list.FindDevicesJob()
    found = job.run_to_completion()
    assert device_list.found() is found and found.problems == ()
    assert found.summary() == "Found 2 displays and 1 camera"
    assert [item[:2] for item in found.display_items()] == [("0", "0: DELL (1920x1080)"),
                                                            ("1", "1: EPSON PJ (800x600)")]
    assert found.camera_items()[0][:2] == ("0", "0: V4L2 (640x480)")
    assert device_list.display_note(found, "epson", (800, 600)) == [("Display 1 'EPSON PJ': 800x600", True)]
    assert device_list.display_note(found, "1", (160, 120))[1] == (
        "The projector is 160x120: set its resolution to 800x600", False)
    text, ok = device_list.display_note(found, "BenQ", (800, 600))[0]
    assert not ok and text.startswith("no display's name contains 'BenQ'")
    assert device_list.display_note(None, "1", (800, 600)) == []  # nothing searched: nothing said

    def no_screen():
        raise _addon_rig_error("the displays could not be listed: there is no screen here")

    monkeypatch.setattr(device_list, "_list_displays", no_screen)
    found = device_list.find_devices()
    assert found.displays == () and len(found.cameras) == 1
    assert found.problems == ("the displays could not be listed: there is no screen here",)


# ---------------------------------------------------------------------------- live window, crossfade

@pytest.fixture
def result_folder(tmp_path):
    from lapig.lapig_core.export.result_files import write_result

    h, w = PROJECTOR_SIZE[1], PROJECTOR_SIZE[0]
    ramp = np.broadcast_to(np.linspace(0, 1, w, dtype=np.float32)[None, :, None], (h, w, 3)).copy()
    return str(write_result(tmp_path / "result", {"projector": ramp, "projector_nopsa": ramp[:, ::-1] * 0.5},
                            {"prompt": "a ramp"}))


def test_the_crossfade_plays_on_the_live_window_and_ends_on_the_look(tmp_path, state, result_folder):
    live, ports, export_result = _module("rigs.live_output"), _module("services.ports"), _module(
        "services.export.export_result")
    store = FakeStore(state, tmp_path, None)
    window = FakeWindow()
    sink = live.open_live(1, window_factory=lambda display: window)
    try:
        job = live.CrossfadeJob(sink, store, result_folder, frames=5, fps=500.0)
        played = job.run_to_completion()
        assert played["frames"] == 5 and len(window.shown) == 5
        end = export_result.result_frame(store, result_folder, 8)
        np.testing.assert_array_equal(window.shown[-1], end.pixels)  # the last frame is the look Export writes
        assert [line for line in live.status_lines()] == [
            ("Showing on the projector, 64x48 (Esc closes it)", True)]
        sink.show(ports.ProjectorFrame(end.image, 80, 60, 8))
        assert live.status_lines()[1] == (
            "the look is 80x60 but the projector's display is 64x48: set the projector's resolution to the "
            "display's, then Generate", False)
        small = live.open_live(1, window_factory=lambda display: FakeWindow((32, 24)))
        with pytest.raises(ValueError, match="the look is 64x48 but the projector's display is 32x24"):
            live.CrossfadeJob(small, store, result_folder, frames=5, fps=30).check()
        assert live.open_sinks() == (small,) and not window.is_open  # one live window: the first one closed
        small.window.is_open = False  # Esc in the window
        assert live.open_sinks() == ()
        assert live.status_lines() == [("The projector window was closed (Esc or its close button)", None)]
    finally:
        live.close_live()
    assert live.status_lines() == []  # closed on purpose: nothing to say


class _SlowWindows:
    """A window factory whose windows open when the test says so, as the helper process does after its start
    (up to 20 s): which thread opened each, and each window made."""

    def __init__(self, fails: str = ""):
        self.started, self.release, self.fails = threading.Event(), threading.Event(), fails
        self.threads, self.windows = [], []

    def __call__(self, display):
        self.started.set()
        assert self.release.wait(10)
        self.threads.append(threading.current_thread())
        if self.fails:
            raise _module("rigs.live_output").RigError(self.fails)
        self.windows.append(FakeWindow())
        return self.windows[-1]


def _step_until(job, condition, limit_s=10.0):
    """Step the job as Blender's timer does (never waiting); the longest step in seconds."""
    job.poll_timeout, longest, deadline = 0, 0.0, time.monotonic() + limit_s
    while not condition():
        assert time.monotonic() < deadline, job.message
        t = time.perf_counter()
        job.step()
        longest = max(longest, time.perf_counter() - t)
        time.sleep(0.005)
    return longest


def test_the_projector_window_opens_in_a_job_that_never_holds_the_main_thread(result_folder):
    from lapig.lapig_core.export.result_files import read_output_image

    live, ports = _module("rigs.live_output"), _module("services.ports")
    look = live.StoredLook(result_folder, *PROJECTOR_SIZE, bit_depth=8)
    windows = _SlowWindows()
    job = live.OpenWindowJob("1", look, window_factory=windows)
    try:
        longest = _step_until(job, windows.started.is_set)
        longest = max(longest, _step_until(job, lambda: job.message.startswith("opening")))
        assert job.message == "opening the projector window on display 1" and live.open_sinks() == ()
        windows.release.set()
        longest = max(longest, _step_until(job, lambda: job.finished))
        assert job.state == "DONE", job.message
        assert longest < 0.1 and threading.main_thread() not in windows.threads
        assert live.open_sinks() == (job.result,) and job.result.window is windows.windows[0]
        expected = ports.ProjectorFrame(read_output_image(result_folder, "projector"), *PROJECTOR_SIZE, 8).pixels
        np.testing.assert_array_equal(windows.windows[0].shown[-1], expected)  # the look Export writes
    finally:
        live.close_live()

    # Esc while the helper starts: the job ends at once, and the window, once open, is closed and never live
    windows = _SlowWindows()
    job = live.OpenWindowJob("1", live.StoredLook(), window_factory=windows)
    _step_until(job, windows.started.is_set)
    job.cancel()
    assert job.state == "CANCELLED"
    windows.release.set()
    job.stop()  # waits for the worker
    assert len(windows.windows) == 1 and not windows.windows[0].is_open and live.open_sinks() == ()

    # a helper that does not start: the job fails with its one line, and nothing is live
    said = "the projector window did not open on display '1': the helper did not start within 20 s; its stderr: nothing"
    windows = _SlowWindows(fails=said)
    windows.release.set()
    job = live.OpenWindowJob("1", live.StoredLook(), window_factory=windows)
    assert job.run() == "FAILED" and job.message == said and live.open_sinks() == ()

    # no result yet: the identification frame
    windows = _SlowWindows()
    windows.release.set()
    sink = live.OpenWindowJob("1", live.StoredLook(), window_factory=windows).run_to_completion()
    try:
        np.testing.assert_array_equal(windows.windows[0].shown[-1], live.identification_frame(PROJECTOR_SIZE))
        assert live.open_sinks() == (sink,)
    finally:
        live.close_live()


def test_the_identification_frame_outlines_the_display():
    frame = _module("rigs.live_output").identification_frame((64, 48))
    assert frame.shape == (48, 64, 3) and frame.dtype == np.uint8
    assert (frame[0] == 255).all() and (frame[:, -1] == 255).all() and (frame[24, 32] == 128).all()


# ------------------------------------------------------------------------------ staleness of a rig change

def test_switching_rigs_makes_the_capture_stale_and_says_which_rig(state, panel_state, tmp_path):
    virtual = state.Rig(projector="P", camera="C", target="T", scene="S", fingerprint="v1", transport="Fast",
                        projector_size=(64, 48))
    real = state.Rig(projector="P", camera="C", target="T", scene="S", fingerprint="r1", transport="Fast",
                     projector_size=(64, 48), kind="REAL", label="the real rig 'gallery'")
    captured = dict(capture_dir=str(tmp_path), capture_fingerprint="v1", capture_transport="Fast",
                    capture_rig="the virtual rig", result_dir=str(tmp_path), result_fingerprint="v1")
    now_real = state.SceneState(rig=real, **captured)
    assert panel_state.capture_status(now_real) == panel_state.StepStatus(
        "STALE", "Captured with the virtual rig; the scene now uses the real rig 'gallery'")
    assert panel_state.capture_blocker(now_real) == "Captured with another rig: capture again"
    assert panel_state.result_status(now_real).text == \
        "Made with the virtual rig; the scene now uses the real rig 'gallery'"
    assert panel_state.capture_status(state.SceneState(rig=virtual, **captured)).state == "DONE"  # back again
    # the same real rig with another camera: its identity changed, not its name
    same_name = state.SceneState(rig=real, **{**captured, "capture_fingerprint": "r0",
                                              "capture_rig": "the real rig 'gallery'", "result_fingerprint": "r0"})
    assert panel_state.capture_status(same_name).text == "The real rig's display or camera changed since the capture"
    assert panel_state.capture_blocker(same_name) == "The real rig's display or camera changed: capture again"
    assert panel_state.result_status(same_name).text == "The real rig changed since this result"
    # a capture from before the rig was recorded: the reason is the general one
    unknown = state.SceneState(rig=real, **{**captured, "capture_rig": ""})
    assert panel_state.capture_blocker(unknown) == "The real rig's display or camera changed: capture again"

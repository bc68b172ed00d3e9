"""A real rig of two projectors with bpy blocked: RealRigFactory opens one window per display and the one camera
(here simulated windows and a simulated camera over the numpy fake rig), the capture job drives them on a worker
thread, the rig check says a line per check per projector, two projectors on one display are refused before any
window opens, and Show on Projector's job opens every projector's window at once, presenting together."""
import importlib
import threading

import numpy as np

from lapig.tools.fakes.fake_rig import FakeProjector, FakeRig, FakeRigDevice, homography_onto
from lapig.lapig_core.rig.clock import VirtualClock
from lapig.lapig_core.rig.frame_lock import LockedWindows
from lapig.tools.fakes.simulated_window import SimulatedWindow
from lapig.lapig_core.rig.multi_rig import SimulatedScreens, _SummedOptics
from lapig.lapig_core.rig.simulated import CameraFaults, SimulatedCamera, SimulatedScreen

from test_multi_jobs import MultiStore

ADDON = "lapig.lapig_addon"
CAMERA, PROJECTOR = (128, 96), (96, 72)


def _module(name):
    return importlib.import_module(f"{ADDON}.{name}")


class Hardware:
    """Two simulated windows (display '1' and '2') and one simulated camera seeing both, opened by the factory's
    hooks; the threads that opened them are kept."""

    def __init__(self):
        quads = ([(0.03, 0.08), (0.63, 0.05), (0.61, 0.95), (0.02, 0.92)],
                 [(0.37, 0.06), (0.97, 0.09), (0.98, 0.93), (0.39, 0.94)])
        self.rig = FakeRig([FakeProjector(PROJECTOR, homography_onto(PROJECTOR, CAMERA, q)) for q in quads], CAMERA,
                           noise=0.0, object_mask=np.ones(CAMERA[::-1], bool))
        self.clock = VirtualClock()
        self.screens = {d: SimulatedScreen(PROJECTOR, self.clock) for d in ("1", "2")}
        self.opened, self.threads = [], set()

    def window(self, display):
        self.opened.append(display)
        self.threads.add(threading.current_thread().name)
        return self.screens[display]

    def camera(self, spec):
        together = SimulatedScreens([self.screens["1"], self.screens["2"]])
        return SimulatedCamera(together, _SummedOptics(FakeRigDevice(self.rig), [PROJECTOR] * 2),
                               CameraFaults(latency_s=0.05, drop_rate=0.03), clock=self.clock)


class Store(MultiStore):
    def read(self):
        state = super().read()
        rig = type(state.rig)(**{**state.rig.__dict__, "projector_size": PROJECTOR,
                                 "projector_sizes": (PROJECTOR, PROJECTOR)})
        return type(state)(**{**state.__dict__, "rig": rig})


def _seams(tmp_path, displays=("1", "2")):
    real_rig, ports, state = _module("rigs.real_rig"), _module("services.ports"), _module("services.state")
    hardware = Hardware()
    store = Store(state, tmp_path / "data", kind="REAL", displays=displays)
    factory = real_rig.RealRigFactory(real_rig.RigSpec(name="gallery rig", display=displays[0], camera="0"),
                                      hardware.window, hardware.camera, clock=hardware.clock,
                                      projectors=tuple(zip(("Left", "Right"), displays, (PROJECTOR, PROJECTOR))))
    return ports.Seams(store, factory), store, hardware


def test_the_capture_job_opens_a_window_per_display_and_one_camera_on_a_worker(tmp_path):
    seams, store, hardware = _seams(tmp_path)
    job = _module("services.capture.capture_job").CaptureJob(seams, store.capture_settings())
    assert job.run() == "DONE", job.error
    assert sorted(hardware.opened) == ["1", "2"] and threading.main_thread().name not in hardware.threads
    meta = job.result["meta"]
    assert meta["device"] == "gallery rig" and [p["name"] for p in meta["projectors"]] == ["Left", "Right"]
    assert all(p["sync"]["frame_code"] == "verified, top and bottom bands" for p in meta["projectors"])
    assert store.models.startswith("First look (joint classical model of 2 projectors)")
    assert all(len(s.timeline) > 50 for s in hardware.screens.values())


def test_the_rig_check_says_each_projectors_lines(tmp_path):
    seams, store, hardware = _seams(tmp_path)
    check = _module("services.capture.rig_check").RigCheckJob(seams, store.capture_settings()).run_to_completion()
    names = [line.name for line in check.lines]
    assert names[:5] == ["Left: Latency", "Left: Frame code", "Left: Exposure", "Left: Gray ramp", "Left: Gamma"]
    assert names[5:] == [n.replace("Left", "Right") for n in names[:5]]
    assert check.ok and all(line.ok for line in check.lines), [line.label() for line in check.lines]


def test_two_projectors_on_one_display_open_no_window(tmp_path):
    seams, store, hardware = _seams(tmp_path, displays=("1", "1"))
    job = _module("services.capture.capture_job").CaptureJob(seams, store.capture_settings())
    assert job.run() == "FAILED"
    assert str(job.error) == "Projectors 'Left' and 'Right' are both on display '1': give each its own display"
    assert hardware.opened == [] and store.capture_dir == ""
    real_rig = _module("rigs.real_rig")  # the factory says the same where it opens the windows
    assert real_rig.multi_display_problem([("A", "1", None), ("B", " 1", None)]) == \
        "Projectors 'A' and 'B' are both on display '1': give each its own display"


def test_show_on_projector_opens_every_window_at_once_presenting_together():
    live_output, ports = _module("rigs.live_output"), _module("services.ports")
    windows = {}

    def factory(display):
        windows[display] = SimulatedWindow({"1": (64, 48), "2": (80, 60)}[display])
        return windows[display]

    job = live_output.OpenWindowsJob(["1", "2"], window_factory=factory, names=["Left", "Right"])
    sink = job.run_to_completion()
    try:
        assert sorted(windows) == ["1", "2"] and isinstance(sink, live_output.LockedWindowsSink)
        assert [w.shown.shape[:2] for w in (windows["1"], windows["2"])] == [(48, 64), (60, 80)]  # identification
        assert sink.skew_frames is None or sink.skew_frames <= 1.0
        image = np.full((60, 80, 3), 0.5, np.float32)
        sink.show(ports.ProjectorFrame(image, 80, 60, 8, projector_index=1))  # Generate's frame of projector 2
        assert sink.problem == "" and abs(int(windows["2"].shown[30, 40, 0]) - 128) <= 1
        assert windows["1"].frames == 2 and windows["2"].frames == 2  # both presented again, together
        assert sink.skew_frames <= 1.0
        assert live_output.status_lines()[0] == ("Showing 2 projectors, presented together (Esc in one closes it)",
                                                 True)
    finally:
        live_output.close_live()
    assert not windows["1"].is_open and not windows["2"].is_open


def test_a_result_of_several_goes_to_the_live_windows_in_one_presentation(tmp_path):
    from lapig.lapig_core.export.result_files import write_result

    live_output, ports = _module("rigs.live_output"), _module("services.ports")
    generate_joint = _module("services.generate.generate_joint")
    windows = [SimulatedWindow((64, 48)), SimulatedWindow((64, 48))]
    sink = live_output.LockedWindowsSink(LockedWindows(windows))
    folder = tmp_path / "result"
    write_result(folder, {"projector_1": np.full((48, 64, 3), 0.2, np.float32),
                          "projector_2": np.full((48, 64, 3), 0.8, np.float32)},
                 {"multi": {"count": 2}, "projectors": [{"image": "projector_1.png", "size": [64, 48]},
                                                         {"image": "projector_2.png", "size": [64, 48]}]})

    class Store:
        def export_settings(self):
            return type("Settings", (), {"bit_depth": 8})()

    generate_joint.show_projector_images(ports.Seams(Store(), None, (sink,)),
                                             {"folder": str(folder), "summary": {}})
    assert [w.frames for w in windows] == [1, 1]  # one presentation, both windows
    assert [int(w.shown[5, 5, 0]) for w in windows] == [51, 204] and sink.skew_frames <= 1.0

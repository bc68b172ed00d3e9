"""`python -m lapig_addon bench hardware --json`: the real-rig path on simulated hardware (issue 26).

One scene (the numpy fake projector and camera, 320x240 projector, 400x300 camera) captured through the
real rig's device (lapig_core.rig.rig_device) several ways, on a virtual clock, so the seconds are the
rig's own (its waits and the camera's pace), not this machine's:

- clean: no latency, no faults: the registration and the false alarms of a clean run;
- latency only: 100 ms, no faults: the pace of a well-behaved camera;
- faulty: 100 ms latency with 30 ms jitter, 5 % each of dropped, repeated and torn frames, noise; and a
  camera that turns later than measured half-way: how many bad pictures the frame code caught;
- drifting: an auto exposure that cannot be locked, and one that can;
- the projector window on a virtual two-monitor screen (tools/virtual_screens): pixel-exact, on the
  chosen monitor, and the time from a finished Generate's frame to the look on the window.

The public code's pace, for comparison: a fixed 0.2 s pause and 13 dropped frames at 30 fps per pattern
(0.2 + 13 / 30 = 0.633 s).
"""
from __future__ import annotations

import os
import shutil
import time

import numpy as np

from ...lapig_core.capture.fake_device import FakeDevice
from ...lapig_core.capture.sequence import GeometryChecks, run_capture
from ...lapig_core.capture.settings import CaptureError, CaptureSettings
from ...lapig_core.common.steps import run_to_end
from ...lapig_core.rig.simulated import CameraFaults, simulated_rig, sync_outcome

PUBLIC_CODE_SECONDS_PER_CAPTURE = 0.2 + 13 / 30
PROJECTOR, CAMERA = (320, 240), (400, 300)


def _optics():
    return FakeDevice(projector_size=PROJECTOR, camera_size=CAMERA, noise=0.003, seed=3)


def _capture(device, out, name, optics=None, patterns=12):
    checks = GeometryChecks(coverage=optics.coverage, exact_projector_to_camera=optics.exact_projector_to_camera) \
        if optics is not None else None
    settings = CaptureSettings(out_dir=out, setup_name=name, train_count=patterns - patterns // 4,
                               test_count=patterns // 4, working_size=128, check_grid_step=8)
    return run_to_end(run_capture(device, settings, checks))["meta"]


def run(args) -> dict:
    out = os.path.abspath(args.out)
    shutil.rmtree(out, ignore_errors=True)
    os.makedirs(out)
    t0 = time.perf_counter()
    patterns = max(8, args.patterns)

    # the same scene with no rig at all, then through a clean rig
    optics = _optics()
    direct = _capture(optics, out, "direct", optics, patterns)
    device, screen, camera = simulated_rig(_optics(), CameraFaults())
    clean = _capture(device, out, "clean", _optics(), patterns)
    clean_sync = sync_outcome(device, screen, camera)

    # 100 ms latency with jitter and faults; half-way, the camera turns 80 ms later than measured
    faults = CameraFaults(latency_s=0.1, jitter_s=0.03, drop_rate=0.05, repeat_rate=0.05, torn_rate=0.05,
                          noise=0.004)
    device, screen, camera = simulated_rig(_optics(), faults)
    shots_before = {}
    original_capture = device.capture

    def capture_then_slow_down(frames):
        if device.sync is not None and not shots_before and device.sync.stats.shots > 60:
            shots_before["at"] = device.sync.stats.shots
            camera.faults.latency_s += 0.08
        return original_capture(frames)

    device.capture = capture_then_slow_down
    start = screen.clock.now()
    faulty = _capture(device, out, "faulty", _optics(), patterns)
    virtual_seconds = screen.clock.now() - start
    faulty_sync = sync_outcome(device, screen, camera)
    shots = faulty["sync"]["shots"]

    # 100 ms latency alone: the pace of a well-behaved camera
    device, screen, _ = simulated_rig(_optics(), CameraFaults(latency_s=0.1))
    start = screen.clock.now()
    steady = _capture(device, out, "latency_only", None, patterns)
    steady_seconds = (screen.clock.now() - start) / steady["sync"]["shots"]

    # auto exposure: drifting (cannot be locked), then one the rig locks
    drifting, _, _ = simulated_rig(_optics(), CameraFaults(latency_s=0.05, auto_exposure=True,
                                                         exposure_lockable=False))
    try:
        _capture(drifting, out, "drifting", None, patterns)
        drift_message = ""
    except (CaptureError, RuntimeError) as exc:
        drift_message = str(exc)
    locked, _, _ = simulated_rig(_optics(), CameraFaults(latency_s=0.05, auto_exposure=True))
    try:
        locked_meta = _capture(locked, out, "locked", None, patterns)
        locked_message = ""
    except (CaptureError, RuntimeError) as exc:
        locked_meta, locked_message = {}, str(exc)

    summary = {
        "stale_frames_detected": round(faulty_sync["caught"] / max(faulty_sync["bad"], 1), 4),
        "stale_frames_injected": faulty_sync["bad"],
        "stale_frames_by_fault": faulty_sync["bad_by_fault"],
        "missed_by_fault": faulty_sync["missed_by_fault"],
        "false_alarms": faulty_sync["false_alarms"] + clean_sync["false_alarms"],
        "false_alarms_clean_run": clean_sync["false_alarms"],
        "registration_error_px_median": round(faulty["registration"]["registration_error_px_median"], 4),
        "registration_error_px_median_clean": round(clean["registration"]["registration_error_px_median"], 4),
        "registration_error_px_median_no_rig": round(direct["registration"]["registration_error_px_median"], 4),
        "registration_error_px_p95": round(faulty["registration"]["registration_error_px_p95"], 4),
        "registration_error_px_p95_clean": round(clean["registration"]["registration_error_px_p95"], 4),
        "valid_fraction": round(faulty["valid_fraction"], 4),
        "valid_fraction_no_rig": round(direct["valid_fraction"], 4),
        "auto_exposure_detected": "auto exposure" in drift_message,
        "auto_exposure_message": drift_message,
        "auto_exposure_detected_locked": "auto exposure" in locked_message,
        "locked_ramp_passes_differ_by": (locked_meta.get("health") or {}).get("ramp", {}).get("passes_differ_by"),
        "latency_measured_s": faulty["sync"]["latency_s"],
        "settle_s_at_end": faulty["sync"]["settle_s"],
        "camera_slowed_down_after_shot": shots_before.get("at"),
        "seconds_per_capture": round(virtual_seconds / shots, 4),
        "seconds_per_capture_latency_only": round(steady_seconds, 4),
        "seconds_per_capture_public_code": round(PUBLIC_CODE_SECONDS_PER_CAPTURE, 4),
        "shots": shots,
        "rejected": faulty["sync"]["rejected"],
        "reshows": faulty["sync"]["reshows"],
        "simulated_capture_s": round(virtual_seconds, 2),
        **_window_figures(out),
        "bench_total_s": round(time.perf_counter() - t0, 2),
    }
    return summary


def _window_figures(out) -> dict:
    """The projector window on a virtual two-monitor screen; {"window_skipped": why} without the tools."""
    from ...lapig_addon.rigs.live_output import ProjectorWindowSink
    from ...lapig_addon.services.ports import ProjectorFrame
    from ...lapig_core.common.imageio import write_png
    from ...lapig_core.rig.projector_window import ProjectorWindow
    from .. import virtual_screens as vs

    if vs.missing_tools():
        return {"window_skipped": "; ".join(vs.missing_tools())}
    monitors = [(0, 0, 640, 480), (640, 0, 1920, 1080)]
    root = (2560, 1080)
    with vs.two_monitors(monitors, root) as env:
        window = ProjectorWindow(1, env=env)
        try:
            rng = np.random.default_rng(0)
            pattern = rng.integers(0, 256, (1080, 1920, 3), dtype=np.uint8)
            window.show(pattern)
            shot = vs.screenshot(env, root)
            exact = bool(np.array_equal(vs.region(shot, 1, monitors), pattern))
            on_chosen = exact and not vs.region(shot, 0, monitors).any()
            write_png(os.path.join(out, "window_screenshot.png"), shot)
            # a finished Generate hands its frame to the sinks: working image -> native pixels -> window
            sink = ProjectorWindowSink(window)
            look = rng.random((144, 256, 3)).astype(np.float32)
            seconds = []
            for _ in range(5):
                t = time.perf_counter()
                sink.show(ProjectorFrame(look, 1920, 1080, 8))
                seconds.append(sink.shown_at - t)
        finally:
            window.close()
    return {"window_pixel_exact": exact, "window_on_chosen_screen": on_chosen,
            "live_look_seconds": round(float(np.median(seconds)), 4),
            "live_look_seconds_max": round(float(max(seconds)), 4), "window_resolution": "1920x1080"}

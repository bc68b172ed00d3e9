# SPDX-License-Identifier: GPL-3.0-or-later
"""A real rig's capture path on simulated hardware: the frame code, the latency, the health checks and
the faults of real cameras and projector windows (lapig_core.rig), on a virtual clock."""
from __future__ import annotations

import pathlib

import numpy as np
import pytest

from lapig.lapig_core.capture.dataset import load_capture_set
from lapig.lapig_core.capture.fake_device import FakeDevice
from lapig.lapig_core.capture.sequence import GeometryChecks, run_capture
from lapig.lapig_core.capture.settings import CaptureError, CaptureSettings
from lapig.lapig_core.common.steps import run_to_end
from lapig.lapig_core.rig import RigError
from lapig.lapig_core.rig import frame_code as fc
from lapig.lapig_core.rig.simulated import CameraFaults, simulated_rig, sync_outcome

FAULTY = CameraFaults(latency_s=0.1, jitter_s=0.02, drop_rate=0.06, repeat_rate=0.06, torn_rate=0.06, noise=0.004)


def _optics(seed=0):
    return FakeDevice(projector_size=(160, 120), camera_size=(200, 150), noise=0.003, seed=seed)


def _run(device, root, checks=None, **settings):
    base = dict(out_dir=str(root), setup_name="wall", train_count=6, test_count=2, working_size=64)
    return run_to_end(run_capture(device, CaptureSettings(**{**base, **settings}), checks))


def _checks(optics):
    return GeometryChecks(coverage=optics.coverage, exact_projector_to_camera=optics.exact_projector_to_camera)


def test_the_code_reads_back_every_number_through_the_optics():
    optics = _optics()
    layout = fc.CodeLayout.for_frame(160, 120)
    black = optics.capture([np.zeros((120, 160, 3), np.uint8)])[0]
    lit = {key: optics.capture([fc.single_cell(layout, *key)])[0] for key in layout.cells()}
    cells = fc.locate_cells(black, lit)
    assert cells.readable_bands() == [0, 1]
    pattern = np.random.default_rng(1).integers(0, 256, (120, 160, 3), dtype=np.uint8)
    for number in range(20):
        reading = fc.read_code(optics.capture([fc.stamp(pattern, layout, number)])[0], cells)
        assert reading.verdict(number) == "ok" and reading.verdict(number + 1) == "stale"
    torn = np.concatenate([optics.capture([fc.stamp(pattern, layout, 5)])[0][:75],
                           optics.capture([fc.stamp(pattern, layout, 4)])[0][75:]])
    assert fc.read_code(torn, cells).verdict(5) == "torn"
    assert fc.read_code(np.zeros_like(black), cells).verdict(5) == "unreadable"


def test_a_faulty_camera_gives_a_registered_data_set_and_every_bad_frame_is_caught(tmp_path):
    optics = _optics()
    device, screen, camera = simulated_rig(optics, FAULTY)
    meta = _run(device, tmp_path, _checks(optics))["meta"]
    outcome = sync_outcome(device, screen, camera)
    assert outcome["bad"] >= 5 and outcome["caught"] == outcome["bad"] and outcome["false_alarms"] == 0
    assert meta["sync"]["frame_code"] == "verified, top and bottom bands"
    assert 0.1 <= meta["device_timing"]["latency_s"] <= 0.25  # latency, jitter, a frame or two of waiting
    assert meta["registration"]["registration_error_px_median"] < 0.5
    assert load_capture_set(str(tmp_path / "setups" / "wall")).cam_train.shape[0] == 6
    # the code's rows are not registered: the patterns did not light them
    band = fc.CodeLayout.for_frame(160, 120).band
    cs = load_capture_set(str(tmp_path / "setups" / "wall"))
    rows = int(np.ceil(band * cs.projector_valid.shape[0] / 120))
    assert not cs.projector_valid[:rows - 1].any() and not cs.projector_valid[-(rows - 1):].any()


def test_a_camera_later_than_measured_gives_stale_frames_that_are_caught(tmp_path):
    optics = _optics()
    device, screen, camera = simulated_rig(optics, CameraFaults(latency_s=0.1), settle_margin_s=0.0)
    device.lock_exposure(None)
    camera.faults.latency_s = 0.25  # the camera slows down after the calibration
    shown = (40, 200, 90, 160)  # out of order: a stale frame (the one before) would break the ranking
    shots = [device.capture([np.full((120, 160, 3), v, np.uint8)])[0] for v in shown]
    outcome = sync_outcome(device, screen, camera)
    assert outcome["bad_by_fault"].get("late", 0) >= 1 and outcome["caught"] == outcome["bad"]
    assert device.sync.settle_s > 0.2  # it learnt to wait longer
    # each shot is of its own frame: the captures rank as the grey levels shown
    assert np.argsort([float(s.mean()) for s in shots]).tolist() == np.argsort(shown).tolist()


def test_a_drifting_auto_exposure_fails_the_health_check_and_a_locked_one_passes(tmp_path):
    drifting = CameraFaults(latency_s=0.05, auto_exposure=True, exposure_lockable=False)
    device, _, _ = simulated_rig(_optics(), drifting)
    with pytest.raises(CaptureError, match="auto exposure or auto gain is on"):
        _run(device, tmp_path / "a")
    assert device.health["ramp"]["passes_differ_by"] > 0.04  # the ramp caught it, not an earlier step
    locked = CameraFaults(latency_s=0.05, auto_exposure=True, exposure_lockable=True)
    device, _, _ = simulated_rig(_optics(), locked)
    meta = _run(device, tmp_path / "b")["meta"]
    assert meta["health"]["problems"] == [] and meta["health"]["ramp"]["passes_differ_by"] < 0.01
    assert meta["camera"]["not_locked"] == []


def test_an_overexposed_camera_is_told_to_lower_its_exposure(tmp_path):
    device, _, camera = simulated_rig(_optics(), CameraFaults(latency_s=0.05))
    camera.gain = 2.5
    with pytest.raises(CaptureError, match="white clips on .* lower the camera's exposure"):
        _run(device, tmp_path)


@pytest.mark.parametrize("fault, message", [
    (dict(faults=CameraFaults(latency_s=0.05, unplug_after=80)), "the camera stopped answering"),
    (dict(closes_after=70), "the projector window was closed"),
])
def test_a_device_lost_mid_capture_ends_with_one_message_and_keeps_the_previous_capture(tmp_path, fault, message):
    first = _run(simulated_rig(_optics(), CameraFaults(latency_s=0.05))[0], tmp_path)
    before = {p: p.read_bytes() for p in pathlib.Path(first["setup_dir"]).rglob("*") if p.is_file()}
    faults = fault.pop("faults", CameraFaults(latency_s=0.05))
    device, _, _ = simulated_rig(_optics(seed=1), faults, **fault)
    with pytest.raises(RigError, match=message):
        _run(device, tmp_path)
    after = {p: p.read_bytes() for p in pathlib.Path(first["setup_dir"]).rglob("*") if p.is_file()}
    assert after == before


def test_a_camera_that_never_shows_the_code_edges_syncs_by_time_and_says_so(tmp_path):
    optics = _optics()
    # a camera zoomed in past the frame's top and bottom edges
    optics.homography = np.diag([1.25, 1.6, 1.0]) @ np.array([[1, 0, 0], [0, 1, -12], [0, 0, 1]], float)
    device, _, _ = simulated_rig(optics, CameraFaults(latency_s=0.05))
    meta = _run(device, tmp_path)["meta"]
    assert meta["sync"]["frame_code"] == "not seen: timing only"
    assert meta["sync"]["rejected"] == {}


def test_a_camera_that_moves_between_the_two_decodes_is_stopped(tmp_path):
    optics = _optics()
    device, _, _ = simulated_rig(optics, CameraFaults(latency_s=0.05))
    steps = run_capture(device, CaptureSettings(out_dir=str(tmp_path), setup_name="wall", train_count=2,
                                                test_count=0, working_size=64))
    with pytest.raises(CaptureError, match="decoded differently twice"):
        for _, message in steps:
            if message.startswith("checking the decode"):  # the camera is knocked by 1.5 pixels
                optics.homography = np.array([[1, 0, 1.5], [0, 1, 1.0], [0, 0, 1]]) @ optics.homography
    assert not (tmp_path / "setups" / "wall").exists()


def test_a_steady_rig_decodes_the_same_twice(tmp_path):
    device, _, _ = simulated_rig(_optics(), CameraFaults(latency_s=0.05))
    meta = _run(device, tmp_path)["meta"]
    assert meta["registration"]["decode_agreement"] > 0.97


def _faulty_capture(root, rate, seed):
    """A capture on a camera that drops, repeats and tears ``rate`` of its frames each."""
    optics = _optics(seed=seed)
    faults = CameraFaults(latency_s=0.05, jitter_s=0.01, drop_rate=rate, repeat_rate=rate, torn_rate=rate)
    device, _, _ = simulated_rig(optics, faults, seed=seed)
    return _run(device, root, _checks(optics), train_count=4, test_count=1, working_size=32)["meta"]


@pytest.mark.parametrize("seed", [0, 4, 15, 22])
def test_a_tenth_of_each_frame_fault_passes_the_health_checks_with_the_clean_registration(tmp_path, seed):
    """The calibration's still pictures and the latency's levels outvote bad grabs (these seeds found the
    latency's one-grab levels, the cells' two-grab pairs and a torn black picture misread before)."""
    clean = _faulty_capture(tmp_path / "clean", 0.0, seed)
    faulty = _faulty_capture(tmp_path / "faulty", 0.1, seed)
    assert faulty["sync"]["frame_code"] == "verified, top and bottom bands"
    assert faulty["health"]["problems"] == [] and faulty["sync"]["rejected"]  # bad grabs, all caught
    drift = abs(faulty["registration"]["registration_error_px_median"]
                - clean["registration"]["registration_error_px_median"])
    assert drift <= 0.1


def test_frames_faulty_beyond_rescue_are_refused_in_those_words(tmp_path):
    for seed in range(3):
        with pytest.raises((RigError, CaptureError)) as refused:
            _faulty_capture(tmp_path / str(seed), 0.3, seed)
        assert str(refused.value).startswith("the camera's frames cannot be verified: "), refused.value

"""A real rig of several projectors (issue 36): K simulated windows and one camera behind the single rig's sync,
captured by lapig_core/multi/capture: each projector calibrated and shot alone, the joint frames verified by every
projector's code, and a display that goes mid-capture stopping it in one line with the previous capture kept."""
import json

import numpy as np
import pytest

from lapig.lapig_core.capture.settings import CaptureError, CaptureSettings
from lapig.lapig_core.common.steps import run_to_end
from lapig.lapig_core.multi.capture import run_multi_capture
from lapig.tools.fakes.fake_rig import FakeProjector, FakeRig, FakeRigDevice, homography_onto
from lapig.lapig_core.rig import RigError
from lapig.lapig_core.rig.multi_rig import simulated_multi_rig
from lapig.lapig_core.rig.simulated import CameraFaults

FAULTY = CameraFaults(latency_s=0.05, jitter_s=0.01, drop_rate=0.05, repeat_rate=0.05, torn_rate=0.05)


CAMERA, PROJECTOR = (128, 96), (96, 72)


def _rig():
    """Two projectors side by side on a wall the camera sees whole, their frames' edges in view (the code's
    bands are at the frames' top and bottom: a camera that cannot see them verifies nothing)."""
    quads = ([(0.03, 0.08), (0.63, 0.05), (0.61, 0.95), (0.02, 0.92)],
             [(0.37, 0.06), (0.97, 0.09), (0.98, 0.93), (0.39, 0.94)])
    projectors = [FakeProjector(PROJECTOR, homography_onto(PROJECTOR, CAMERA, q), gamma=g, gain=0.6)
                  for q, g in zip(quads, (2.2, 1.9))]
    return FakeRig(projectors, CAMERA, noise=0.0, object_mask=np.ones(CAMERA[::-1], bool))


def _capture(tmp_path, faults=FAULTY, **options):
    fake = _rig()
    device, screens, camera = simulated_multi_rig(FakeRigDevice(fake), faults, names=["left", "right"], **options)
    s = CaptureSettings(out_dir=str(tmp_path), setup_name="s", train_count=3)
    return fake, device, screens, camera, run_to_end(run_multi_capture(device, s, ["left", "right"]))


def test_two_windows_and_one_camera_capture_with_every_projector_calibrated_alone(tmp_path):
    fake, device, screens, camera, out = _capture(tmp_path)
    meta = out["meta"]
    assert meta["device"] == "simulated rig" and meta["multi"]["count"] == 2
    for record in meta["projectors"]:  # each projector: its own latency, code and health, measured alone
        assert record["sync"]["frame_code"] == "verified, top and bottom bands", record
        assert record["sync"]["latency_s"] >= 0.05 and record["health"]["problems"] == []
    assert meta["joint_sync"]["shots"] >= 2  # all black, all white together
    # only one projector lit at a time, but for the joint frames: every other change of the screens leaves one dark
    lit = [sum(f is not None and f.any() for f in frames) for _, frames in screens.timeline]
    assert len(lit) > 100 and 1 <= sum(n > 1 for n in lit) <= 2 * device.joint_shows
    from lapig.lapig_core.multi.capture_set import load_multi_capture

    cs = load_multi_capture(out["setup_dir"])
    for k in range(2):  # the registration against the rig's truth, where both valid
        truth, got = fake.camera_map(k), cs.maps[k]
        both = truth.valid & got.valid
        assert both.sum() > 0.7 * truth.valid.sum()  # less the code's bands
        err = np.hypot(truth.map_x - got.map_x, truth.map_y - got.map_y)[both]
        assert np.median(err) < 1.0, np.median(err)
    assert meta["coverage"]["overlap"] > 0.1
    code = device.code_pixels()  # the joint frames carry every projector's code: no registration uses its pixels
    assert code.any() and not any((m.valid & code).any() for m in cs.maps)


def test_a_display_that_goes_mid_capture_stops_it_in_one_line_and_the_previous_capture_stays(tmp_path):
    _, _, _, _, first = _capture(tmp_path, CameraFaults(latency_s=0.02))
    before = open(first["setup_dir"] / "setup.json", "rb").read()
    with pytest.raises(RigError) as said:
        _capture(tmp_path, CameraFaults(latency_s=0.02), closes_after=[None, 70])
    line = str(said.value)
    assert line.startswith("projector 'right': its display is gone") and "\n" not in line, line
    assert open(first["setup_dir"] / "setup.json", "rb").read() == before
    assert json.loads(before)["multi"]["count"] == 2


def test_a_joint_frame_a_late_window_missed_is_grabbed_again():
    """The right window presents its joint frame late: the grab that shows the left's new frame with the right's
    old one reads the right's code stale, and is thrown away."""
    fake = _rig()
    device, screens, camera = simulated_multi_rig(FakeRigDevice(fake), CameraFaults(latency_s=0.1),
                                                  names=["left", "right"])
    device.lock_exposure(None)
    late = screens.screens[1]
    show = late.show

    def late_show(frame):  # the right window says it presented, but its frame goes up 0.2 s later
        said = device.clock.now()
        device.clock.sleep(0.2)
        show(frame)
        return said

    late.show = late_show
    device.joint_settle_s = 0.01  # as if measured before the window slowed
    white = [np.full((72, 96, 3), 255, np.uint8)] * 2
    image = device.capture([white])[0]
    assert device.joint_stats["shots"] == 1 and device.joint_stats["stale"] >= 1, device.joint_stats
    assert image.shape == (96, 128, 3)
    truth = fake.capture(white)
    rows = slice(20, 76)  # away from the code bands
    assert np.abs(image[rows].astype(int) - truth[rows].astype(int)).max() <= 2


def test_refused_without_a_camera_seeing_a_projector(tmp_path):
    rig = _rig()
    away = FakeProjector((96, 72), homography_onto((96, 72), (128, 96), [(2, 2), (3, 2), (3, 3), (2, 3)]))
    fake = FakeRig([rig.projectors[0], away], CAMERA, noise=0.0, object_mask=rig.object_mask)
    device, _, _ = simulated_multi_rig(FakeRigDevice(fake), CameraFaults(), names=["left", "away"])
    with pytest.raises((RigError, CaptureError)) as said:
        device.lock_exposure(None)
    assert str(said.value).startswith("projector 'away': the camera does not see the projector change")

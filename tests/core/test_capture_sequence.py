# SPDX-License-Identifier: GPL-3.0-or-later
"""The capture sequence end to end on the numpy fake device: data set, registration, cancel, commit."""
from __future__ import annotations

import os
import pathlib

import cv2
import numpy as np
import pytest

from lapig.lapig_core.capture import staging
from lapig.lapig_core.capture.dataset import DatasetError, load_capture_set
from lapig.lapig_core.capture.fake_device import FakeDevice
from lapig.lapig_core.capture.registration import Registration, frame_grid
from lapig.lapig_core.capture.sequence import GeometryChecks, pattern_images, run_capture
from lapig.lapig_core.capture.settings import CaptureError, CaptureSettings
from lapig.lapig_core.common.locking import FolderBusy
from lapig.lapig_core.common.steps import run_to_end

SETUP = "plane"


def _settings(root, **kw):
    base = dict(out_dir=str(root), setup_name=SETUP, train_count=4, test_count=2, working_size=32, chunk=4)
    base.update(kw)
    return CaptureSettings(**base)


def _checks(device):
    return GeometryChecks(coverage=device.coverage, exact_projector_to_camera=device.exact_projector_to_camera)


def _capture(root, device=None, stop_after=None, **kw):
    """Run a capture to its end (returns its result and progress), or close it once it has
    yielded ``stop_after`` (a progress message prefix), as the job engine does on a cancel."""
    device = device or FakeDevice()
    progress = []

    def seen(step):
        progress.append(step[0])
        return bool(stop_after) and step[1].startswith(stop_after)
    return run_to_end(run_capture(device, _settings(root, **kw), _checks(device)), seen), progress


def _snapshot(root) -> dict:
    files = sorted(p for p in pathlib.Path(root).rglob("*") if p.is_file())
    return {p.relative_to(root).as_posix(): p.read_bytes() for p in files}


def test_capture_completes_and_the_data_set_loads(tmp_path):
    result, progress = _capture(tmp_path)
    assert progress == sorted(progress) and progress[-1] == 1.0
    assert result["setup_dir"] == tmp_path / "setups" / SETUP
    cs = load_capture_set(result["setup_dir"])
    # the 64x48 projector's whole frame at working size 32
    assert cs.prj_train.shape == cs.cam_train.shape == (4, 24, 32, 3)
    assert cs.prj_test.shape == cs.cam_test.shape == (2, 24, 32, 3)
    assert cs.frame_size == (32, 24) and cs.meta["working_frame"] == [32, 24] and cs.meta["working_size"] == 32
    assert cs.projector_valid.shape == (24, 32) and cs.projector_valid.all()  # the plane fills the frame
    assert 0.01 < cs.cam_black.mean() < cs.cam_gray.mean() < cs.cam_white.mean()
    meta = cs.meta
    assert meta["device"] == "numpy fake (homography)" and meta["counts"] == {"train": 4, "test": 2, "sl": 26}
    assert meta["coverage"] == {"projector_on_object": 1.0, "seen_by_camera": 1.0}
    assert meta["valid_fraction"] > 0.95 and meta["white_clipped_fraction"] == 0.0
    assert set(meta["timings"]) >= {"references_s", "structured_light_render_s", "patterns_s", "total_s"}
    assert not (tmp_path / staging.STAGING_DIR).exists()


def test_registration_recovers_the_fake_geometry(tmp_path):
    device = FakeDevice()
    result, _ = _capture(tmp_path, device)
    # against the exact homography, through the sequence's own check
    assert result["meta"]["registration"]["registration_error_px_median"] < 0.3
    assert result["meta"]["registration"]["registration_error_px_p95"] < 0.6
    # the saved registration: camera coordinates of the working pixel centres
    reg = Registration.load(result["setup_dir"] / "registration.npz")
    xs, ys = frame_grid(64, 48, 32, 24)
    grid = np.stack(np.meshgrid(xs, ys), -1)
    exact = cv2.perspectiveTransform(grid.reshape(-1, 1, 2), device.homography).reshape(grid.shape)
    error = np.hypot(reg.map_x - exact[..., 0], reg.map_y - exact[..., 1])
    assert reg.valid.all() and np.median(error) < 0.5 and error.max() < 1.5  # camera pixels
    # registered captures follow what was projected (surface-modulated)
    cs = load_capture_set(result["setup_dir"])
    for prj, cam in zip(np.concatenate([cs.prj_train, cs.prj_test]), np.concatenate([cs.cam_train, cs.cam_test])):
        assert np.corrcoef(prj.mean(-1).ravel(), cam.mean(-1).ravel())[0, 1] > 0.85


def test_projector_missing_the_camera_is_refused_before_anything_is_written(tmp_path):
    shifted = np.array([[1, 0, 120], [0, 1, 0], [0, 0, 1]]) @ FakeDevice().homography  # mostly off-frame
    with pytest.raises(CaptureError, match=r"covers 100% .* the camera sees \d+% of it"):
        _capture(tmp_path, FakeDevice(homography=shifted))
    assert list(tmp_path.iterdir()) == []


def test_cancel_leaves_no_partial_setup(tmp_path):
    result, _ = _capture(tmp_path, stop_after="captures")
    assert result is None
    assert list(tmp_path.iterdir()) == []  # no setup, no projector images, no staging folder


def test_cancelled_recapture_leaves_the_previous_capture_byte_identical(tmp_path):
    first, _ = _capture(tmp_path, seed=0)
    before = _snapshot(tmp_path)
    assert "prj/train/img_0001.png" in before and "setups/plane/setup.json" in before
    for stop_after in ("structured light", "writing references", "captures"):
        result, _ = _capture(tmp_path, FakeDevice(seed=1), stop_after=stop_after, seed=1)
        assert result is None and _snapshot(tmp_path) == before
        assert sorted(p.name for p in tmp_path.iterdir()) == ["prj", "setups"]
    cs = load_capture_set(first["setup_dir"])
    assert np.abs(cs.prj_train - pattern_images(_settings(tmp_path, seed=0), (32, 24))[:4]).max() <= 0.5 / 255 + 1e-6


def _kill_after(monkeypatch, renames):
    """From the rename ``renames`` + 1 on, every rename dies, as a killed process would: the
    commit's own roll-back cannot run either."""
    class Killed(BaseException):
        pass

    done = []
    real = pathlib.Path.replace

    def replace(self, target):
        if len(done) >= renames:
            raise Killed()
        done.append(self)
        return real(self, target)

    monkeypatch.setattr(pathlib.Path, "replace", replace)
    return Killed


@pytest.mark.parametrize("renames", range(1, 8))  # 8 moves: setup out, in; prj ref, train, test out, in
def test_a_kill_between_the_commit_renames_is_detected_then_finished(tmp_path, monkeypatch, renames):
    _capture(tmp_path, seed=0)
    old = load_capture_set(tmp_path / "setups" / SETUP)
    killed = _kill_after(monkeypatch, renames)
    with pytest.raises(killed):
        _capture(tmp_path, FakeDevice(seed=1), seed=1)
    monkeypatch.undo()
    assert (tmp_path / staging.STAGING_DIR / SETUP / staging.JOURNAL).exists()
    with pytest.raises(DatasetError):  # neither the old set nor the new one: refused
        load_capture_set(tmp_path / "setups" / SETUP)

    assert staging.finish_interrupted_commits(tmp_path) == [SETUP]  # what the next capture does first
    new = load_capture_set(tmp_path / "setups" / SETUP)
    assert new.meta["pattern_source"] == "generated (seed 1)"
    assert np.abs(new.prj_train - pattern_images(_settings(tmp_path, seed=1), (32, 24))[:4]).max() <= 0.5 / 255 + 1e-6
    assert not np.array_equal(new.cam_train, old.cam_train)
    assert not (tmp_path / staging.STAGING_DIR).exists()


@pytest.mark.parametrize("failing", [0, 3, 7])
def test_a_rename_that_fails_during_the_commit_puts_the_old_set_back(tmp_path, monkeypatch, failing):
    _capture(tmp_path, seed=0)
    before = _snapshot(tmp_path)
    calls = []
    real = pathlib.Path.replace

    def replace(self, target):  # e.g. a file held open on Windows: one rename refused
        calls.append(self)
        if len(calls) == failing + 1:
            raise PermissionError(13, "in use", str(self))
        return real(self, target)

    monkeypatch.setattr(pathlib.Path, "replace", replace)
    with pytest.raises(PermissionError):
        _capture(tmp_path, FakeDevice(seed=1), seed=1)
    assert _snapshot(tmp_path) == before and sorted(p.name for p in tmp_path.iterdir()) == ["prj", "setups"]


def test_a_kill_before_the_commit_leaves_the_old_set_and_the_next_capture_cleans_up(tmp_path):
    _capture(tmp_path, seed=0)
    before = _snapshot(tmp_path)
    # what kills in the middle of captures leave: staging folders without a journal, of this
    # setup and of another one captured into the same root
    for name in (SETUP, "other"):
        leftover = tmp_path / staging.STAGING_DIR / name / "setups" / name / "cam" / "raw" / "sl"
        leftover.mkdir(parents=True)
        (leftover / "img_0001.png").write_bytes(b"half")
    assert load_capture_set(tmp_path).meta["pattern_source"] == "generated (seed 0)"
    result, _ = _capture(tmp_path, seed=2)
    assert result["meta"]["pattern_source"] == "generated (seed 2)"
    assert not (tmp_path / staging.STAGING_DIR).exists() and _snapshot(tmp_path) != before


def test_a_second_capture_into_the_same_root_is_refused_at_once_and_the_first_completes(tmp_path):
    first = run_capture(FakeDevice(), _settings(tmp_path, seed=0), holder="LAPIG capture")
    assert next(first)[1] == "preparing the capture"  # it holds the root now
    with pytest.raises(FolderBusy, match=rf"{tmp_path} is in use by LAPIG capture \(pid {os.getpid()}, "):
        _capture(tmp_path, seed=1, setup_name="other")
    for _ in first:
        pass
    assert load_capture_set(tmp_path).meta["pattern_source"] == "generated (seed 0)"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["prj", "setups"]  # no lock file, no staging
    _capture(tmp_path, seed=0, setup_name="other")  # the root is free again
    stopped = run_capture(FakeDevice(), _settings(tmp_path, seed=0))
    next(stopped)
    stopped.close()  # a cancel frees it too
    _capture(tmp_path, seed=0)


def test_setups_sharing_a_root_keep_its_projector_images(tmp_path):
    _capture(tmp_path, seed=0, setup_name="a")
    prj = {k: v for k, v in _snapshot(tmp_path).items() if k.startswith("prj/")}
    _capture(tmp_path, FakeDevice(seed=5), seed=0, setup_name="b")  # same patterns: welcome
    assert {k: v for k, v in _snapshot(tmp_path).items() if k.startswith("prj/")} == prj
    for name in ("a", "b"):
        assert load_capture_set(tmp_path / "setups" / name).setup == name
    before = _snapshot(tmp_path)
    with pytest.raises(CaptureError, match="other setups"):
        _capture(tmp_path, seed=1, setup_name="c")
    with pytest.raises(CaptureError, match="other setups"):
        _capture(tmp_path, seed=0, setup_name="c", test_count=1)
    assert _snapshot(tmp_path) == before


@pytest.mark.parametrize("projector, working_size, frame", [((64, 48), 64, (64, 48)), ((64, 36), 64, (64, 36)),
                                                             ((36, 64), 48, (28, 48))])
def test_a_non_square_projector_is_captured_over_its_whole_frame(tmp_path, projector, working_size, frame):
    device = FakeDevice(projector_size=projector)
    result, _ = _capture(tmp_path, device, working_size=working_size)
    cs = load_capture_set(result["setup_dir"])
    w, h = frame
    assert cs.frame_size == frame and cs.cam_train.shape == (4, h, w, 3) and cs.meta["working_frame"] == [w, h]
    # every working pixel is registered, up to the frame's edges: no central square, no black bars
    assert cs.projector_valid.all() and cs.cam_white[:, :2].mean() > cs.cam_black[:, :2].mean() + 0.1
    reg = Registration.load(result["setup_dir"] / "registration.npz")
    assert reg.dense_xy.shape == (projector[1], projector[0], 2)


@pytest.mark.parametrize("working_size, match", [(8, "16 to 1024"), (96, "larger than the projector")])
def test_a_working_size_the_networks_cannot_use_is_refused(tmp_path, working_size, match):
    with pytest.raises(CaptureError, match=match):
        _capture(tmp_path, working_size=working_size)
    assert list(tmp_path.iterdir()) == []


def test_the_fake_projector_takes_native_8bit_frames():
    device = FakeDevice()
    with pytest.raises(ValueError, match="uint8"):
        device.show(np.zeros((48, 64, 3), np.float32))
    device.show(np.full((48, 64, 3), 255, np.uint8))
    white = device.grab()
    device.show(np.zeros((48, 64, 3), np.uint8))
    assert white.dtype == np.uint8 and white.shape == (120, 160, 3)
    assert white.mean() > device.grab().mean() + 60

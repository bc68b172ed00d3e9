"""Refine on the rig with bpy blocked: the job projects the scene's result through the device factory (the
numpy fake, and a simulated real rig over it), captures, corrects, and writes the refined result whole or not
at all; the sinks and Export get the refined image."""
import importlib
import json
import os
import pathlib
import threading
import time

import cv2
import numpy as np
import pytest

from lapig.lapig_core.capture.dataset import load_capture_set, resolve_setup
from lapig.lapig_core.export.result_files import output_name, read_output_image, read_summary, write_new_result
from lapig.lapig_core.photometric.classical import ClassicalModel
from lapig.lapig_core.photometric.targets import desired_targets, reachable_mask

from job_fakes import FakeFactory, FakeSink, FakeStore

ADDON = "lapig.lapig_addon"


def _module(name):
    return importlib.import_module(f"{ADDON}.{name}")


def _seams(tmp_path, simulated=False, main_thread=False):
    ports, state = _module("services.ports"), _module("services.state")
    factory = FakeFactory(ports, main_thread=main_thread)
    if simulated:  # a real rig's device (frame code, latency, verified grabs) over the fake's optics
        from lapig.lapig_core.rig.clock import VirtualClock

        factory = _module("rigs.real_rig").SimulatedRigFactory(factory, clock=VirtualClock())
    return ports.Seams(FakeStore(state, tmp_path / "data", factory), factory, (FakeSink(),))


def _result(seams, tmp_path, weak=0.75, native=True):
    """A captured setup and a result on it whose projector image is a weak open-loop compensation (its light
    scaled by `weak`): what a model's error leaves for the rig's captures to correct."""
    captured = _module("services.capture.capture_job").CaptureJob(
        seams, seams.store.capture_settings(train_count=12, test_count=0)).run_to_completion()
    cs = load_capture_set(captured["setup_dir"])
    model = ClassicalModel.fit(cs.prj_train, cs.cam_train)
    coarse = np.random.default_rng(4).random((3, 4, 3)).astype(np.float32)
    look = cv2.resize(coarse, (32, 24), interpolation=cv2.INTER_CUBIC).clip(0, 1)
    mask = reachable_mask(cs.cam_black, cs.cam_white)
    target = desired_targets(look[None], cs.cam_black, cs.cam_white, mask)[0]
    projector = model.compensate(target) * weak ** (1 / model.gamma_p)
    images = {"target": target, "projector": projector}
    if native:  # the output at the projector's 64x48, as Generate makes it
        images.update(projector_native=cv2.resize(projector, (64, 48), interpolation=cv2.INTER_LINEAR),
                      target_native=cv2.resize(target, (64, 48), interpolation=cv2.INTER_LINEAR))
    summary = {"prompt": "test look", "capture": str(captured["setup_dir"]), "summary_line": "test look; simulated 30.0 dB",
               "metrics": {"simulated_psnr": 30.0}}
    folder = str(write_new_result(tmp_path / "results", "look", images, summary))
    seams.store.record_result(folder, summary["summary_line"])
    return folder


def test_refinement_writes_the_refined_result_and_the_sinks_show_it(tmp_path):
    seams = _seams(tmp_path)
    folder = _result(seams, tmp_path)
    job = _module("services.refine.refine_job").RefineResultJob(seams, 4)
    out = job.run_to_completion()
    rec = out["refine"]
    assert rec["refined_psnr"] > rec["open_loop_psnr"] + 3, rec  # the weak image corrected on the rig
    assert 1 <= rec["iterations"] <= 4 and rec["noise_floor_psnr"] > rec["open_loop_psnr"]
    assert rec["frame"] == "native"  # the native output is what was projected, captured and corrected
    saved = read_summary(folder)
    assert saved["refine"]["images"] == {"projector_working": "projector_refined", "projector": "projector_refined_native"}
    assert saved["metrics"]["refine_refined_psnr"] == rec["refined_psnr"]
    assert output_name(folder, "projector") == "projector_refined_native"
    frame = seams.sinks[0].frames[-1]
    np.testing.assert_array_equal(frame.image, read_output_image(folder, "projector"))
    line = seams.store.result[1]
    assert line.startswith("test look; simulated 30.0 dB; refined ") and "floor" in line
    # the export's sidecar carries the figures
    written = _module("services.export.export_result").export_current(seams.store, seams.store.export_settings())
    sidecar = json.loads(pathlib.Path(written["sidecar"]).read_text())
    assert sidecar["refine"]["refined_psnr"] == rec["refined_psnr"]
    # the device was opened once for every round of captures, and closed
    assert seams.devices.closed == seams.devices.opened == 2  # the capture's and the refinement's


def test_the_classical_fit_is_a_worker_step_on_a_main_thread_rig(tmp_path, monkeypatch):
    """A capture without its first look: the job fits the classical model. With Cycles (a main-thread rig) the
    job's own steps run on Blender's thread, so the fit (seconds) must run on a worker thread."""
    from lapig.lapig_core.photometric.first_look import FIRST_LOOK_FILE, models_dir

    seams = _seams(tmp_path, main_thread=True)
    folder = _result(seams, tmp_path)
    os.remove(models_dir(read_summary(folder)["capture"]) / FIRST_LOOK_FILE)
    classical = importlib.import_module("lapig.lapig_core.photometric.classical").ClassicalModel
    fit, fitted_on = classical.fit.__func__, []

    def fit_and_say_where(cls, *args, **kwargs):
        fitted_on.append(threading.current_thread())
        return fit(cls, *args, **kwargs)

    monkeypatch.setattr(classical, "fit", classmethod(fit_and_say_where))
    rec = _module("services.refine.refine_job").RefineResultJob(seams, 2).run_to_completion()["refine"]
    assert rec["refined_psnr"] > rec["open_loop_psnr"]
    assert fitted_on and threading.main_thread() not in fitted_on, "the classical model was fitted on the main thread"


def test_refinement_runs_through_a_simulated_real_rig(tmp_path):
    seams = _seams(tmp_path, simulated=True)
    folder = _result(seams, tmp_path, native=False)  # a result at the working frame only
    rec = _module("services.refine.refine_job").RefineResultJob(seams, 3).run_to_completion()["refine"]
    assert rec["refined_psnr"] > rec["open_loop_psnr"] + 3, rec
    assert rec["frame"] == "working" and output_name(folder, "projector") == "projector_refined"
    device = seams.devices.last[0]
    assert device.sync.verifies and device.sync.stats.shots >= 2 + rec["iterations"]


def test_a_cancelled_refinement_leaves_the_result_as_it_was(tmp_path):
    seams = _seams(tmp_path)
    folder = _result(seams, tmp_path)
    before = {p: pathlib.Path(folder, p).read_bytes() for p in sorted(os.listdir(folder))}
    job = _module("services.refine.refine_job").RefineResultJob(seams, 4)
    seen = []
    # Esc at the first poll: the fake rig is so fast that waiting for "step 1/" let the worker finish first
    state = job.run(on_progress=lambda p, m: seen.append(m), should_cancel=lambda: bool(seen))
    assert state == "CANCELLED", (state, job.error)
    assert {p: pathlib.Path(folder, p).read_bytes() for p in sorted(os.listdir(folder))} == before
    assert seams.store.result[1] == "test look; simulated 30.0 dB" and len(seams.sinks[0].frames) == 0
    job.stop()  # waits for the worker thread, which closes the device at its next step
    assert seams.devices.closed == seams.devices.opened


def _capture_is_free(seams) -> bool:
    """Whether a job could take the capture's lock now (the one Refine holds while the rig captures)."""
    locking = importlib.import_module("lapig.lapig_core.common.locking")
    try:
        locking.FolderLock(resolve_setup(seams.store.capture_dir).root, "LAPIG check").acquire().release()
    except locking.FolderBusy:
        return False
    return True


def test_a_cancelled_refinement_lets_go_of_the_capture_only_once_its_camera_is_closed(tmp_path):
    """Esc while the camera grabs on its own thread: the background Train, resumed on the free lock, would open
    the same camera and window."""
    seams = _seams(tmp_path)
    _result(seams, tmp_path)
    grabs = seams.devices.grab_gate = threading.Event()  # the camera's grab blocks until set
    job = _module("services.refine.refine_job").RefineResultJob(seams, 4)
    job.poll_timeout = 0.01
    while seams.devices.opened < 2 and job.step():  # the capture's, then the refinement's
        pass
    job.cancel()  # the UI stops waiting; the camera is still grabbing
    assert job.state == "CANCELLED" and not _capture_is_free(seams)
    grabs.set()
    deadline = time.monotonic() + 20
    while not _capture_is_free(seams) and time.monotonic() < deadline:
        time.sleep(0.01)
    assert _capture_is_free(seams) and seams.devices.closed == seams.devices.opened
    job.stop()


def test_a_changed_rig_or_a_moved_object_is_refused_and_nothing_written(tmp_path):
    seams = _seams(tmp_path)
    folder = _result(seams, tmp_path)
    refine_job, pipeline_errors = _module("services.refine.refine_job"), _module("services.pipeline_errors")
    before = sorted(os.listdir(folder))
    seams.devices.moved = True  # another camera: the capture is stale
    with pytest.raises(pipeline_errors.PipelineError, match="moved: capture again"):
        refine_job.RefineResultJob(seams, 2).run_to_completion()
    seams.devices.moved = False
    original = seams.devices._device

    def shifted():  # the object moved 3 camera pixels since the capture: the registration check refuses
        cm = original()
        device = cm.__enter__()
        device.homography = np.array([[1, 0, 6], [0, 1, 0], [0, 0, 1]]) @ device.homography
        return _Entered(cm, device)

    seams.devices._device = shifted
    with pytest.raises(pipeline_errors.PipelineError, match="moved since the capture"):
        refine_job.RefineResultJob(seams, 2).run_to_completion()
    assert sorted(os.listdir(folder)) == before
    with pytest.raises(pipeline_errors.PipelineError, match="Refinement steps"):
        refine_job.RefineResultJob(seams, 99)


class _Entered:
    def __init__(self, cm, device):
        self.cm, self.device = cm, device

    def __enter__(self):
        return self.device

    def __exit__(self, *exc):
        return self.cm.__exit__(*exc)

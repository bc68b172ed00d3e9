"""The first look (issue 28): Capture ends by fitting the classical model, Generate then works at once with it
as compensator and as PSA's simulator and says so, Train says how far the networks are ahead of it, and a
later Generate uses Train's choice. bpy blocked; the fake rig of job_fakes."""
import importlib
import json
import os

import numpy as np
import pytest


ADDON = "lapig.lapig_addon"


def _module(name):
    return importlib.import_module(f"{ADDON}.services.{name}")


def _captured(seams):
    return _module("capture.capture_job").CaptureJob(seams, seams.store.capture_settings()).run_to_completion()


def _summary(folder):
    return json.loads(open(os.path.join(folder, "result.json")).read())


@pytest.mark.torch
def test_generate_after_capture_uses_the_first_look_and_says_so(seams, monkeypatch):
    generate_job, train_job, panel_state = _module("generate.generate_job"), _module("train.train_job"), _module("panel.panel_state")
    from lapig.lapig_core.photometric import first_look

    captured = _captured(seams)
    store = seams.store
    models_dir = os.path.join(captured["setup_dir"], "models")
    assert sorted(os.listdir(models_dir)) == ["classical.npz", "first_look.json"]
    assert captured["first_look_seconds"] >= 0.0
    status = panel_state.models_status(store.read())
    assert status.state == "MISSING" and status.text.startswith("First look: classical model (fitted in")

    # no fine-tuning may happen on the way: the first look works at once
    def no_training(*a, **k):
        raise AssertionError("Generate trained the networks despite the first look")
    monkeypatch.setattr(train_job, "train_models", no_training)
    out = generate_job.GenerateJob(seams, store.generate_request(mix="charcoal_wash:1", psa=True), 2).run_to_completion()
    summary = _summary(out["folder"])
    assert summary["models"] == {"first_look": True, "compensator": "classical", "simulator": "classical",
                                 "line": first_look.FIRST_LOOK_LINE}
    assert first_look.FIRST_LOOK_LINE in store.result[1]
    assert "simulated by the classical model" in store.result[1]  # its own inverse: said whose figure it is
    assert store.models[0] == ""  # the networks are still not trained: the step says so
    assert sorted(os.listdir(models_dir)) == ["classical.npz", "first_look.json"]
    assert summary["metrics"]["simulated_psnr"] > 10


@pytest.mark.torch
def test_train_says_how_far_the_networks_are_from_the_first_look_and_generate_uses_its_choice(seams):
    train_job, generate_job = _module("train.train_job"), _module("generate.generate_job")
    captured = _captured(seams)
    store = seams.store
    train_job.TrainModelsJob(seams, 2).run_to_completion()
    choice = json.load(open(os.path.join(captured["setup_dir"], "models", "compensator_choice.json")))
    ahead = choice["learned_psnr"] - choice["classical_psnr"]
    line = store.models[1]
    assert store.models[0] == store.capture_fingerprint
    # the line says what the measurement means for the first look (every case: test_first_look_core)
    from lapig.lapig_core.photometric.choice import CompensatorChoice
    from lapig.lapig_core.photometric.first_look import after_train_note

    note = after_train_note(CompensatorChoice(choice["chosen"], choice["learned_psnr"], choice["classical_psnr"], 1))
    assert note and note in line
    out = generate_job.GenerateJob(seams, store.generate_request(mix="charcoal_wash:1", psa=False), 2).run_to_completion()
    models = _summary(out["folder"])["models"]
    assert models["first_look"] is False and models["compensator"] == choice["chosen"]
    assert models["simulator"] == "PCNet"
    assert models["networks_ahead_of_first_look_db"] == pytest.approx(ahead, abs=1e-3)
    assert "first look" not in store.result[1]


@pytest.mark.torch
def test_a_first_look_of_another_capture_or_a_damaged_one_is_not_used(seams):
    from lapig.lapig_core.capture.dataset import load_capture_set
    from lapig.lapig_core.photometric import first_look

    captured = _captured(seams)
    setup_dir = captured["setup_dir"]
    fingerprint = captured["meta"]["fingerprint"]
    look = first_look.load_first_look(setup_dir, fingerprint)
    assert look is not None and look.fingerprint == fingerprint
    assert first_look.load_first_look(setup_dir, "another rig") is None
    record = os.path.join(setup_dir, "models", "first_look.json")
    open(record, "w").write("{not json")
    assert first_look.load_first_look(setup_dir, fingerprint) is None
    # the saved model is the fit of the capture's pairs (Train reuses it rather than fitting again)
    cs = load_capture_set(setup_dir)
    again = first_look.fit_first_look(cs, setup_dir)
    np.testing.assert_array_equal(again.classical.M, look.classical.M)
    assert first_look.load_first_look(setup_dir, fingerprint) is not None


@pytest.mark.torch
def test_a_cancel_while_fitting_the_first_look_keeps_the_capture_and_the_whole_fit(seams, monkeypatch):
    import threading

    from lapig.lapig_core.capture.dataset import load_capture_set
    from lapig.lapig_core.photometric import first_look

    capture_job = _module("capture.capture_job")
    started, fit = threading.Event(), first_look.fit_first_look

    def fit_when_seen(*args):  # the test knows the fit is under way before it cancels
        started.set()
        return fit(*args)
    monkeypatch.setattr(first_look, "fit_first_look", fit_when_seen)
    job = capture_job.CaptureJob(seams, seams.store.capture_settings())
    while job.step():
        if job.message.startswith("fitting the first look"):
            assert started.wait(60)
            job.stop()
            break
    assert job.state == "CANCELLED"
    store = seams.store
    assert store.recorded == ["capture"]  # the capture was complete and recorded; no first look line
    load_capture_set(store.capture_dir)  # the capture is whole
    # the fit under way when the cancel came finished whole (files written temp-then-rename)
    assert first_look.load_first_look(store.capture_dir, store.capture_fingerprint) is not None

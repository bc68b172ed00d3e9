"""The artist's whole path through the operators: capture, train, generate, preview, render, export."""
import json
import os

import numpy as np
import pytest

bpy = pytest.importorskip("bpy")

pytestmark = [pytest.mark.blender, pytest.mark.torch]


def _light_pixels(projector) -> np.ndarray:
    """The relative light the projector's image datablock holds, rows from the top."""
    from lapig.lapig_addon.blender import projector_nodes

    image = projector_nodes.projected_image(projector.data)
    w, h = image.size
    rgba = np.empty(w * h * 4, np.float32)
    image.pixels.foreach_get(rgba)
    return rgba.reshape(h, w, 4)[::-1, :, :3]


def _psa_fast(scene):
    s = scene.lapig
    s.prompt = "Render it in the style of a Van Gogh oil painting"
    s.psa_adaptation = 0.5


def test_whole_path_through_the_operators(captured, tmp_path):
    from lapig.lapig_addon.services.panel import panel_state
    from lapig.lapig_addon.blender import preview, scene_state

    scene = captured
    s = scene.lapig
    assert panel_state.models_status(scene_state.read(scene)).state == "MISSING"
    assert bpy.ops.lapig.train_models() == {"FINISHED"}
    assert panel_state.models_status(scene_state.read(scene)).state == "DONE"
    _psa_fast(scene)
    assert bpy.ops.lapig.generate() == {"FINISHED"}
    assert s.result_dir.startswith("//wall_lapig/results/")  # relative: a copied project uses its own
    folder = scene_state.read(scene).result_dir
    summary = json.load(open(os.path.join(folder, "result.json")))
    assert summary["lgst"]["styles"][0][0] == "starry_blue_yellow"
    assert summary["metrics"]["psa_iterations"] >= 1
    for name in ("target", "projector", "simulated", "compensability", "target_nopsa", "comparison",
                 "target_native", "projector_native"):
        assert os.path.isfile(os.path.join(folder, name + ".png")), name
    # the working frame is the whole 160x120 frame at 64x48; the final look and its projector image
    # were made again at the projector's native resolution
    from lapig.lapig_core.export.result_files import read_result_image

    assert read_result_image(folder, "projector").shape == (48, 64, 3)
    assert read_result_image(folder, "projector_native").shape == (120, 160, 3)
    assert summary["native_output"]["frame"] == [160, 120] and summary["dark_outside"]
    # the projector now emits the compensated image
    light_image = scene.lapig.projector.data.node_tree.nodes["LAPIG projected image"].image
    assert light_image.name == "LAPIG projector image"
    generated_light = _light_pixels(s.projector).copy()

    target = s.target
    original = [slot.material.name for slot in target.material_slots]
    for mode in ("TARGET", "SIMULATED", "COMPENSABILITY", "PROJECTION"):
        assert bpy.ops.lapig.preview_mode(mode=mode) == {"FINISHED"}
        assert preview.is_previewing(target)
    with pytest.raises(RuntimeError, match="no 'rendered' image"):
        bpy.ops.lapig.preview_mode(mode="RENDERED")
    assert bpy.ops.lapig.render_result() == {"FINISHED"}  # with the preview on: Cycles sees the real surface
    assert preview.is_previewing(target)
    summary = json.load(open(os.path.join(folder, "result.json")))
    assert summary["metrics"]["rendered_psnr"] > 5 and "rendered_psnr_nopsa" in summary["metrics"]
    assert summary["metrics"]["rendered_psnr_native"] > 5 and "rendered_ssim_native" in summary["metrics"]
    assert read_result_image(folder, "rendered_native").shape == (120, 160, 3)
    assert bpy.ops.lapig.preview_mode(mode="RENDERED") == {"FINISHED"}
    assert bpy.ops.lapig.preview_mode(mode="ORIGINAL") == {"FINISHED"}
    assert [slot.material.name for slot in target.material_slots] == original

    from lapig.lapig_addon.blender.properties import projector_model

    model = projector_model(s.projector)
    for depth, dtype in (("8", np.uint8), ("16", np.uint16)):
        s.export_bit_depth = depth
        path = str(tmp_path / f"projector ü {depth}.png")
        assert bpy.ops.lapig.export_image(filepath=path) == {"FINISHED"}
        import cv2

        data = cv2.imdecode(np.fromfile(path, np.uint8), cv2.IMREAD_UNCHANGED)
        assert data.dtype == dtype and data.shape == (120, 160, 3)
        # what Cycles projects is the light of exactly the exported pixels
        np.testing.assert_allclose(_light_pixels(s.projector), model.emitted(data[:, :, ::-1]), rtol=0, atol=1e-6)
        if depth == "8":  # the scene's default, so the light Generate set
            np.testing.assert_array_equal(generated_light, _light_pixels(s.projector))
        side = json.load(open(path[:-4] + ".json", encoding="utf-8"))
        assert side["prompt"] == s.prompt and side["projector"]["width"] == 160
        assert side["result_bit_depth"] == 16
    s.crossfade_frames = 3
    assert bpy.ops.lapig.export_crossfade(directory=str(tmp_path / "fade")) == {"FINISHED"}
    assert len([f for f in os.listdir(tmp_path / "fade") if f.endswith(".png")]) == 3

    # reopening the file restores where the user was
    bpy.ops.wm.save_mainfile()
    bpy.ops.wm.open_mainfile(filepath=bpy.data.filepath)
    state = scene_state.read(bpy.context.scene)
    assert state.result_dir == folder and panel_state.result_status(state).state == "DONE"


def _generate_blocker(scene):
    from lapig.lapig_addon.blender import scene_state
    from lapig.lapig_addon.services.panel import panel_state

    return panel_state.generate_blocker(scene_state.read(scene), scene_state.generate_request(scene))


def test_bad_input_is_refused_with_a_reason(captured, monkeypatch, tmp_path):
    scene = captured
    s = scene.lapig
    s.prompt = "   "
    assert _generate_blocker(scene) == "Type a prompt"
    with pytest.raises(RuntimeError, match="empty"):
        bpy.ops.lapig.generate()
    # missing weights: a clear message, nothing half-done
    monkeypatch.setattr("lapig.lapig_core.photometric.checkpoints.WEIGHTS_DIR", tmp_path / "no weights")
    s.prompt = "Make it a charcoal sketch ✏️ " + "very " * 400
    with pytest.raises(RuntimeError, match="pretrained CompenNeSt weights are missing"):
        bpy.ops.lapig.train_models()
    monkeypatch.undo()
    # an output larger than the projector's frame, or than the memory budget: refused before any work
    s.output_size = 200
    with pytest.raises(RuntimeError, match="larger than the projector's 160x120 frame: use at most 160"):
        bpy.ops.lapig.generate()
    s.output_size = 0
    monkeypatch.setattr("lapig.lapig_core.native_output.DEFAULT_BUDGET_MB", 10)
    with pytest.raises(RuntimeError, match="160x120 output needs about 16 MB, over the 10 MB memory budget"):
        bpy.ops.lapig.generate()
    monkeypatch.undo()
    # the object moved: captures are stale and the next steps say so
    s.target.location.x += 0.3
    bpy.context.view_layer.update()
    assert "capture again" in _generate_blocker(scene)
    with pytest.raises(RuntimeError, match="capture again"):
        bpy.ops.lapig.train_models()
    with pytest.raises(RuntimeError, match="Generate a projector image first"):
        bpy.ops.lapig.export_image(filepath=str(tmp_path / "x.png"))


def test_no_projector(lapig_registered):
    from lapig.lapig_addon.blender import demo_scene

    demo_scene.new_empty_scene()
    scene = bpy.context.scene
    assert _generate_blocker(scene) == "Add the projector and camera first"
    with pytest.raises(RuntimeError, match="Add the projector and camera first"):
        bpy.ops.lapig.generate()


def test_moved_blend_finds_its_data_again(captured, tmp_path):
    import shutil

    from lapig.lapig_addon.blender import storage

    old = bpy.data.filepath
    new_dir = tmp_path / "moved"
    new_dir.mkdir()
    bpy.ops.wm.save_mainfile()
    shutil.copytree(old[:-6] + "_lapig", str(new_dir / "wall_lapig"))
    shutil.copy(old, new_dir / "wall.blend")
    shutil.rmtree(old[:-6] + "_lapig")
    bpy.ops.wm.open_mainfile(filepath=str(new_dir / "wall.blend"))
    folder = storage.resolve_capture_dir(bpy.context.scene.lapig.last_capture_dir)
    assert folder.startswith(str(new_dir)) and os.path.isdir(folder)


def test_cancelled_generate_changes_nothing(captured):
    from lapig.lapig_addon.blender import projector_nodes, scene_state
    from lapig.lapig_addon.blender.scene_store import scene_seams
    from lapig.lapig_addon.services.generate.generate_job import GenerateJob

    scene = captured
    s = scene.lapig
    _psa_fast(scene)
    before = (s.result_dir, projector_nodes.projected_image(s.projector.data).name)
    job = GenerateJob(scene_seams(scene), scene_state.generate_request(scene), scene_state.finetune_iterations(scene))
    for _ in range(3):
        job.step()
    job.cancel()
    assert job.state == "CANCELLED"
    assert (s.result_dir, projector_nodes.projected_image(s.projector.data).name) == before


def test_unavailable_backend_falls_back_with_a_message(captured, tmp_path):
    from lapig.lapig_addon.blender import scene_state
    from lapig.lapig_addon.services.panel import panel_state
    from lapig.lapig_addon.blender.scene_store import scene_seams
    from lapig.lapig_addon.services.generate.generate_job import GenerateJob

    scene = captured
    request = scene_state.generate_request(scene, backend="instruct-pix2pix", psa=False,
                                           ip2p_model=str(tmp_path / "no model here"))
    warning = panel_state.backend_warning(request)
    assert "no model here" in warning or "diffusers" in warning
    out = GenerateJob(scene_seams(scene), request, scene_state.finetune_iterations(scene)).run_to_completion()
    assert "used 'styletransfer' instead" in out["summary"]["lgst"]["fallback"]


def test_cancelled_render_leaves_the_scene_as_it_was(captured):
    from lapig.lapig_addon.blender import capture_studio, projector_nodes
    from lapig.lapig_addon.blender.scene_store import scene_seams
    from lapig.lapig_addon.services.render.render_job import RenderResultJob

    scene = captured
    s = scene.lapig
    _psa_fast(scene)
    s.psa_adaptation = 0.0  # keep the look: PSA stops early
    assert bpy.ops.lapig.generate() == {"FINISHED"}
    image = projector_nodes.projected_image(s.projector.data).name
    scenes = set(bpy.data.scenes.keys())
    job = RenderResultJob(scene_seams(scene))
    while job.step() and not job.message.startswith("captured 1"):
        pass
    job.cancel()
    assert job.state == "CANCELLED"
    assert set(bpy.data.scenes.keys()) == scenes and capture_studio.STUDIO_NAME not in bpy.data.scenes
    assert projector_nodes.projected_image(s.projector.data).name == image


def test_generate_from_a_style_image_records_it(captured, tmp_path):
    import cv2

    from lapig.lapig_addon.blender import scene_state
    from lapig.lapig_addon.blender.scene_store import scene_seams
    from lapig.lapig_addon.services.generate.generate_job import GenerateJob, PipelineError

    scene = captured
    gray = (np.random.default_rng(0).random((40, 48)) * 255).astype(np.uint8)  # grayscale: converted, said
    painting = tmp_path / "gray painting.png"
    cv2.imwrite(str(painting), gray)
    request = scene_state.generate_request(scene, prompt="", style_images=(str(painting),), psa=False)
    out = GenerateJob(scene_seams(scene), request, scene_state.finetune_iterations(scene)).run_to_completion()
    with open(os.path.join(out["folder"], "result.json")) as f:
        lgst = json.load(f)["lgst"]
    assert lgst["backend"] == "arbitrary" and lgst["style_images"][0]["path"] == str(painting)
    assert lgst["style_images"][0]["file_size"] == [48, 40]
    assert any("grayscale" in n for n in lgst["notes"])
    assert "gray_painting" in os.path.basename(out["folder"])  # named after the image, no prompt
    tiny = tmp_path / "tiny.png"
    cv2.imwrite(str(tiny), gray[:8, :8])
    with pytest.raises(PipelineError, match="too small"):  # refused before any model runs
        GenerateJob(scene_seams(scene), scene_state.generate_request(scene, style_images=(str(tiny),))).prepare()


def _saved_choice(scene):
    from lapig.lapig_addon.blender import scene_state
    from lapig.lapig_core.photometric import choice

    models = os.path.join(scene_state.read(scene).capture_dir, "models")
    return json.load(open(os.path.join(models, choice.CHOICE_FILE)))


def test_train_chooses_the_compensator_by_rendering_both(captured_with_tests):
    """After fine-tuning, the rig renders both compensations of the held-back images in Cycles; the better
    capture decides, and the panel's model status and the saved choice say so."""
    from lapig.lapig_addon.blender import scene_state
    from lapig.lapig_core.photometric import choice

    scene = captured_with_tests
    assert bpy.ops.lapig.train_models() == {"FINISHED"}
    saved = _saved_choice(scene)
    assert saved["judge"] == choice.RENDERED_JUDGE and saved["validation_pairs"] == 2
    assert 10 < saved["learned_psnr"] < 60 and 10 < saved["classical_psnr"] < 60
    assert saved["chosen"] == (choice.LEARNED if saved["learned_psnr"] > saved["classical_psnr"] else choice.CLASSICAL)
    status = scene_state.read(scene).models_status
    assert "in Cycles captures of 2 held-back images" in status and saved["line"] in status


def test_a_cancel_while_rendering_the_choice_keeps_pcnets_choice(captured_with_tests):
    from lapig.lapig_addon.blender import scene_state
    from lapig.lapig_addon.blender.scene_store import scene_seams
    from lapig.lapig_addon.services.train.train_job import TrainModelsJob
    from lapig.lapig_core.photometric import choice

    scene = captured_with_tests
    job = TrainModelsJob(scene_seams(scene), 4)
    while job.step() and not job.message.startswith("measuring"):
        pass
    assert job.message.startswith("measuring both compensations on the rig")
    job.cancel()
    assert job.state == "CANCELLED"
    assert _saved_choice(scene)["judge"] == choice.PCNET_JUDGE  # the models' own, saved with them
    assert "PCNet's simulated captures" in scene_state.read(scene).models_status
    assert not scene.lapig.result_dir


def test_generate_after_capture_is_the_first_look_then_uses_trains_rendered_choice(captured_with_tests):
    """Capture fitted the classical model: Generate works at once with it and says so (issue 28); after Train,
    Generate uses the compensator the rig's renders chose."""
    from lapig.lapig_addon.blender import scene_state
    from lapig.lapig_core.photometric import choice, first_look

    scene = captured_with_tests
    _psa_fast(scene)
    assert scene_state.read(scene).models_status.startswith("First look: classical model")
    assert bpy.ops.lapig.generate() == {"FINISHED"}
    summary = json.load(open(os.path.join(scene_state.read(scene).result_dir, "result.json")))
    assert summary["models"]["first_look"] is True and summary["compensator"] is None
    assert first_look.FIRST_LOOK_LINE in scene.lapig.result_summary
    assert not os.path.exists(os.path.join(scene_state.read(scene).capture_dir, "models", choice.CHOICE_FILE))

    assert bpy.ops.lapig.train_models() == {"FINISHED"}
    assert _saved_choice(scene)["judge"] == choice.RENDERED_JUDGE
    assert bpy.ops.lapig.generate() == {"FINISHED"}
    summary = json.load(open(os.path.join(scene_state.read(scene).result_dir, "result.json")))
    assert summary["compensator"]["judge"] == choice.RENDERED_JUDGE and summary["models"]["first_look"] is False
    assert summary["models"]["compensator"] == _saved_choice(scene)["chosen"]


def test_a_capture_this_rig_did_not_make_keeps_pcnets_choice(captured_with_tests):
    """An imported data set (here: one made before the object moved) cannot be rendered by this rig:
    Train keeps the choice in PCNet's simulated captures, and says so."""
    from lapig.lapig_addon.blender import scene_state
    from lapig.lapig_core.photometric import choice

    scene = captured_with_tests
    folder = scene_state.read(scene).capture_dir
    scene.lapig.target.location.x += 0.05
    assert bpy.ops.lapig.import_capture(directory=folder) == {"FINISHED"}
    assert bpy.ops.lapig.train_models() == {"FINISHED"}
    assert _saved_choice(scene)["judge"] == choice.PCNET_JUDGE
    assert "PCNet's simulated captures" in scene_state.read(scene).models_status

import json

import bpy
import numpy as np
import pytest


def _settings(tmp_path, **kw):
    from lapig.lapig_addon.services.capture.capture_job import CaptureSettings

    base = dict(out_dir=str(tmp_path / "data"), setup_name="panel", train_count=4, test_count=2,
                working_size=64, chunk=8, check_grid_step=2)
    base.update(kw)
    return CaptureSettings(**base)


def _user_state(scene):
    """What a capture must leave exactly as it was."""
    r = scene.render
    return {
        "scenes": sorted(s.name for s in bpy.data.scenes),
        "objects": sorted(o.name for o in bpy.data.objects),
        "materials": {o.name: [m.name for m in o.data.materials] for o in bpy.data.objects if o.type == "MESH"},
        "lights": sorted(light.name for light in bpy.data.lights),
        "render": (r.engine, r.resolution_x, r.resolution_y, r.filepath, scene.cycles.samples,
                   scene.view_settings.view_transform, scene.frame_start, scene.frame_end),
        "collections": {o.name: sorted(c.name for c in o.users_collection) for o in bpy.data.objects},
        "worlds": sorted(w.name for w in bpy.data.worlds),
        "images": sorted(i.name for i in bpy.data.images),
    }


@pytest.mark.blender
def test_capture_writes_a_registered_dataset_and_restores_the_scene(small_setup, tmp_path):
    from lapig.lapig_addon.cli import headless
    from lapig.lapig_core.capture.dataset import load_capture_set

    scene, projector, camera, target = small_setup
    before = _user_state(scene)
    result = headless.run_capture(scene, _settings(tmp_path))
    assert _user_state(scene) == before

    meta = result["meta"]
    assert meta["valid_fraction"] > 0.95
    assert meta["registration"]["registration_error_px_median"] < 0.5
    assert meta["registration"]["registration_error_px_p95"] < 1.5
    assert meta["white_clipped_fraction"] < 0.02

    cs = load_capture_set(result["setup_dir"])
    # the 160x120 projector's whole frame, at working size 64
    assert cs.cam_train.shape == (4, 48, 64, 3) and cs.cam_test.shape == (2, 48, 64, 3)
    assert cs.meta["working_frame"] == [64, 48] and cs.projector_valid.mean() > 0.95
    # a real room: I- is dim but not black, I+ is bright, s in between
    assert 0.005 < cs.cam_black.mean() < cs.cam_gray.mean() < cs.cam_white.mean()
    assert cs.cam_white.mean() > 0.4
    # registered captures follow what was projected (same structure, surface-modulated)
    for prj, cam in zip(cs.prj_train, cs.cam_train):
        corr = np.corrcoef(prj.mean(-1).ravel(), cam.mean(-1).ravel())[0, 1]
        assert corr > 0.7
    saved = json.loads((tmp_path / "data" / "setups" / "panel" / "setup.json").read_text())
    assert saved["gray_level"] == 0.5 and saved["projector"]["width"] == 160


@pytest.mark.blender
def test_cancel_in_the_middle_restores_the_scene(small_setup, tmp_path):
    from lapig.lapig_addon.blender.scene_store import scene_seams
    from lapig.lapig_addon.services.capture.capture_job import CaptureJob

    scene, projector, camera, target = small_setup
    before = _user_state(scene)
    image_before = projector.data.node_tree.nodes["LAPIG projected image"].image
    job = CaptureJob(scene_seams(scene, projector, camera, target), _settings(tmp_path, chunk=4), record=False)
    for _ in range(4):
        assert job.step()
    assert any(s.name.startswith("LAPIG capture studio") for s in bpy.data.scenes)
    job.cancel()
    assert job.state == "CANCELLED"
    assert _user_state(scene) == before
    assert projector.data.node_tree.nodes["LAPIG projected image"].image == image_before
    setups = tmp_path / "data" / "setups"
    assert not setups.exists() or not any(setups.iterdir())  # no half-written setup left behind


@pytest.mark.blender
def test_cycles_device_shows_and_grabs_what_it_captures_in_batches(small_setup):
    from lapig.lapig_addon.blender.cycles_device import CyclesCaptureDevice

    scene, projector, camera, target = small_setup
    left = np.zeros((120, 160, 3), np.uint8)
    left[:, :80] = 255
    frames = [left, 255 - left]
    with CyclesCaptureDevice(scene, projector, camera, target, seed=3) as device:
        info = device.describe()
        batch = device.capture(frames)
    with CyclesCaptureDevice(scene, projector, camera, target, seed=3) as device:
        singles = []
        for frame in frames:
            device.show(frame)
            singles.append(device.grab())
    assert info.projector_size == (160, 120) and info.camera_size == (160, 120)
    assert all(a.dtype == np.uint8 and a.shape == (120, 160, 3) for a in batch)
    assert all(np.array_equal(a, b) for a, b in zip(batch, singles))  # same light, same noise
    assert np.abs(batch[0].astype(int) - batch[1]).mean() > 20  # each half lights its own part


@pytest.mark.blender
def test_studio_leaves_no_temporary_folder_even_when_the_scene_cannot_be_restored(small_setup, tmp_path,
                                                                                monkeypatch):
    import tempfile

    from lapig.lapig_addon.blender.capture_studio import CaptureStudio

    scene, projector, camera, _ = small_setup
    monkeypatch.setattr(tempfile, "tempdir", str(tmp_path))  # /tmp is shared with other runs
    studio = CaptureStudio(scene, projector, camera, 160, 120)
    assert not list(tmp_path.glob("lapig_render_*"))  # nothing on disk before it opens
    studio.__enter__()
    assert list(tmp_path.glob("lapig_render_*"))
    bpy.data.objects.remove(projector)  # e.g. another file loaded in the middle of a capture
    with pytest.raises(ReferenceError):
        studio.close()
    assert not list(tmp_path.glob("lapig_render_*"))


@pytest.mark.blender
def test_object_outside_the_projector_is_refused_with_the_coverage(small_setup, tmp_path):
    from lapig.lapig_addon.cli import headless
    from lapig.lapig_addon.services.capture.capture_job import CaptureError

    scene, projector, camera, target = small_setup
    before = _user_state(scene)
    projector.rotation_euler.z += 1.2  # aim well away from the panel
    with pytest.raises(CaptureError, match=r"covers \d+% of the projector"):
        headless.run_capture(scene, _settings(tmp_path))
    assert _user_state(scene) == before


@pytest.mark.blender
def test_capture_settings_are_the_scenes_with_the_callers_overrides(small_setup, tmp_path):
    from lapig.lapig_addon.blender import scene_state

    scene = small_setup[0]
    scene.lapig.ambient, scene.lapig.gray_level, scene.lapig.train_count = 0.12, 0.4, 20
    settings = scene_state.capture_settings(scene, out_dir=str(tmp_path), train_count=2, seed=None)
    assert (settings.out_dir, settings.train_count, settings.test_count) == (str(tmp_path), 2, 8)
    assert settings.ambient == pytest.approx(0.12) and settings.gray_level == pytest.approx(0.4)
    assert settings.setup_name == "LAPIG_demo_panel" and settings.pattern_folder is None


@pytest.mark.blender
def test_capture_operator_reports_missing_rig(lapig_registered):
    from lapig.lapig_addon.blender import demo_scene

    demo_scene.new_empty_scene()
    with pytest.raises(RuntimeError, match="Add the projector and camera first"):
        bpy.ops.lapig.capture()


@pytest.mark.blender
def test_capture_operator_on_unsaved_file_uses_a_temporary_folder(small_setup):
    import shutil

    from lapig.lapig_addon.blender import scene_state, storage
    from lapig.lapig_addon.services.panel.panel_state import capture_status

    scene = small_setup[0]
    s = scene.lapig
    s.train_count, s.test_count, s.working_size = 2, 0, 32
    folder, temporary = storage.data_root()
    assert temporary and "lapig_unsaved" in folder
    try:
        assert bpy.ops.lapig.capture() == {"FINISHED"}
        assert s.last_capture_dir.startswith(folder)
        assert capture_status(scene_state.read(scene)).state == "DONE"
        small_setup[3].location.x += 0.1  # the object moved: the capture is stale
        bpy.context.view_layer.update()  # as any redraw does in the UI
        assert capture_status(scene_state.read(scene)).state == "STALE"
    finally:
        shutil.rmtree(folder, ignore_errors=True)
    assert capture_status(scene_state.read(scene)).state == "MISSING"  # its folder is gone


@pytest.mark.blender
def test_capture_sees_the_real_surface_while_the_preview_is_on(small_setup, tmp_path):
    from lapig.lapig_addon.cli import headless
    from lapig.lapig_addon.blender import preview, projector_nodes

    scene, projector, camera, target = small_setup
    preview.enable_preview(target, projector, projector_nodes.projected_image(projector.data))
    shown = target.material_slots[0].material.name
    headless.run_capture(scene, _settings(tmp_path, train_count=1, test_count=0))
    assert preview.is_previewing(target) and target.material_slots[0].material.name == shown
    preview.disable_preview(target)
    assert target.material_slots[0].material.name == "sakura surface"


@pytest.mark.blender
@pytest.mark.torch  # the import checks the set with the dataset loader, which the add-on runs with torch
def test_import_capture_folder_accepts_a_good_set_and_names_the_bad_file(small_setup, tmp_path):
    from lapig.lapig_addon.cli import headless

    scene = small_setup[0]
    result = headless.run_capture(scene, _settings(tmp_path, train_count=2, test_count=0))
    setup_dir = str(result["setup_dir"])
    assert bpy.ops.lapig.import_capture(directory=setup_dir) == {"FINISHED"}
    assert scene.lapig.last_capture_dir == setup_dir
    # a set of another aspect (as a public 256x256 one for a 4:3 projector) cannot cover the frame
    projector = small_setup[1].lapig_projector
    projector.resolution_x = projector.resolution_y
    with pytest.raises(RuntimeError, match=r"64x48 \(aspect 1.333\) but the projector is 120x120"):
        bpy.ops.lapig.import_capture(directory=setup_dir)
    with pytest.raises(RuntimeError, match=r"the capture is 64x48 .* cannot cover the projector's frame"):
        bpy.ops.lapig.train_models()  # the imported capture, now of another aspect than the projector
    projector.resolution_x = 160
    broken = tmp_path / "data" / "setups" / "panel" / "cam" / "warp" / "train" / "img_0002.png"
    broken.write_bytes(b"not a png")
    with pytest.raises(RuntimeError, match="img_0002.png"):
        bpy.ops.lapig.import_capture(directory=setup_dir)

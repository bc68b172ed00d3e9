"""Run in a fresh Python with BLENDER_USER_RESOURCES set: install one zip with Blender's Install from Disk
operator and print what Blender did with it, as one line `ZIP RESULT {json}`.

Usage: python install_for_python.py EXTENSION.zip
"""
import contextlib
import importlib.util
import io
import json
import os
import sys

import bpy

module = "bl_ext.user_default.lapig"
said = io.StringIO()
with contextlib.redirect_stdout(said), contextlib.redirect_stderr(said):
    try:
        result = sorted(bpy.ops.extensions.package_install_files(filepath=sys.argv[1], repo="user_default",
                                                                  enable_on_install=True))
    except RuntimeError as exc:  # an operator that reports an ERROR raises in background mode
        result = ["ERROR", str(exc)]
import addon_utils  # noqa: E402

probe = importlib.util.find_spec("lapig_probe")
local = os.path.join(os.environ["BLENDER_USER_RESOURCES"], "extensions", ".local")
print("ZIP RESULT " + json.dumps({
    "blender": bpy.app.version_string, "python": "%d.%d" % sys.version_info[:2], "result": result,
    "enabled": bool(addon_utils.check(module)[1]),
    "installed": os.path.isfile(os.path.join(os.environ["BLENDER_USER_RESOURCES"], "extensions", "user_default",
                                             "lapig", "blender_manifest.toml")),
    "wheel_unpacked": bool(probe and probe.origin and probe.origin.startswith(local)),
    "said": said.getvalue()[-3000:]}))

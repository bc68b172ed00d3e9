"""`blender -b file.blend -c lapig ...`: the same command line as `python -m lapig_addon`."""
from __future__ import annotations

import bpy

_handle = None


def _run(argv):
    from . import main as cli

    return cli.main(list(argv))


def register():
    global _handle
    if hasattr(bpy.utils, "register_cli_command"):
        _handle = bpy.utils.register_cli_command("lapig", _run)


def unregister():
    global _handle
    if _handle is not None:
        bpy.utils.unregister_cli_command(_handle)
        _handle = None

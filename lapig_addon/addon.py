"""Registration of everything the add-on adds to Blender, in dependency order."""
from __future__ import annotations

import importlib

_MODULES = (
    "..lapig_addon.properties",
    "..lapig_addon.preferences",
    "..operators",
    "..panels",
    "..lapig_addon.cli_command",
)


def _modules():
    return [importlib.import_module(name, __package__) for name in _MODULES]


_registered = []


def _embedding_mode(mode):
    """In Blender's UI the prompt model runs in a helper process: loading it in-process holds the
    GIL long enough to freeze the UI (bench ui). Headless runs keep it in-process."""
    try:
        from ..lapig_core.lgst import prompt_mapping
    except ImportError:  # torch missing: the panels say so
        return
    if mode is None:
        prompt_mapping.shutdown_embedding_process()
        prompt_mapping.set_embedding_mode("inprocess")
    else:
        prompt_mapping.set_embedding_mode(mode)


def register():
    import bpy

    for module in _modules():
        module.register()
        _registered.append(module)
    if not bpy.app.background:
        _embedding_mode("subprocess")


def unregister():
    while _registered:
        _registered.pop().unregister()
    _embedding_mode(None)


def is_registered() -> bool:
    return bool(_registered)

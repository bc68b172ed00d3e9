"""Registration of everything the add-on adds to Blender, in dependency order."""
from __future__ import annotations

import importlib
import sys

from ...lapig_core.common.embedding_mode import DEFAULT_MODE, set_embedding_mode

_MODULES = (
    ".properties",
    ".light_properties",
    ".preferences",
    ".torch_installer",
    ".model_manager",
    ".prompt_preview",
    "...operators",
    "...panels",
    ".live_devices",
    ".modal_runner",
    ".look_sliders",
    ".show_timeline",
    "..cli.blender_command",
)


def _modules():
    return [importlib.import_module(name, __package__) for name in _MODULES]


_registered = []


def extension_package() -> str:
    """The extension's own package name (e.g. bl_ext.user_default.lapig): two levels above here."""
    return __package__.rsplit(".", 2)[0]


def _stop_embedding_process():
    root = extension_package()
    prompt_mapping = sys.modules.get(root + ".lapig_core.lgst.prompt_mapping")
    if prompt_mapping is not None:  # only if it was ever used: never import torch here
        prompt_mapping.shutdown_embedding_process()


def register():
    import bpy

    for module in _modules():
        module.register()
        _registered.append(module)
    if not bpy.app.background:  # a UI to keep responsive: the prompt model runs in a helper process
        set_embedding_mode("subprocess")


def unregister():
    while _registered:
        _registered.pop().unregister()
    set_embedding_mode(DEFAULT_MODE)
    _stop_embedding_process()


def is_registered() -> bool:
    return bool(_registered)

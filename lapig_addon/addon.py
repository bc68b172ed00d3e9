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


def register():
    for module in _modules():
        module.register()
        _registered.append(module)


def unregister():
    while _registered:
        _registered.pop().unregister()


def is_registered() -> bool:
    return bool(_registered)

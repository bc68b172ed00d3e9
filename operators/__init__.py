"""Operators: thin wrappers that validate input, call lapig_addon, and report to the user."""
from . import capture_ops, light_ops, pipeline_ops, preview_ops, real_rig_ops, rig_ops, show_ops

_MODULES = (rig_ops, real_rig_ops, capture_ops, pipeline_ops, preview_ops, light_ops, show_ops)


def register():
    for module in _MODULES:
        module.register()


def unregister():
    for module in reversed(_MODULES):
        module.unregister()

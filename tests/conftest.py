"""Test setup: load the repository root as the extension package `lapig`, as Blender does.

lapig_core is also importable on its own (`import lapig_core`) for the bpy-free tests.
"""
from lapig_addon.__main__ import _load_extension_package

_load_extension_package()

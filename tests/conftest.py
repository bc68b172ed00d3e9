"""Test setup: load the repository root as the extension package `lapig`, as Blender does.

lapig_core is also importable on its own (`import lapig_core`) for the bpy-free tests.
"""
import importlib.util

import pytest

from lapig_addon.__main__ import _load_extension_package

_load_extension_package()

HAS_TORCH = importlib.util.find_spec("torch") is not None


def pytest_collection_modifyitems(config, items):
    """Tests marked `torch` skip where torch is absent (the version matrix's torch-free venvs).
    Modules that import torch themselves use pytest.importorskip("torch")."""
    if HAS_TORCH:
        return
    skip = pytest.mark.skip(reason="needs torch, which is not installed")
    for item in items:
        if "torch" in item.keywords:
            item.add_marker(skip)

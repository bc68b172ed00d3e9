"""One package name in a test run: the code is `lapig.lapig_core...`, and a second name is caught."""
import importlib.util
import sys
import types

import pytest
from package_names import files_loaded_twice


def test_the_top_level_names_are_not_importable():
    """As in the installed extension: no top-level lapig_core or lapig_addon beside the package."""
    for name in ("lapig_core", "lapig_addon"):
        with pytest.raises(ImportError):
            __import__(name)
    assert importlib.util.find_spec("lapig.lapig_core.rig.tethered") is not None


def test_a_file_loaded_under_two_names_is_found():
    real = sys.modules["lapig.lapig_core.common.imageio"]
    copy = types.ModuleType("lapig_core.common.imageio")
    copy.__file__ = real.__file__
    twice = files_loaded_twice({"lapig.lapig_core.common.imageio": real, "lapig_core.common.imageio": copy})
    assert list(twice.values()) == [["lapig.lapig_core.common.imageio", "lapig_core.common.imageio"]]
    assert files_loaded_twice({"lapig.lapig_core.common.imageio": real}) == {}

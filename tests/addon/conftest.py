"""The add-on's logic without Blender: each test imports it afresh with bpy blocked.

With sys.modules['bpy'] = None any import of bpy, direct or through another module, raises
ImportError, so a passing test also proves that the modules it uses do not need bpy. The block
lasts one test: the Cycles tests of the same session still find bpy and the modules they loaded.
"""
import importlib
import sys

import pytest

ADDON = "lapig.lapig_addon"


@pytest.fixture(autouse=True)
def bpy_blocked(monkeypatch):
    for name in [n for n in sys.modules if n == "bpy" or n.startswith(("bpy.", ADDON))]:
        monkeypatch.delitem(sys.modules, name)  # restored after the test
    monkeypatch.setitem(sys.modules, "bpy", None)
    package = importlib.import_module("lapig")
    monkeypatch.setattr(package, "lapig_addon", getattr(package, "lapig_addon", None), raising=False)


@pytest.fixture
def state():
    return importlib.import_module(ADDON + ".services.state")


@pytest.fixture
def panel_state():
    return importlib.import_module(ADDON + ".services.panel.panel_state")


@pytest.fixture
def seams(tmp_path):
    """The job seams over the fake rig of job_fakes: a store, a device factory and one sink."""
    from job_fakes import FakeFactory, FakeSink, FakeStore

    ports = importlib.import_module(ADDON + ".services.ports")
    state = importlib.import_module(ADDON + ".services.state")
    factory = FakeFactory(ports)
    return ports.Seams(FakeStore(state, tmp_path / "data", factory), factory, (FakeSink(),))

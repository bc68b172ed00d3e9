import importlib

import pytest


def test_the_logic_imports_and_the_blender_side_is_refused(state, panel_state):
    assert state.SceneState().rig == state.Rig() and panel_state.StepStatus("DONE", "").state == "DONE"
    with pytest.raises(ImportError):  # the block works: the bpy reader cannot load here
        importlib.import_module("lapig.lapig_addon.blender.scene_state")

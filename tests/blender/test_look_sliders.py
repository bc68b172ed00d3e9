"""A world look's sliders in Blender (issue 50, item 4): after Generate they show the look's values; a slider set and
Update Look make the result's image again, with the value kept in result.json; a look of another kind shows none."""
import json
import os

import numpy as np
import pytest

bpy = pytest.importorskip("bpy")

pytestmark = [pytest.mark.blender, pytest.mark.torch]  # the looks of the world (lgst) load torch


def _target(folder):
    from lapig.lapig_core.export.result_files import read_result_image

    return read_result_image(folder, "target")


def test_a_slider_set_makes_the_result_image_again(captured):
    from lapig.lapig_addon.blender import scene_state

    s = captured.lapig
    s.prompt, s.use_psa = "old cobblestones", False
    assert bpy.ops.lapig.generate() == {"FINISHED"}
    assert scene_state.look_sliders_shown(captured) and s.look_scale == pytest.approx(1.0)
    folder = scene_state.read(captured).result_dir
    before = _target(folder)
    s.look_scale = 2.5  # in background mode the slider's update makes nothing: the script asks
    assert np.array_equal(_target(folder), before)
    assert bpy.ops.lapig.edit_look() == {"FINISHED"}
    assert np.abs(_target(folder) - before).mean() > 0.01
    summary = json.load(open(os.path.join(folder, "result.json"), encoding="utf-8"))
    assert summary["lgst"]["look_parameters"]["scale"] == 2.5 and "Scale 1 -> 2.5" in s.result_summary
    # the look as a shader node group, with the slider's scale, in the object's own material
    assert bpy.ops.lapig.look_nodes() == {"FINISHED"}
    group = bpy.data.node_groups["LAPIG look: cobblestones"]
    texture = group.nodes["LAPIG texture"]
    assert texture.bl_idname == "ShaderNodeTexVoronoi" and texture.feature == "DISTANCE_TO_EDGE"
    from lapig.lapig_core.lgst.world.catalog import by_name

    assert texture.inputs["Scale"].default_value == pytest.approx(by_name()["cobblestones"].scale * 2.5, rel=1e-4)
    from lapig.lapig_addon.blender.look_nodes import _own_material

    own = _own_material(scene_state.rig_objects(captured)[2])  # not the preview's, where it shows one
    assert any(n.bl_idname == "ShaderNodeGroup" and n.node_tree == group for n in own.node_tree.nodes)
    assert bpy.ops.lapig.edit_look(reset=True) == {"FINISHED"}
    assert s.look_scale == pytest.approx(1.0)  # the sliders follow the result
    s.prompt, s.style_override = "", "charcoal_wash:1"
    assert bpy.ops.lapig.generate() == {"FINISHED"}
    assert not scene_state.look_sliders_shown(captured)

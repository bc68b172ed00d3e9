"""The Blend preview of a rig of two projectors (issue 36): each projector's light shows its share of the object
in its own colour, and a tiny Cycles render of the scene shows red where the first reaches alone and green
where the second does."""
import os

import bpy
import numpy as np
import pytest

from test_multi_projector import _statue_lit_from_the_front_left


def _render(scene, camera, path, size=(80, 60)):
    scene.camera = camera
    r = scene.render
    r.engine = "CYCLES"
    r.resolution_x, r.resolution_y, r.resolution_percentage = size[0], size[1], 100
    scene.cycles.samples = 32
    r.image_settings.file_format = "OPEN_EXR"
    r.filepath = str(path)
    bpy.ops.render.render(write_still=True, scene=scene.name)
    image = bpy.data.images.load(str(path))
    w, h = image.size
    px = np.array(image.pixels[:], np.float32).reshape(h, w, 4)[::-1, :, :3]
    bpy.data.images.remove(image)
    return px


@pytest.mark.blender
def test_the_blend_preview_lights_each_projectors_share_in_its_colour(lapig_registered, tmp_path):
    from lapig.lapig_addon.blender import projector_nodes, scene_state
    from lapig.lapig_core.multi.blend import blend_weights
    from lapig.lapig_core.multi.first_look import load_joint_model

    scene, projector, camera, target = _statue_lit_from_the_front_left(tmp_path)
    bpy.ops.wm.save_as_mainfile(filepath=str(tmp_path / "statue.blend"))
    assert bpy.ops.lapig.add_projector() == {"FINISHED"}
    with pytest.raises(RuntimeError, match="capture the rig of several projectors first"):
        bpy.ops.lapig.blend_preview()
    assert bpy.ops.lapig.capture() == {"FINISHED"}
    assert bpy.ops.lapig.blend_preview() == {"FINISHED"}
    projectors = scene_state.rig_projectors(scene)
    shown = [projector_nodes.projected_image(p.data) for p in projectors]
    assert [i.name for i in shown] == ["LAPIG blend share 1", "LAPIG blend share 2"]

    model = load_joint_model(scene_state.read(scene).capture_dir)
    weights = blend_weights(model.maps)
    reached = model.reached
    render = _render(scene, camera, tmp_path / "blend.exr")
    assert render.shape[:2] == model.shape
    first = reached[0] & ~reached[1] & (weights[0] > 0.99)
    second = reached[1] & ~reached[0] & (weights[1] > 0.99)
    assert first.sum() > 50 and second.sum() > 50
    r1, g1 = render[first][:, 0].mean(), render[first][:, 1].mean()
    r2, g2 = render[second][:, 0].mean(), render[second][:, 1].mean()
    print("first alone: red", r1, "green", g1, "; second alone: red", r2, "green", g2)
    assert r1 > 3 * g1 and g2 > 3 * r2  # red where the first reaches alone, green where the second does
    assert render[..., 2][first | second].mean() < 0.3 * max(r1, g2)  # neither lights blue

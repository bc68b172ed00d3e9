"""The Blend preview of a rig of two projectors (issue 36): each projector's light shows its share of the object
in its own colour, and a tiny Cycles render of the scene shows red where the first reaches alone and green
where the second does."""
import os

import bpy
import numpy as np
import pytest

from test_multi_projector import _statue_lit_from_the_front_left


def _images_upstream(socket) -> set:
    """The images of every image node that feeds `socket`, through any nodes between."""
    images, todo = set(), [link.from_node for link in socket.links]
    while todo:
        node = todo.pop()
        if node.bl_idname == "ShaderNodeTexImage":
            images.add(node.image)
        todo.extend(link.from_node for sock in node.inputs for link in sock.links)
    return images


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


@pytest.mark.blender
@pytest.mark.torch
def test_the_result_preview_modes_of_several_cast_the_camera_space_images_from_the_camera(lapig_registered, tmp_path):
    """A result of two projectors lives in the camera's frame: Target, Problem areas and Rendered (Lux and Contrast
    too) cast their images from the rig's camera, so a render from that camera shows each where the camera saw it; Projection casts both
    projectors' images at once; Original puts the materials back as they were, and the result is untouched."""
    from lapig.lapig_addon.blender import preview, projector_nodes, result_preview, scene_state
    from lapig.lapig_core.common.imageio import read_image, write_png
    from lapig.lapig_core.multi.first_look import load_joint_model
    from lapig.lapig_core.multi.result_files import problem_areas

    scene, projector, camera, target = _statue_lit_from_the_front_left(tmp_path)
    bpy.ops.wm.save_as_mainfile(filepath=str(tmp_path / "statue.blend"))
    originals = [slot.material.name if slot.material else "" for slot in target.material_slots]
    assert bpy.ops.lapig.add_projector() == {"FINISHED"}
    assert bpy.ops.lapig.capture() == {"FINISHED"}
    assert bpy.ops.lapig.generate() == {"FINISHED"}
    state = scene_state.read(scene)
    look = read_image(os.path.join(state.result_dir, "look.png"))
    files = {name: os.stat(os.path.join(state.result_dir, name)).st_mtime_ns for name in os.listdir(state.result_dir)}
    reached = load_joint_model(state.capture_dir).reached.any(axis=0)

    reports = []
    assert result_preview.apply_mode(scene, "TARGET", lambda kind, text: reports.append(text)), reports
    assert preview.is_previewing(target) and target.get("lapig_preview_caster") == camera.name
    seen = _render(scene, camera, tmp_path / "target.exr")
    shown = np.clip(seen, 0, 1)  # the preview emits the image's values as they are (as one projector's does)
    write_png(str(tmp_path / "target_preview.png"), np.concatenate([look, shown], axis=1))
    inner = reached.copy()
    inner[[0, -1], :] = inner[:, [0, -1]] = False
    error = np.abs(shown - look)[inner].mean()
    print("target preview against the look: mean abs", error)
    assert error < 0.06  # the look lands where the camera saw it (a misplaced cast is off by its texture)
    shifted = np.abs(np.roll(shown, 4, axis=1) - look)[inner].mean()
    assert shifted > error + 0.01

    # Problem areas: the joint capture's shortfall from the look, cast from the camera as well
    assert result_preview.apply_mode(scene, "COMPENSABILITY", lambda kind, text: reports.append(text)), reports
    problems = problem_areas(state.result_dir)
    seen = np.clip(_render(scene, camera, tmp_path / "problems.exr"), 0, 1)
    write_png(str(tmp_path / "problems_preview.png"), np.concatenate([problems, seen], axis=1))
    error = np.abs(seen - problems)[inner].mean()
    print("problem areas preview against the map: mean abs", error)
    assert error < 0.06 and np.abs(np.roll(seen, 4, axis=1) - problems)[inner].mean() > error + 0.005

    assert not result_preview.apply_mode(scene, "RENDERED", lambda kind, text: reports.append(text))
    assert reports[-1] == "Rendered: press Render Real Capture first"
    assert preview.is_previewing(target)  # a refused mode leaves the preview as it was
    # Projection: each projector's light carries its own image (Generate set them), and the surface shows their sum
    projectors = scene_state.rig_projectors(scene)
    lights = [projector_nodes.projected_image(p.data) for p in projectors]
    assert len(projectors) == 2 and None not in lights and lights[0] != lights[1]
    assert result_preview.apply_mode(scene, "PROJECTION", lambda kind, text: reports.append(text)), reports
    assert list(target["lapig_preview_casters"]) == [p.name for p in projectors]
    for slot in target.material_slots:
        nodes = slot.material.node_tree.nodes
        cast = sorted((n for n in nodes if n.name.startswith("LAPIG projected image")), key=lambda n: n.name)
        assert [n.image for n in cast] == lights
        coords = [n.object for n in nodes if n.bl_idname == "ShaderNodeTexCoord"]
        assert sorted(c.name for c in coords) == sorted(p.name for p in projectors)
        adds = [n for n in nodes if n.bl_idname == "ShaderNodeMix" and n.blend_type == "ADD"]
        # each side of the sum is one projector's image, weighted by its light's reach
        assert len(adds) == 1 and _images_upstream(adds[0].inputs["A"]) | _images_upstream(adds[0].inputs["B"]) \
            == set(lights) and all(len(_images_upstream(adds[0].inputs[side])) == 1 for side in "AB")
    # a capture borrows the real surface and gives the preview back with both casts
    with preview.real_surface(target, projector):
        assert not preview.is_previewing(target)
    assert list(target["lapig_preview_images"]) == [i.name for i in lights]

    # Render Real Capture and the Light Report give Rendered, Lux and Contrast their camera-space images
    assert bpy.ops.lapig.render_result() == {"FINISHED"} and bpy.ops.lapig.light_report() == {"FINISHED"}
    rendered = read_image(os.path.join(state.result_dir, "rendered.png"))
    assert result_preview.apply_mode(scene, "RENDERED", lambda kind, text: reports.append(text)), reports
    seen = np.clip(_render(scene, camera, tmp_path / "rendered.exr"), 0, 1)
    assert np.abs(seen - rendered)[inner].mean() < 0.06
    for mode, name in (("LUX", "light_lux"), ("CONTRAST", "light_contrast")):
        assert result_preview.apply_mode(scene, mode, lambda kind, text: reports.append(text)), reports
        assert target["lapig_preview_caster"] == camera.name
        assert target["lapig_preview_image"] == result_preview.IMAGE_PREFIX + "camera " + name
    files = {name: os.stat(os.path.join(state.result_dir, name)).st_mtime_ns for name in os.listdir(state.result_dir)}

    for mode in ("SIMULATED", "TARGET", "ORIGINAL"):
        assert result_preview.apply_mode(scene, mode)
    assert not preview.is_previewing(target)
    assert [slot.material.name if slot.material else "" for slot in target.material_slots] == originals
    assert not [k for k in target.keys() if k.startswith("lapig_preview")]
    assert not [m.name for m in bpy.data.materials if m.name.startswith(preview.PREVIEW_PREFIX)]
    assert preview.UV_NAME not in target.data.uv_layers and preview.UV_NAME not in target.modifiers
    assert files == {n: os.stat(os.path.join(state.result_dir, n)).st_mtime_ns for n in os.listdir(state.result_dir)}

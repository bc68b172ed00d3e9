import bpy
import numpy as np
import pytest


@pytest.mark.blender
@pytest.mark.parametrize("shape,min_cover", [("panel", 0.99), ("box", 0.55), ("statue", 0.3)])
def test_add_rig_aims_at_wall_box_and_statue(lapig_registered, tmp_path, shape, min_cover):
    from lapig.lapig_addon.blender import demo_scene, geometry_probe as probe, rig
    from lapig.lapig_addon.blender.scene_state import projector_model

    demo_scene.new_empty_scene()
    target = demo_scene.add_surface_object(shape, "wood", folder=str(tmp_path), size=64)
    target.select_set(True)
    bpy.context.view_layer.objects.active = target
    assert bpy.ops.lapig.add_rig() == {"FINISHED"}
    s = bpy.context.scene.lapig
    assert s.projector.lapig_projector.is_projector and s.camera.type == "CAMERA" and s.target == target
    tree = s.projector.data.node_tree
    assert tree.nodes.get("LAPIG projected image") is not None

    # the object fills much of the projector frame (its whole frame: a box or a statue leaves the
    # corners free) and the camera sees what is lit
    dg = bpy.context.evaluated_depsgraph_get()
    bvh = probe.scene_bvh([target], dg)
    scene = bpy.context.scene
    scene.render.resolution_x, scene.render.resolution_y = 480, 360
    cam = probe.CameraProjection(s.camera, scene, 480, 360)
    cover = probe.coverage(bvh, s.projector, projector_model(s.projector), cam, bvh)
    assert cover["projector_on_object"] >= min_cover
    assert cover["seen_by_camera"] >= min_cover - 0.05
    # the camera sees the whole object: every vertex projects inside the frame
    verts, _ = rig.object_world_vertices(target, dg)
    xy = cam.project(verts)
    if shape != "panel":  # a wall is framed on its lit part, larger than the frame is fine
        assert np.all((xy[:, 0] > -0.5) & (xy[:, 0] < 479.5) & (xy[:, 1] > -0.5) & (xy[:, 1] < 359.5))


@pytest.mark.blender
def test_add_rig_without_selection_reports_an_error(lapig_registered):
    from lapig.lapig_addon.blender import demo_scene

    demo_scene.new_empty_scene()
    with pytest.raises(RuntimeError, match="Select the mesh"):
        bpy.ops.lapig.add_rig()
    assert len(bpy.data.objects) == 0  # nothing half-made


@pytest.mark.blender
def test_projector_properties_rebuild_the_light_nodes(small_setup):
    scene, projector, camera, target = small_setup
    node = projector.data.node_tree.nodes["LAPIG u scale"]
    projector.lapig_projector.throw_ratio = 2.0
    assert node.inputs[1].default_value == pytest.approx(-2.0)
    projector.lapig_projector.brightness = 1234.0
    assert projector.data.energy == pytest.approx(1234.0)


@pytest.mark.blender
def test_viewport_preview_is_reversible_and_keeps_user_materials(small_setup, tmp_path):
    from lapig.lapig_addon.blender import preview

    scene, projector, camera, target = small_setup
    original = target.material_slots[0].material
    names_before = sorted(m.name for m in bpy.data.materials)
    assert bpy.ops.lapig.preview_toggle() == {"FINISHED"}
    shown = target.material_slots[0].material
    assert shown is not original and shown.name.startswith(preview.PREVIEW_PREFIX)
    assert shown.node_tree.nodes.active.image == projector.data.node_tree.nodes["LAPIG projected image"].image
    assert original.use_fake_user  # survives a save while previewing
    assert target.data.uv_layers.active.name == preview.UV_NAME and target.modifiers.get(preview.UV_NAME)
    objects_while = len(bpy.data.objects)
    # a save and reload while previewing keeps the user's material
    path = str(tmp_path / "preview.blend")
    bpy.ops.wm.save_as_mainfile(filepath=path)
    bpy.ops.wm.open_mainfile(filepath=path)
    scene = bpy.context.scene
    target = scene.lapig.target
    assert bpy.data.materials.get("sakura surface") is not None
    assert bpy.ops.lapig.preview_toggle() == {"FINISHED"}
    assert target.material_slots[0].material.name == "sakura surface"
    assert not target.material_slots[0].material.use_fake_user
    assert sorted(m.name for m in bpy.data.materials) == names_before
    assert target.data.uv_layers.active.name == "UVMap" and not target.modifiers
    assert len(bpy.data.objects) == objects_while - 1  # the hidden lens camera is gone

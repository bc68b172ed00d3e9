"""export 'sl' (shader lamp) MPCDI of two projectors over a plane, read back strictly (issue 36)."""
import math

import numpy as np
import pytest

bpy = pytest.importorskip("bpy")


def _scene():
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    bpy.ops.mesh.primitive_plane_add(size=4.0, location=(0.0, 0.0, 0.0))
    target = bpy.context.active_object
    projectors = []
    for k, (x, yaw) in enumerate(((-0.6, -0.15), (0.7, 0.2))):
        ob = bpy.data.objects.new(f"P{k + 1}", None)  # an empty: the pose is all the package needs
        scene.collection.objects.link(ob)
        ob.location = (x, -0.3, 2.5)
        ob.rotation_euler = (0.1, yaw, 0.05 * k)
        projectors.append(ob)
    bpy.context.view_layer.update()
    return scene, target, projectors


def test_sl_package_round_trip(tmp_path):
    from lapig.lapig_addon.blender.geometry_probe import sl_rig_geometry
    from lapig.tools.checks.mpcdi_read import read_mpcdi
    from lapig.lapig_core.multi.mpcdi_export import (sl_coordinate_frame, sl_frustum, sl_texel_pixels,
                                                     write_rig_mpcdi_sl)
    from lapig.lapig_core.optics.projector_model import ProjectorModel

    scene, target, projectors = _scene()
    models = [ProjectorModel(width=64, height=48, throw_ratio=1.4, shift_x=0.05, shift_y=-0.1),
              ProjectorModel(width=80, height=50, throw_ratio=1.8)]
    geometry = sl_rig_geometry(scene, projectors, models, step=8)
    alphas = [np.full((m.height, m.width), 0.5) for m in models]
    path = write_rig_mpcdi_sl(tmp_path / "rig.mpcdi", ["P1", "P2"], models, geometry["matrices"],
                              geometry["points"], alphas)
    package = read_mpcdi(path)
    assert package.profile == "sl"
    assert b"<!-- LAPIG shader-lamp package. 3D data: Blender world coordinates, Z up" in package.descriptor
    assert [b.id for b in package.buffers] == ["P1", "P2"]
    for k, (ob, model) in enumerate(zip(projectors, models)):
        region = package.regions[f"P{k + 1} region"]
        want_f, want_c = sl_frustum(model), sl_coordinate_frame(np.array(ob.matrix_world))
        for name in ("yaw", "pitch", "roll", "right_angle", "left_angle", "up_angle", "down_angle"):
            assert getattr(region.frustum, name) == pytest.approx(getattr(want_f, name), abs=1e-4)
        # the frame is the object's own, read from Blender directly
        m = np.array(ob.matrix_world)
        assert region.coordinate_frame.position == pytest.approx(tuple(m[:3, 3]), abs=1e-4)
        assert region.coordinate_frame.roll_axis == pytest.approx(tuple(-m[:3, 2]), abs=1e-4)
        assert region.coordinate_frame.yaw_axis == pytest.approx(tuple(m[:3, 1]), abs=1e-4)
        assert region.coordinate_frame.pitch_axis == pytest.approx(tuple(m[:3, 0]), abs=1e-4)
        assert want_c.position == pytest.approx(region.coordinate_frame.position, abs=1e-4)
        # the frustum's edge angles are the lens's: the right edge of the image through the model
        right = model.pixel_to_direction(np.array([model.width - 0.5, model.height / 2 - 0.5]))
        assert region.frustum.right_angle == pytest.approx(
            math.degrees(math.atan2(right[0], -right[2])), abs=0.6)  # within half a pixel's angle
        warp = package.warp(region.id)
        pixels = sl_texel_pixels(model, 8)
        assert warp.shape == pixels.shape[:2] + (3,)
        hit = np.isfinite(warp).all(axis=-1)
        assert hit.sum() > 0.5 * hit.size
        points = warp[hit].astype(np.float64)
        # on the object: the plane z = 0, |x|, |y| <= 2
        assert np.abs(points[:, 2]).max() < 0.01
        assert np.abs(points[:, :2]).max() <= 2.0 + 1e-3
        # back through the projector to the texel's pixel
        local = (points - m[:3, 3]) @ (m[:3, :3] / np.linalg.norm(m[:3, :3], axis=0))
        back = model.uv_to_pixel(model.directions_to_uv(local))
        assert np.abs(back - pixels[hit]).max() < 1.0


def test_sl_unwritable_path_one_line_nothing_left(tmp_path):
    from lapig.lapig_core.multi.mpcdi_export import write_rig_mpcdi_sl
    from lapig.lapig_core.optics.projector_model import ProjectorModel

    model = ProjectorModel(width=16, height=12)
    points = [np.zeros((3, 3, 3), np.float32)]
    blocker = tmp_path / "a_file"
    blocker.write_text("x")
    target = blocker / "rig.mpcdi"  # its folder is a file: cannot be written
    with pytest.raises((OSError, ValueError)) as err:
        write_rig_mpcdi_sl(target, ["P"], [model], [np.eye(4)], points, [np.ones((12, 16))])
    assert "\n" not in str(err.value)
    assert blocker.read_text() == "x" and list(tmp_path.iterdir()) == [blocker]


def test_the_scene_store_gathers_a_lapig_projectors_pose_and_surface_points(small_setup):
    """BlenderSceneStore.sl_geometry on the demo panel's rig: the LAPIG projector's own world matrix and
    model, each texel's point on the target (< 1 cm from its mesh) and back through the lens to its pixel."""
    from mathutils import Vector
    from mathutils.bvhtree import BVHTree

    from lapig.lapig_addon.blender import scene_state
    from lapig.lapig_addon.blender.scene_store import BlenderSceneStore
    from lapig.lapig_core.multi.mpcdi_export import sl_texel_pixels

    scene, projector, camera, target = small_setup
    geometry = BlenderSceneStore(scene).sl_geometry(step=16)
    model = geometry["models"][0]
    assert (model.width, model.height) == (160, 120)
    assert model == scene_state.projector_model(projector)
    m = np.array(projector.matrix_world)
    assert np.allclose(geometry["matrices"][0], m, atol=1e-6)
    points, pixels = geometry["points"][0], sl_texel_pixels(model, 16)
    hit = np.isfinite(points).all(axis=-1)
    assert hit.sum() > 0.3 * hit.size, "the projector should light the panel"
    depsgraph = bpy.context.evaluated_depsgraph_get()
    bvh = BVHTree.FromObject(target, depsgraph)
    inv = np.linalg.inv(np.array(target.matrix_world))
    scale = np.linalg.norm(np.array(target.matrix_world)[:3, :3], axis=0).max()
    for p in points[hit].astype(np.float64):
        local = inv[:3, :3] @ p + inv[:3, 3]
        nearest, _, _, dist = bvh.find_nearest(Vector(local))
        assert nearest is not None and dist * scale < 0.01
    rot = m[:3, :3] / np.linalg.norm(m[:3, :3], axis=0)
    back = model.uv_to_pixel(model.directions_to_uv((points[hit] - m[:3, 3]) @ rot))
    assert np.abs(back - pixels[hit]).max() < 1.0


def test_export_takes_a_profile_2d_by_default_and_refuses_another():
    from lapig.lapig_addon.cli.main import _parser

    parser = _parser()
    assert parser.parse_args(["export", "--out", "x.png", "--mpcdi", "r.mpcdi"]).profile == "2d"
    assert parser.parse_args(["export", "--out", "x.png", "--mpcdi", "r.mpcdi", "--profile", "sl"]).profile == "sl"
    with pytest.raises(SystemExit):
        parser.parse_args(["export", "--out", "x.png", "--profile", "3d"])

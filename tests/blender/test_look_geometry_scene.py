"""The object as the projector sees it, ray cast in Blender for the looks of the world (issue 50): the demo's corner
(two walls at 90 degrees opening towards the rig) has its crease as a crevice, walls that face no way up, and water
running down them; the flat panel has no crevice. No render: ray casts only."""
import numpy as np
import pytest

bpy = pytest.importorskip("bpy")

pytestmark = [pytest.mark.blender, pytest.mark.torch]  # the looks of the world (lgst) load torch


def _rigged(shape, tmp_path):
    from lapig.lapig_addon.blender import rig
    from lapig.lapig_addon.cli import headless

    scene, projector, camera, target = headless.build_demo_setup(shape, "sakura", folder=str(tmp_path),
                                                                 camera_resolution=(160, 120))
    rig.add_rig(bpy.context, target, projector, camera)
    return scene


@pytest.mark.parametrize("shape", ["corner", "panel"])
def test_the_projector_sees_the_objects_crevices_tops_and_downhill(lapig_registered, tmp_path, shape):
    from lapig.lapig_addon.blender.scene_store import BlenderSceneStore

    scene = _rigged(shape, tmp_path)
    g = BlenderSceneStore(scene).look_geometry(64, 48)
    assert g is not None and g.source == "scene" and g.shape == (48, 64)
    on = g.valid
    assert on.mean() > 0.3
    assert np.abs(g.up[on]).mean() < 0.3  # walls: neither tops nor undersides
    assert np.median(g.downhill[on][:, 1]) > 0.8  # water runs down the image
    assert 0.5 < float(np.nanmedian(g.depth[on])) < 20
    # the demo's meshes have UV maps: the look lies on them in metres (the frame about as wide as the metres across)
    assert g.mapping == "uv" and 0.5 < np.ptp(g.surface_u[on]) / g.metres_across < 1.5
    seen = BlenderSceneStore(scene).camera_look_geometry(64)  # a rig of several: from the camera
    assert seen is not None and seen.shape == (48, 64) and seen.valid.mean() > 0.3
    if shape == "corner":  # the crease between the walls holds the crevice
        column = np.argmax((g.cavity * on).sum(0))
        assert g.cavity[on].max() > 0.5 and abs(column - 32) < 12, (column, g.cavity.max())
        assert (g.cavity[:, column] * on[:, column]).mean() > 3 * (g.cavity[on]).mean() / 2
    else:
        assert (g.cavity[on] > 0.5).mean() < 0.02

import pytest

bpy = pytest.importorskip("bpy")


@pytest.fixture(scope="session")
def lapig_registered():
    from lapig.lapig_addon.blender import addon

    if not addon.is_registered():
        addon.register()
    yield
    addon.unregister()


@pytest.fixture
def small_setup(lapig_registered, tmp_path):
    """A demo panel with a small projector and camera, so a whole capture takes a few seconds."""
    from lapig.lapig_addon.cli import headless
    from lapig.lapig_addon.blender import rig

    scene, projector, camera, target = headless.build_demo_setup("panel", "sakura", folder=str(tmp_path),
                                                                 camera_resolution=(160, 120))
    projector.lapig_projector.resolution_x = 160
    projector.lapig_projector.resolution_y = 120
    rig.add_rig(bpy.context, target, projector, camera)
    return scene, projector, camera, target

"""Scenes the Cycles tests share (imported by conftest.py and the module-scoped project fixtures)."""

def small_rig(folder, projector_size=(160, 120)):
    """A demo panel with a small projector and a 160x120 camera, rigged, so a whole capture takes a few
    seconds: (scene, projector, camera, target). The module-scoped project fixtures build on it too."""
    import bpy

    from lapig.lapig_addon.blender import rig
    from lapig.lapig_addon.cli import headless

    scene, projector, camera, target = headless.build_demo_setup("panel", "sakura", folder=str(folder),
                                                                 camera_resolution=(160, 120))
    projector.lapig_projector.resolution_x, projector.lapig_projector.resolution_y = projector_size
    rig.add_rig(bpy.context, target, projector, camera)
    return scene, projector, camera, target

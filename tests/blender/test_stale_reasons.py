"""The reason the panel gives when a capture no longer fits the rig, read from a real scene."""
import pytest

bpy = pytest.importorskip("bpy")
pytestmark = pytest.mark.blender


def test_a_projector_resolution_changed_after_the_capture_is_named(small_setup, tmp_path):
    from lapig.lapig_addon.blender import scene_state
    from lapig.lapig_addon.services.panel import panel_state

    scene, projector, _, _ = small_setup
    state = scene_state.read(scene)
    scene_state.record_capture(scene, str(tmp_path), state.rig.fingerprint, state.rig.transport)
    assert panel_state.capture_status(scene_state.read(scene)).state == "DONE"
    projector.lapig_projector.resolution_x, projector.lapig_projector.resolution_y = 320, 180
    after = scene_state.read(scene)
    assert panel_state.capture_status(after).text == "Captured for a 160x120 projector; it is now 320x180"
    assert panel_state.capture_blocker(after) == "The projector's resolution changed: capture again"
    scene_state.record_capture(scene, str(tmp_path), "")  # imported, tied to no rig: no size to compare
    assert scene_state.read(scene).capture_projector_size is None

"""Show on Projector on a real rig of two projectors, through the operator: every projector's window opens at once
(off Blender's main thread), each on its own display showing its own image of the result (result.json's
projectors[k].image), presented together; the panel says so, and the button again closes both. Two projectors on
one display are refused in one line and open nothing."""
import threading

import bpy
import numpy as np
import pytest

from test_multi_projector import statue  # noqa: F401 (the fixture)

pytestmark = [pytest.mark.blender]
SIZE = (64, 48)  # the statue's projectors


@pytest.fixture
def simulated_windows(monkeypatch):
    from lapig.lapig_addon.rigs import live_output, real_rig
    from lapig.lapig_core.rig.frame_lock import SimulatedWindow

    opened = {}

    def window(display):
        opened[display] = SimulatedWindow(SIZE)
        opened[display].thread = threading.current_thread()
        return opened[display]

    monkeypatch.setattr(real_rig, "_projector_window", window)
    yield opened
    live_output.close_live()


def _two_displays(scene, second="2"):
    assert bpy.ops.lapig.add_projector() == {"FINISHED"}
    s = scene.lapig
    s.rig_kind, s.real.display, s.real.camera = "REAL", "1", "0"
    s.extra_projectors[0].display = second


def _multi_result(scene, folder):
    from lapig.lapig_addon.blender import scene_state
    from lapig.lapig_core.export.result_files import write_result

    w, h = SIZE
    images = {"projector_1": np.full((h, w, 3), 0.25, np.float32), "projector_2": np.full((h, w, 3), 0.75, np.float32)}
    write_result(folder, images, {"multi": {"count": 2},
                                  "projectors": [{"name": "A", "image": "projector_1.png", "size": [w, h]},
                                                 {"name": "B", "image": "projector_2.png", "size": [w, h]}]})
    scene_state.record_result(scene, str(folder), "two projectors")


def test_show_on_projector_opens_every_projectors_window_with_its_own_image(statue, simulated_windows, tmp_path):
    from lapig.lapig_addon.rigs import live_output

    scene = statue[0]
    _two_displays(scene)
    _multi_result(scene, tmp_path / "result")
    assert bpy.ops.lapig.show_on_projector() == {"FINISHED"}
    assert sorted(simulated_windows) == ["1", "2"]
    assert all(w.thread is not threading.main_thread() for w in simulated_windows.values())
    levels = [int(simulated_windows[d].shown[10, 10, 0]) for d in ("1", "2")]
    assert abs(levels[0] - 64) <= 1 and abs(levels[1] - 191) <= 1, levels  # each its own image
    sink = live_output.open_sinks()[0]
    assert isinstance(sink, live_output.LockedWindowsSink) and sink.skew_frames <= 1.0
    assert live_output.status_lines()[0][0].startswith("Showing 2 projectors")
    assert bpy.ops.lapig.show_on_projector() == {"FINISHED"}  # again: both closed
    assert not live_output.open_sinks() and not any(w.is_open for w in simulated_windows.values())


def test_two_projectors_on_one_display_open_no_window(statue, simulated_windows):
    _two_displays(statue[0], second="1")
    with pytest.raises(RuntimeError, match="are both on display '1': give each its own display"):
        bpy.ops.lapig.show_on_projector()
    assert simulated_windows == {}


def test_a_real_rig_of_several_is_another_rig_when_a_projectors_display_changes(statue):
    from lapig.lapig_addon.blender import scene_state
    from lapig.lapig_addon.blender.scene_store import device_factory

    scene = statue[0]
    _two_displays(scene)
    before = scene_state.read_rig(scene).fingerprint
    assert device_factory(scene).rig_identity().key() == before  # what the capture records is what staleness reads
    scene.lapig.extra_projectors[0].display = "3"
    assert scene_state.read_rig(scene).fingerprint != before

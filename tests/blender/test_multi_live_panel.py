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
    from lapig.tools.fakes.simulated_window import SimulatedWindow

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


def test_play_crossfade_and_export_crossfade_take_every_projector(statue, simulated_windows, tmp_path):
    """Play Crossfade on the windows of two: each projector's crossfade (from black: the result has no images
    without PSA) on its own window, every frame on both; Export Crossfade: a folder per projector."""
    import os

    scene = statue[0]
    _two_displays(scene)
    _multi_result(scene, tmp_path / "result")
    assert bpy.ops.lapig.show_on_projector() == {"FINISHED"}
    before = [simulated_windows[d].frames for d in ("1", "2")]
    scene.lapig.crossfade_frames, scene.lapig.crossfade_fps = 4, 120.0
    assert bpy.ops.lapig.play_crossfade() == {"FINISHED"}
    assert [simulated_windows[d].frames - b for d, b in zip(("1", "2"), before)] == [4, 4]
    levels = [int(simulated_windows[d].shown[10, 10, 0]) for d in ("1", "2")]
    assert abs(levels[0] - 64) <= 1 and abs(levels[1] - 191) <= 1, levels  # each ends on its own image
    assert bpy.ops.lapig.export_crossfade(directory=str(tmp_path / "fade")) == {"FINISHED"}
    assert sorted(os.listdir(tmp_path / "fade")) == ["projector_1", "projector_2"]
    assert len([f for f in os.listdir(tmp_path / "fade" / "projector_2") if f.endswith(".png")]) == 4


def test_play_show_and_show_timeline_play_each_projectors_frames_on_its_window(statue, simulated_windows, tmp_path,
                                                                               monkeypatch, capsys):
    """Play Show (the panel) and show --timeline (the command) on a rig of two: every frame of the show on both
    windows, each its own projector's frames (the stale-look checks, a capture's, are stood in for here)."""
    import json

    from lapig.lapig_addon.blender import scene_state, show_timeline
    from lapig.lapig_addon.cli.main import main
    from lapig.lapig_addon.rigs import live_output
    from lapig.lapig_core.export.result_files import write_result
    from lapig.lapig_core.rig import projector_window

    scene = statue[0]
    _two_displays(scene)
    w, h = SIZE
    entries = [{"name": "A", "image": "projector_1.png", "size": [w, h]},
               {"name": "B", "image": "projector_2.png", "size": [w, h]}]
    for i, levels in enumerate(((0.25, 0.75), (0.75, 0.25))):
        folder = write_result(tmp_path / f"look{i}", {f"projector_{k + 1}": np.full((h, w, 3), level, np.float32)
                                                      for k, level in enumerate(levels)},
                              {"multi": {"count": 2}, "projectors": entries})
        scene_state.add_show_look(scene, str(folder), name=f"Look {i}", hold_s=0.1, transition_s=0.0)
    scene.render.fps, scene.render.fps_base = 20, 1.0
    monkeypatch.setattr(show_timeline, "blocker", lambda scene: "")
    assert bpy.ops.lapig.show_on_projector() == {"FINISHED"}
    before = {d: simulated_windows[d].frames for d in ("1", "2")}
    assert bpy.ops.lapig.play_show() == {"FINISHED"}
    assert {d: simulated_windows[d].frames - before[d] for d in ("1", "2")} == {"1": 4, "2": 4}
    assert [int(simulated_windows[d].shown[5, 5, 0]) for d in ("1", "2")] == [191, 64]  # look 1: each its own
    live_output.close_live()
    bpy.ops.wm.save_as_mainfile(filepath=str(tmp_path / "two.blend"))
    opened = []

    def window(display, **kw):
        from lapig.tools.fakes.simulated_window import SimulatedWindow

        opened.append(SimulatedWindow(SIZE))
        return opened[-1]

    monkeypatch.setattr(projector_window, "ProjectorWindow", window)
    capsys.readouterr()
    assert main(["show", "--timeline", "--blend", bpy.data.filepath, "--display", "1,2"]) == 0
    printed = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
    assert printed["show"]["frames"] == 4 and "max_skew_frames" in printed["show"] and len(printed["displays"]) == 2
    assert [win.frames for win in opened] == [4, 4]  # the show's four frames on both windows
    assert [int(win.shown[5, 5, 0]) for win in opened] == [191, 64]
    capsys.readouterr()
    assert main(["show", "--timeline", "--blend", bpy.data.filepath, "--display", "1"]) != 0  # one display for two
    said = capsys.readouterr()
    assert "the rig has 2 projectors: give --display one display each, e.g. --display 1,2" in said.out + said.err
    assert len(opened) == 2  # no window opened

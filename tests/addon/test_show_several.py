"""Play Show on a rig of several projectors (issues 36 and 38), with bpy blocked: each projector's window shows
its own frame of the show, every frame presented on all the windows together, late frames counted as for one."""
import importlib

import numpy as np
import pytest

from lapig.lapig_core.optics.projector_model import ProjectorModel
from lapig.lapig_core.rig.frame_lock import LockedWindows
from lapig.tools.fakes.simulated_window import SimulatedWindow
from window_fakes import Recording

ADDON = "lapig.lapig_addon"
SIZES = [(64, 48), (80, 60)]  # projectors of different sizes: a swap of frames would not fit
LEVELS = [(0.2, 0.7), (0.9, 0.4)]  # look i's level on projector k: LEVELS[i][k]


def _module(name):
    return importlib.import_module(f"{ADDON}.{name}")


def _multi_result(folder, levels):
    from lapig.lapig_core.export.result_files import write_result

    images = {f"projector_{k + 1}": np.full((h, w, 3), level, np.float32)
              for k, ((w, h), level) in enumerate(zip(SIZES, levels))}
    entries = [{"image": f"projector_{k + 1}.png", "size": list(size)} for k, size in enumerate(SIZES)]
    return str(write_result(folder, images, {"multi": {"count": 2}, "projectors": entries, "prompt": "p"}))


@pytest.fixture
def show(tmp_path):
    show_plan, show_source = _module("services.show.show_plan"), _module("services.show.show_source")
    folders = [_multi_result(tmp_path / f"look{i}", levels) for i, levels in enumerate(LEVELS)]
    plan = show_plan.ShowPlan(looks=(show_plan.ShowLook(result_dir=folders[0], hold_s=0.2, transition_s=0.2),
                                     show_plan.ShowLook(result_dir=folders[1], hold_s=0.2)), fps=50.0)
    models = tuple(ProjectorModel(width=w, height=h, gamma=2.2) for w, h in SIZES)
    return show_source.ShowSource(plan, projectors=models, bit_depth=8, use_producer=False)


def test_play_show_plays_each_projectors_frames_on_its_own_window_together(show):
    live = _module("rigs.live_output")
    windows = [Recording(size) for size in SIZES]
    sink = live.make_live(live.LockedWindowsSink(LockedWindows(windows), fps=50.0))
    try:
        played = live.ShowPlayJob(sink, show).run_to_completion()
        assert played["frames"] == 30 and [w.frames for w in windows] == [30, 30]  # every frame on both, together
        assert set(played) == {"frames", "seconds", "late_frames", "late_frame_pct", "max_skew_frames"}
        assert played["late_frame_pct"] == pytest.approx(100 * played["late_frames"] / 30, abs=1e-3)
        assert played["seconds"] >= 29 / 50 - 0.01  # at the show's rate
        assert 0.0 <= played["max_skew_frames"] <= 1.0
        # each window its own projector's images: look 0's level first, look 1's last, a dissolve between
        for k, window in enumerate(windows):
            first, last = LEVELS[0][k] * 255, LEVELS[1][k] * 255
            assert window.reds[0] == pytest.approx(first, abs=1.5) and window.reds[-1] == pytest.approx(last, abs=1.5)
            middle = window.reds[15]
            assert min(first, last) + 5 < middle < max(first, last) - 5
        assert [w.shown.shape[:2] for w in windows] == [(48, 64), (60, 80)]
        assert [f.shape[:2] for f in sink.frames] == [(48, 64), (60, 80)]  # the sink keeps the show's last frames
    finally:
        live.close_live()


def test_a_late_frame_of_several_is_counted(show):
    live = _module("rigs.live_output")
    windows = [SimulatedWindow(SIZES[0], present_s=0.05), SimulatedWindow(SIZES[1])]  # one slow window: 2.5 periods
    sink = live.LockedWindowsSink(LockedWindows(windows), fps=50.0)
    played = live.ShowPlayJob(sink, show).run_to_completion()
    assert played["frames"] == 30 and played["late_frames"] >= 20 and played["late_frame_pct"] > 60


def test_play_show_of_several_refuses_windows_that_do_not_match_the_rig(show):
    live = _module("rigs.live_output")
    one = live.LockedWindowsSink(LockedWindows([SimulatedWindow(SIZES[0])]))
    with pytest.raises(ValueError, match=r"the rig has 2 projectors but 1 window\(s\) are open"):
        live.ShowPlayJob(one, show).check()
    swapped = live.LockedWindowsSink(LockedWindows([SimulatedWindow(SIZES[1]), SimulatedWindow(SIZES[0])]))
    with pytest.raises(ValueError, match="projector 1: the look is 64x48 but the projector's display is 80x60"):
        live.ShowPlayJob(swapped, show).check()

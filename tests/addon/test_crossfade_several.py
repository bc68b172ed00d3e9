"""Crossfades of a result of several projectors (issues 36 and 38), with bpy blocked: Export Crossfade writes a
folder per projector, each projector's crossfade between its own two images in its own gamma; Play Crossfade plays
them on the windows of several, every frame presented together; the mismatches are refused in one line."""
import importlib
import json
import os

import numpy as np
import pytest

from lapig.lapig_core.common.imageio import read_image
from lapig.lapig_core.optics.projector_model import ProjectorModel
from lapig.lapig_core.rig.frame_lock import LockedWindows
from lapig.tools.fakes.simulated_window import SimulatedWindow
from window_fakes import Recording

ADDON = "lapig.lapig_addon"
SIZES = [(64, 48), (80, 60)]
GAMMAS = [2.2, 1.0]  # projector 2 mixes its values as they are: its midpoint is their mean
START, END = [0.2, 0.9], [0.8, 0.3]  # each projector's level without PSA and with it


def _module(name):
    return importlib.import_module(f"{ADDON}.{name}")


def _multi_result(folder, nopsa=True):
    from lapig.lapig_core.export.result_files import write_result

    images = {}
    for k, (w, h) in enumerate(SIZES):
        images[f"projector_{k + 1}"] = np.full((h, w, 3), END[k], np.float32)
        if nopsa:
            images[f"projector_{k + 1}_nopsa"] = np.full((h, w, 3), START[k], np.float32)
    if nopsa:
        images["look_nopsa"] = np.full((8, 8, 3), 0.5, np.float32)
    entries = [{"image": f"projector_{k + 1}.png", "size": list(size), "name": name}
               for k, (size, name) in enumerate(zip(SIZES, ("Left", "Right")))]
    return str(write_result(folder, images, {"multi": {"count": 2}, "projectors": entries, "prompt": "two"}))


class Store:
    """The scene of a rig of two projectors of different sizes and gammas."""

    def __init__(self, models=None):
        self.models = models if models is not None else tuple(
            ProjectorModel(width=w, height=h, gamma=g) for (w, h), g in zip(SIZES, GAMMAS))

    def read(self):
        s = _module("services.state")
        rig = s.Rig(projector="Left", camera="Camera", target="Bust", scene="Scene", fingerprint="rig2",
                    projector_size=SIZES[0], projectors=("Left", "Right"), projector_sizes=tuple(SIZES))
        return s.SceneState(rig=rig)

    def projector_model(self):
        return self.models[0]

    def projector_models(self):
        return self.models

    def rig_metadata(self):
        return {"surface_object": "Bust"}

    def software(self):
        return {"software_host": "tests"}


def _settings(frames=5, bit_depth=8):
    return _module("services.state").ExportSettings(path="", bit_depth=bit_depth, crossfade_frames=frames)


def _mid(k):
    g = GAMMAS[k]
    return ((START[k] ** g + END[k] ** g) / 2) ** (1 / g) * 255


def test_export_crossfade_of_several_writes_each_projectors_crossfade_in_its_own_gamma(tmp_path):
    export_result = _module("services.export.export_result")
    folder = _multi_result(tmp_path / "result")
    out = tmp_path / "fades"
    heard = []
    paths = export_result.export_crossfade(Store(), str(out), _settings(), folder,
                                           on_progress=lambda f, m: heard.append((f, m)))
    assert len(paths) == 10
    assert sorted(os.listdir(out)) == ["projector_1", "projector_2"]
    for k, (w, h) in enumerate(SIZES):
        own = sorted(p for p in os.listdir(out / f"projector_{k + 1}") if p.endswith(".png"))
        assert own == [f"crossfade_{i:04d}.png" for i in range(1, 6)]
        frames = [read_image(str(out / f"projector_{k + 1}" / name)) for name in own]
        assert frames[0].shape[:2] == (h, w)  # its native size
        levels = [float(f[..., 0].mean()) * (255 if f.dtype != np.uint8 else 1) for f in frames]
        assert levels[0] == pytest.approx(START[k] * 255, abs=1.0) and levels[-1] == pytest.approx(END[k] * 255,
                                                                                                      abs=1.0)
        assert levels[2] == pytest.approx(_mid(k), abs=1.0)  # the midpoint mixed in this projector's gamma
        sidecar = json.loads((out / f"projector_{k + 1}" / "crossfade.json").read_text())
        assert sidecar["projector"] == {"index": k + 1, "count": 2, "name": ("Left", "Right")[k],
                                       "resolution": [w, h], "gamma": GAMMAS[k]}
    shared = ((START[1] ** 2.2 + END[1] ** 2.2) / 2) ** (1 / 2.2) * 255
    assert shared - _mid(1) > 5  # projector 1's gamma on projector 2 would miss its midpoint
    assert heard and heard[-1][0] == pytest.approx(1.0, abs=0.05) and "projector 2" in heard[-1][1]


def test_a_result_of_several_without_psa_images_fades_from_black(tmp_path):
    export_result = _module("services.export.export_result")
    folder = _multi_result(tmp_path / "result", nopsa=False)
    paths = export_result.export_crossfade(Store(), str(tmp_path / "fades"), _settings(frames=3), folder)
    first = read_image(paths[0])
    assert len(paths) == 6 and float(np.asarray(first).max()) == 0.0


def test_export_crossfade_of_several_refuses_another_rig_and_leaves_no_folder(tmp_path):
    export_result = _module("services.export.export_result")
    folder = _multi_result(tmp_path / "result")
    out = tmp_path / "fades"
    out.mkdir()
    with pytest.raises(ValueError, match="the result was made for 2 projectors; the rig has 1: generate again"):
        export_result.export_crossfade(Store(models=(ProjectorModel(width=64, height=48),)), str(out), _settings(),
                                       folder)
    assert os.listdir(out) == []

    class Failing(Store):  # projector 2's crossfade fails: projector 1's folder goes too
        def projector_models(self):
            return (self.models[0], ProjectorModel(width=80, height=60, gamma=float("nan")))

    with pytest.raises(Exception, match="gamma"):
        export_result.export_crossfade(Failing(), str(out), _settings(), folder)
    assert os.listdir(out) == []


def test_play_crossfade_of_several_plays_each_projectors_crossfade_on_its_window_together(tmp_path):
    live = _module("rigs.live_output")
    folder = _multi_result(tmp_path / "result")
    windows = [Recording(size) for size in SIZES]
    sink = live.LockedWindowsSink(LockedWindows(windows), fps=100.0)
    played = live.CrossfadeJob(sink, Store(), folder, frames=5, fps=100.0).run_to_completion()
    assert played["frames"] == 5 and [w.frames for w in windows] == [5, 5]
    assert set(played) == {"frames", "seconds", "late_frames", "max_skew_frames"}
    assert 0.0 <= played["max_skew_frames"] <= 1.0
    for k, window in enumerate(windows):
        assert window.reds[0] == pytest.approx(START[k] * 255, abs=1.0)
        assert window.reds[2] == pytest.approx(_mid(k), abs=1.0)
        assert window.reds[-1] == pytest.approx(END[k] * 255, abs=1.0)
    assert [w.shown.shape[:2] for w in windows] == [(48, 64), (60, 80)]


def test_play_crossfade_refuses_windows_that_do_not_match_the_result(tmp_path):
    from lapig.lapig_core.export.result_files import write_result
    from lapig.lapig_core.rig.simulated import SimulatedScreen

    live = _module("rigs.live_output")
    several = _multi_result(tmp_path / "result")
    one = str(write_result(tmp_path / "one", {"projector": np.full((48, 64, 3), 0.5, np.float32)}, {"prompt": "x"}))
    single = live.ProjectorWindowSink(SimulatedScreen(SIZES[0]))
    with pytest.raises(ValueError, match="the result has several projectors but one window is open"):
        live.CrossfadeJob(single, Store(), several, frames=5, fps=30).check()
    locked = live.LockedWindowsSink(LockedWindows([SimulatedWindow(s) for s in SIZES]))
    with pytest.raises(ValueError, match="the result is of one projector"):
        live.CrossfadeJob(locked, Store(), one, frames=5, fps=30).check()
    swapped = live.LockedWindowsSink(LockedWindows([SimulatedWindow(s) for s in SIZES[::-1]]))
    with pytest.raises(ValueError, match="projector 1: the look is 64x48 but the projector's display is 80x60"):
        live.CrossfadeJob(swapped, Store(), several, frames=5, fps=30).check()
    three = live.LockedWindowsSink(LockedWindows([SimulatedWindow(s) for s in SIZES + [SIZES[0]]]))
    with pytest.raises(ValueError, match=r"the result has 2 projectors but 3 window\(s\) are open"):
        live.CrossfadeJob(three, Store(), several, frames=5, fps=30).check()

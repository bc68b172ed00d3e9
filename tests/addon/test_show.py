"""The show through the add-on (issue 38), with bpy blocked: the list's times and the timeline's markers, stale
looks, the frames of holds and dissolves, Bake Show and Export Show written whole (a cancel leaves nothing), their
one-line refusals, and Play Show on a simulated window counting its late frames."""
import importlib
import json
import os
import shutil
import threading
import time

import numpy as np
import pytest

from lapig.lapig_core.optics.projector_model import ProjectorModel

ADDON = "lapig.lapig_addon"
SIZE = (64, 48)
COLOURS = [(0.9, 0.1, 0.1), (0.1, 0.8, 0.2), (0.1, 0.2, 0.9)]


def _module(name):
    return importlib.import_module(f"{ADDON}.{name}")


def _plan(looks, fps=10.0, **kw):
    show_plan = _module("services.show.show_plan")
    return show_plan.ShowPlan(looks=tuple(show_plan.ShowLook(**look) for look in looks), fps=fps, **kw)


@pytest.fixture
def results(tmp_path):
    """Three results of one 64x48 projector, each one flat colour, made from the capture 'cap' of fingerprint 'fp'."""
    from lapig.lapig_core.export.result_files import write_result

    capture = tmp_path / "data" / "panel" / "setups" / "panel"
    capture.mkdir(parents=True)
    (capture / "setup.json").write_text("{}")
    old = time.time() - 100
    os.utime(capture / "setup.json", (old, old))
    folders = []
    for i, colour in enumerate(COLOURS):
        image = np.broadcast_to(np.float32(colour), (SIZE[1], SIZE[0], 3)).copy()
        folders.append(str(write_result(tmp_path / "data" / "results" / f"look{i}", {"projector": image},
                                        {"prompt": f"look {i}", "backend": "styletransfer", "seed": i,
                                         "capture": str(capture), "fingerprint": "fp"})))
    return folders, str(capture)


def _source(plan, bit_depth=8, projectors=1):
    show_source = _module("services.show.show_source")
    model = ProjectorModel(width=SIZE[0], height=SIZE[1], gamma=2.2)
    return show_source.ShowSource(plan, projectors=(model,) * projectors, bit_depth=bit_depth, use_producer=False)


# ---------------------------------------------------------------------------- the list and the timeline

def test_the_segments_tile_the_show_and_the_markers_name_looks_and_transitions():
    plan = _plan([dict(result_dir="/r/a", name="Glass", hold_s=1.0, transition="dissolve", transition_s=0.5),
                  dict(result_dir="/r/b", name="Ink", hold_s=2.0, transition="morph", transition_s=1.0),
                  dict(result_dir="/r/c", name="", hold_s=1.0, transition_s=3.0)],  # the last transition: not played
                 fps=10.0, frame_start=101)
    assert plan.problem() == ""
    assert [(s.kind, s.a, s.b, s.first, s.frames) for s in plan.segments()] == [
        ("hold", 0, 0, 0, 10), ("dissolve", 0, 1, 10, 5), ("hold", 1, 1, 15, 20), ("morph", 1, 2, 35, 10),
        ("hold", 2, 2, 45, 10)]
    assert plan.frame_count() == 55 and plan.frame_end() == 155 and plan.seconds() == 5.5
    assert plan.markers() == [(101, "Glass"), (111, "dissolve 0.5s to Ink"), (116, "Ink"),
                              (136, "morph 1s to c"), (146, "c")]
    mid = plan.segment_at(12)
    assert mid.kind == "dissolve" and mid.weight(12) == pytest.approx(0.5) and mid.weight(10) == pytest.approx(1 / 6)
    assert plan.segment_at(999).kind == "hold"  # past the end: the last look
    # the sidecar's show: looks, times, transitions, motions, the frame rate
    d = plan.to_dict()
    assert d["fps"] == 10.0 and d["frames"] == 55 and d["looks"][1]["transition"] == {"kind": "morph", "seconds": 1.0}
    assert d["looks"][0]["motion"]["kind"] == "none"
    assert plan.key() != _plan([dict(result_dir="/r/a", hold_s=1.5)]).key()
    long = _plan([dict(result_dir="/r/a", name="x" * 100, hold_s=1.0)])
    assert len(long.markers()[0][1]) == 63


@pytest.mark.parametrize("looks, fps, said", [
    ([], 30.0, "The show has no looks: add a result to it (Add Look)"),
    ([dict(result_dir="/r/a")], 0.0, "The show's frame rate is 0: set the scene's frame rate above 0"),
    ([dict(result_dir="/r/a", hold_s=-1.0)], 30.0, "Look 1 'a': hold and transition times must not be negative"),
    ([dict(result_dir="/r/a", hold_s=0.0)], 30.0, "The show lasts no frame: give its looks hold times"),
    ([dict(result_dir="", name="Gone")], 30.0, "Look 1 'Gone': its result folder is gone (choose the result again)"),
    ([dict(result_dir="/r/a", motion="spin")], 30.0, "Look 1 'a': unknown motion 'spin'"),
    ([dict(result_dir="/r/a", motion="pulse", motion_period_s=0.0)], 30.0, "its pulse needs a period above 0 s"),
])
def test_a_show_that_cannot_play_says_why_in_one_line(looks, fps, said):
    problem = _plan(looks, fps=fps).problem()
    assert said in problem and "\n" not in problem


def test_the_list_moves_and_removes_like_the_panel_buttons():
    show_plan = _module("services.show.show_plan")
    assert show_plan.moved(["a", "b", "c"], 2, -1) == (["a", "c", "b"], 1)
    assert show_plan.moved(["a", "b", "c"], 0, -1) == (["a", "b", "c"], 0)  # at the top: stays
    assert show_plan.moved(["a", "b", "c"], 2, +1) == (["a", "b", "c"], 2)
    assert show_plan.index_after_removal(2, 2) == 1 and show_plan.index_after_removal(0, 0) == 0
    plan = show_plan.with_look(_plan([dict(result_dir="/r/a")]), 0, hold_s=9.0)
    assert plan.looks[0].hold_s == 9.0


def test_a_new_look_is_named_after_its_prompt(results, tmp_path):
    show_plan = _module("services.show.show_plan")
    folders, _ = results
    assert show_plan.look_name(folders[1]) == "look 1"
    assert show_plan.look_name(str(tmp_path / "no_result")) == "no_result"
    from lapig.lapig_core.export.result_files import write_result

    long = write_result(tmp_path / "long", {}, {"prompt": "Render it in the style of a Van Gogh oil painting, at night"})
    assert show_plan.look_name(str(long)) == "Render it in the style of a Van Gogh oi~"


def test_a_look_is_stale_when_its_capture_is_not_the_scenes_or_older(results, state):
    show_plan = _module("services.show.show_plan")
    folders, capture = results
    plan = _plan([dict(result_dir=f, hold_s=1.0) for f in folders])
    assert show_plan.stale_looks(plan, capture, "fp") == []
    # made from another capture (another fingerprint, another folder)
    assert show_plan.stale_looks(plan, capture, "other")[0] == \
        "Look 1 'look0' was made from another capture than the scene's: generate it again"
    assert "was made from the capture" in show_plan.stale_looks(plan, "/elsewhere/x/setups/y", "fp")[0]
    # captured again after the looks were made
    os.utime(os.path.join(capture, "setup.json"))
    stale = show_plan.stale_looks(plan, capture, "fp")
    assert len(stale) == 3 and stale[0] == \
        "Look 1 'look0' is older than the scene's capture (captured again since): generate it again"
    gone = _plan([dict(result_dir=folders[0] + "_gone", name="Gone")])
    assert show_plan.stale_looks(gone, capture, "fp")[0].startswith("Look 1 'Gone': its result is gone")
    # the show's one blocker: the scene's capture first, then the looks
    rig = state.Rig(projector="P", camera="C", target="T", scene="S", fingerprint="fp")
    scene = state.SceneState(rig=rig, capture_dir=capture, capture_fingerprint="fp")
    assert show_plan.show_blocker(plan, scene).startswith("Look 1 'look0' is older")
    moved = state.SceneState(rig=state.Rig(projector="P", camera="C", target="T", scene="S", fingerprint="new"),
                             capture_dir=capture, capture_fingerprint="fp")
    assert show_plan.show_blocker(plan, moved) == \
        "The show's looks need the scene's capture: the rig or the object moved: capture again"
    assert show_plan.show_blocker(_plan([]), scene).startswith("The show has no looks")


# ---------------------------------------------------------------------------- frames

def test_holds_are_the_looks_exported_pixels_and_a_dissolve_mixes_in_linear_light(results):
    from lapig.lapig_core.export.result_files import read_output_image
    from lapig.lapig_core.optics.projector_model import quantised_frame

    show_source = _module("services.show.show_source")
    folders, _ = results
    plan = _plan([dict(result_dir=folders[0], hold_s=0.3, transition_s=0.4), dict(result_dir=folders[1], hold_s=0.3)])
    frames = list(show_source.frames(_source(plan, bit_depth=16)))
    assert [i for i, _ in frames] == list(range(10))
    a = quantised_frame(read_output_image(folders[0], "projector"), *SIZE, 16)
    b = quantised_frame(read_output_image(folders[1], "projector"), *SIZE, 16)
    np.testing.assert_array_equal(frames[0][1][0], a)  # what Export writes of look 1
    np.testing.assert_array_equal(frames[9][1][0], b)
    mid = frames[5][1][0].astype(np.float64) / 65535  # w = 3/5 (frames 3..6 are the dissolve: 1/5 .. 4/5)
    expected = ((a / 65535.0) ** 2.2 * 0.4 + (b / 65535.0) ** 2.2 * 0.6) ** (1 / 2.2)
    np.testing.assert_allclose(mid, expected, atol=2e-4)
    red = [float(f[0][..., 0].mean()) for _, f in frames]
    assert red[2] > red[4] > red[6] and red[7] == red[9]
    notes = show_source.fallback_notes(_source(_plan([dict(result_dir=folders[0], motion="drift")]), projectors=2))
    assert len(notes) == 1 and notes[0].startswith("motions stand still: ")  # no capture here (or no producer)
    assert show_source.fallback_notes(_source(plan)) == []  # holds and dissolves: nothing is missing


@pytest.mark.torch
def test_a_stored_dissolve_is_compensated_at_its_keys_on_the_scene_capture(tmp_path):
    """Holds stay the looks' exported pixels; the dissolve's keys are the targets' linear-light mix compensated
    by the capture's first look (the shipped device-check capture), the frames between them their crossfade."""
    import shutil

    from lapig.lapig_core.capture.dataset import load_capture_set, setup_dir_of
    from lapig.lapig_core.export.result_files import write_result
    from lapig.lapig_core.optics.projector_model import quantised_frame
    from lapig.lapig_core.photometric.first_look import fit_first_look
    from lapig.lapig_core.show.dissolve import StoredDissolve
    from lapig.lapig_core.show.frames import ShowSetup
    from lapig.tools.bench.device_fixture import FIXTURE

    show_source = _module("services.show.show_source")
    shutil.copytree(FIXTURE, tmp_path / "fixture")
    cs = load_capture_set(tmp_path / "fixture")
    fit_first_look(cs, setup_dir_of(cs))
    width, height = 160, 120
    rows = np.linspace(0.0, 1.0, height, dtype=np.float32)[:, None, None]
    looks, targets = [], []
    for i, colour in enumerate([(0.95, 0.9, 0.2), (0.1, 0.2, 0.95)]):  # bright looks: partly out of reach
        target = np.broadcast_to(np.float32(colour) * (0.5 + 0.5 * rows), (height, width, 3)).copy()
        targets.append(quantised_frame(target, width, height, 16).astype(np.float32) / 65535)
        projector = np.clip(target * 1.2, 0, 1)
        looks.append(str(write_result(tmp_path / "results" / f"look{i}", {"projector": projector, "target": target},
                                      {"prompt": f"look {i}"})))
    plan = _plan([dict(result_dir=looks[0], hold_s=0.2, transition_s=0.7), dict(result_dir=looks[1], hold_s=0.2)])
    model = ProjectorModel(width=width, height=height, gamma=2.2)
    source = show_source.ShowSource(plan, projectors=(model,), bit_depth=16, use_producer=False,
                                    capture_dir=str(setup_dir_of(cs)))
    frames = dict(show_source.frames(source))  # frames 0-1 look 0, 2-8 the dissolve (w = n/8), 9-10 look 1
    plain = dict(show_source.frames(show_source.ShowSource(plan, projectors=(model,), bit_depth=16,
                                                           use_producer=False, compensated_dissolves=False)))
    assert sorted(frames) == list(range(11))
    for i in (0, 1, 9, 10):
        np.testing.assert_array_equal(frames[i][0], plain[i][0])  # holds: the looks' own exported pixels
    dissolve = StoredDissolve(ShowSetup.from_capture(setup_dir_of(cs)), width, height)
    key = quantised_frame(dissolve.key(targets[0], targets[1], 0.5), width, height, 16)
    np.testing.assert_allclose(frames[5][0].astype(np.float64), key.astype(np.float64), atol=2)  # w = 4/8: a key
    assert np.abs(frames[5][0].astype(np.float64) - plain[5][0]).mean() > 100  # not the looks' crossfade
    assert frames[5][0].mean() > 1000  # lit, not black


def test_an_8_bit_dissolve_is_the_linear_light_mix_of_the_8_bit_looks(tmp_path):
    from lapig.lapig_core.export.result_files import write_result

    show_source = _module("services.show.show_source")
    rng = np.random.default_rng(4)
    folders = [str(write_result(tmp_path / f"r{i}", {"projector": rng.random((SIZE[1], SIZE[0], 3)).astype(np.float32)},
                                {"prompt": "noise"})) for i in range(2)]
    plan = _plan([dict(result_dir=folders[0], hold_s=0.1, transition_s=0.3), dict(result_dir=folders[1], hold_s=0.1)])
    frames = [f[0] for _, f in show_source.frames(_source(plan, bit_depth=8))]
    assert len(frames) == 5 and all(f.dtype == np.uint8 for f in frames)
    a, b = frames[0].astype(np.float64) / 255, frames[4].astype(np.float64) / 255
    for k, w in ((1, 0.25), (2, 0.5), (3, 0.75)):
        expected = np.round(255 * ((1 - w) * a ** 2.2 + w * b ** 2.2) ** (1 / 2.2))
        assert np.abs(frames[k] - expected).max() <= 1


def test_the_adapter_hands_the_plan_to_the_show_producer_where_it_is_here(results):
    show_source = _module("services.show.show_source")
    if not show_source.has_producer():
        pytest.skip("lapig_core.show is not merged in this build")
    folders, _ = results
    plan = _plan([dict(result_dir=folders[0], hold_s=1.0, transition="morph", transition_s=0.5),
                  dict(result_dir=folders[1], hold_s=1.0, motion="pulse", motion_amount=0.3, motion_period_s=2.0)])
    show = show_source.core_show_of(plan, show_source.read_summaries(plan))
    show.validate()
    from lapig.lapig_core.show.schedule import schedule_of

    assert schedule_of(show).total_frames == plan.frame_count()


# ---------------------------------------------------------------------------- bake and export

def test_bake_show_writes_a_png_sequence_per_projector_whole(results, tmp_path):
    from lapig.lapig_core.common.imageio import read_image

    show_jobs = _module("services.show.show_jobs")
    folders, _ = results
    plan = _plan([dict(result_dir=f, hold_s=0.1, transition_s=0.0) for f in folders])
    folder = tmp_path / "data" / "shows" / "show"
    out = show_jobs.BakeShowJob(_source(plan), str(folder)).run_to_completion()
    assert out["frames"] == 3 and out["key"] == plan.key()
    names = sorted(os.listdir(folder / "projector_1"))
    assert names == ["frame_0001.png", "frame_0002.png", "frame_0003.png"]
    means = [read_image(str(folder / "projector_1" / n)).reshape(-1, 3).mean(0) for n in names]
    assert [int(np.argmax(m)) for m in means] == [0, 1, 2]  # red, green, blue
    assert json.loads((folder / "show.json").read_text())["show"]["frames"] == 3
    assert sorted(os.listdir(folder.parent)) == ["show"]  # no scratch folder left


def _cancel_midway(job):
    job.poll_timeout = 0.01
    deadline = time.monotonic() + 30
    while job.step():
        if job.progress > 0.3:
            job.stop()
            break
        assert time.monotonic() < deadline
    return job


def test_a_cancelled_bake_or_export_leaves_nothing_and_the_previous_output_as_it_was(results, tmp_path):
    show_jobs = _module("services.show.show_jobs")
    folders, _ = results
    plan = _plan([dict(result_dir=f, hold_s=2.0, transition_s=1.0) for f in folders], fps=30.0)
    folder = tmp_path / "data" / "shows" / "show"
    job = _cancel_midway(show_jobs.BakeShowJob(_source(plan), str(folder)))
    assert job.state == "CANCELLED" and not folder.exists()
    assert os.listdir(folder.parent) == []
    folder.mkdir()
    (folder / "before.txt").write_text("kept")
    _cancel_midway(show_jobs.BakeShowJob(_source(plan), str(folder)))
    assert os.listdir(folder) == ["before.txt"]
    out = tmp_path / "export"
    job = _cancel_midway(show_jobs.ShowExportJob(_source(plan), str(out), "png"))
    assert job.state == "CANCELLED" and os.listdir(out) == []


def test_export_show_writes_each_projector_and_a_sidecar(results, tmp_path):
    show_jobs = _module("services.show.show_jobs")
    folders, _ = results
    plan = _plan([dict(result_dir=f, hold_s=0.2, transition_s=0.1) for f in folders[:2]])
    out = show_jobs.ShowExportJob(_source(plan, bit_depth=16), str(tmp_path / "export"), "png",
                                  metadata={"rig": "test"}).run_to_completion()
    assert out["frames"] == 5 and out["fps"] == 10.0
    assert sorted(os.listdir(tmp_path / "export")) == ["show", "show.json"]
    assert len([n for n in os.listdir(tmp_path / "export" / "show") if n.endswith(".png")]) == 5
    sidecar = json.loads((tmp_path / "export" / "show.json").read_text())
    assert sidecar["show"]["looks"][0]["hold_s"] == 0.2 and sidecar["codec"] == "png" and sidecar["bit_depth"] == 16
    assert sidecar["rig"] == "test" and sidecar["files"] == ["show"]


def test_export_show_refuses_bad_input_in_one_line_before_any_file(results, tmp_path, monkeypatch):
    show_jobs, show_source = _module("services.show.show_jobs"), _module("services.show.show_source")
    folders, _ = results
    good = _plan([dict(result_dir=folders[0], hold_s=0.5)])
    out = tmp_path / "export"

    def refused(job):
        assert job.run() == "FAILED"
        assert not out.exists()
        return str(job.error)

    monkeypatch.setenv("LAPIG_FFMPEG", str(tmp_path / "no_ffmpeg"))  # neither PyPI's PyAV nor this has HAP
    hap = refused(show_jobs.ShowExportJob(_source(good), str(out), "hap"))
    assert "hap" in hap.lower() and "\n" not in hap
    assert refused(show_jobs.ShowExportJob(_source(good), str(out), "mpeg1")).startswith("unknown codec 'mpeg1'")
    assert "frame rate is 0" in refused(show_jobs.ShowExportJob(_source(_plan([dict(result_dir=folders[0])], fps=0.0)),
                                                                str(out), "png"))
    assert "has no looks" in refused(show_jobs.ShowExportJob(_source(_plan([])), str(out), "png"))
    monkeypatch.setattr(show_source, "disk_free", lambda folder: 1000)
    small = refused(show_jobs.ShowExportJob(_source(good), str(out), "png"))
    assert small.startswith("the show needs about") and "free some space" in small


# ---------------------------------------------------------------------------- play

def test_play_show_plays_every_frame_at_its_rate_and_counts_late_ones(results):
    from lapig.lapig_core.rig.simulated import SimulatedScreen

    live = _module("rigs.live_output")
    folders, _ = results
    plan = _plan([dict(result_dir=folders[0], hold_s=0.2, transition_s=0.2), dict(result_dir=folders[1], hold_s=0.2)],
                 fps=50.0)
    screen = SimulatedScreen(SIZE)
    sink = live.open_live(1, window_factory=lambda display: screen)
    try:
        played = live.ShowPlayJob(sink, _source(plan)).run_to_completion()
        assert played["frames"] == 30 == len(screen.timeline)
        assert set(played) == {"frames", "seconds", "late_frames", "late_frame_pct"}
        assert played["late_frame_pct"] == pytest.approx(100 * played["late_frames"] / 30, abs=1e-3)
        assert played["seconds"] >= 29 / 50 - 0.01
        times = [t for t, _ in screen.timeline]
        assert times[-1] - times[0] >= 29 / 50 - 0.005  # at the show's rate, not as fast as made
        reds = [int(f[..., 0].mean()) for _, f in screen.timeline]
        assert reds[0] > reds[15] > reds[-1]
        small = live.open_live(1, window_factory=lambda display: SimulatedScreen((32, 24)))
        with pytest.raises(ValueError, match="the look is 64x48 but the projector's display is 32x24"):
            live.ShowPlayJob(small, _source(plan)).check()
    finally:
        live.close_live()


def test_a_late_frame_is_counted():
    live = _module("rigs.live_output")

    class Clock:
        now = 0.0

        def perf_counter(self):
            return self.now

        def sleep(self, s):
            self.now += s

    clock = Clock()

    class SlowWindow:
        size = SIZE
        shown = 0

        def show(self, pixels):  # the fourth frame takes 0.1 s to appear
            self.shown += 1
            clock.now += 0.1 if self.shown == 4 else 0.0
            return clock.now

    frames = (np.zeros((SIZE[1], SIZE[0], 3), np.uint8) for _ in range(10))
    played = live.late_share(live.play(SlowWindow(), frames, fps=25, clock=clock))
    assert played["late_frames"] == 2 and played["late_frame_pct"] == 20.0  # the fourth, and the fifth after it


def test_the_producer_is_asked_at_the_projectors_size_and_gamma_and_its_cancel_is_a_cancel(results, tmp_path,
                                                                                          monkeypatch):
    """lapig_core/show's producer behind the adapter (a stand-in here: the real one needs a capture): it is given
    the capture, the projector's native size and gamma; an InterruptedError it raises at a cancel cancels the job,
    and nothing is written."""
    import types

    show_source, show_jobs = _module("services.show.show_source"), _module("services.show.show_jobs")
    folders, capture = results
    asked, stop = {}, threading.Event()

    def show_frames(show, setup, *, size, cancel_event, on_progress, start, stop, settings):
        asked.update(size=size, gamma=settings.gamma, setup=setup, looks=len(show.looks))
        for i in range(start, stop):
            if i == 3:  # Esc, seen by the producer first, between two frames
                cancel_event.set()
                raise InterruptedError("cancelled")
            yield i, np.full((SIZE[1], SIZE[0], 3), 0.5, np.float32)

    fake = types.SimpleNamespace(show_frames=show_frames, FrameSettings=lambda gamma: types.SimpleNamespace(gamma=gamma),
                                 ShowSetup=types.SimpleNamespace(from_capture=lambda folder: f"setup of {folder}"))
    monkeypatch.setattr(show_source, "_core_frames", lambda: fake)
    monkeypatch.setattr(show_source, "has_producer", lambda: True)
    plan = _plan([dict(result_dir=folders[0], hold_s=0.5, transition="morph", transition_s=0.5),
                  dict(result_dir=folders[1], hold_s=0.5, motion="rise")])
    source = show_source.ShowSource(plan, projectors=(ProjectorModel(width=SIZE[0], height=SIZE[1], gamma=2.4),),
                                    capture_dir=capture)
    assert show_source.uses_producer(source) and show_source.fallback_notes(source) == []
    plain = _plan([dict(result_dir=folders[0], hold_s=0.5), dict(result_dir=folders[1], hold_s=0.5)])
    assert not show_source.uses_producer(show_source.ShowSource(plain, projectors=source.projectors))  # stored looks
    job = show_jobs.ShowExportJob(source, str(tmp_path / "export"), "png")
    assert job.run() == "CANCELLED"
    assert asked == {"size": SIZE, "gamma": 2.4, "setup": f"setup of {capture}", "looks": 2}
    assert os.listdir(tmp_path / "export") == []


@pytest.mark.parametrize("codec", ["lossless", "h264", "h264-444"])
def test_export_show_writes_a_frame_locked_video_with_the_show_in_its_sidecar(results, tmp_path, codec):
    """Through lapig_core/export/video (PyAV): the decoded video has the show's frames, size and rate; the lossless
    one holds the exact pixels (OpenCV decodes to BGR)."""
    import cv2

    show_jobs, show_source = _module("services.show.show_jobs"), _module("services.show.show_source")
    if show_source.codec_problem(codec):
        pytest.skip(show_source.codec_problem(codec))
    folders, _ = results
    plan = _plan([dict(result_dir=folders[0], hold_s=0.3, transition_s=0.2), dict(result_dir=folders[2], hold_s=0.3)])
    out = show_jobs.ShowExportJob(_source(plan), str(tmp_path / "export"), codec).run_to_completion()
    video = out["outputs"][0]["path"]
    assert os.path.isfile(video) and out["sidecar"] == str(tmp_path / "export" / "show.json")
    assert sorted(os.listdir(tmp_path / "export")) == sorted([os.path.basename(video), "show.json"])
    sidecar = json.loads((tmp_path / "export" / "show.json").read_text())
    assert sidecar["show"]["frames"] == 8 and sidecar["show"]["looks"][1]["hold_s"] == 0.3
    capture = cv2.VideoCapture(video)
    decoded = []
    while True:
        ok, frame = capture.read()
        if not ok:
            break
        decoded.append(frame[..., ::-1])
    assert len(decoded) == 8 and decoded[0].shape == (SIZE[1], SIZE[0], 3)
    assert capture.get(cv2.CAP_PROP_FPS) == pytest.approx(10.0)
    if codec != "lossless":  # OpenCV ignores the BT.709 tags: PyAV's decoder honours them
        import av

        with av.open(video) as container:
            decoded = [f.to_ndarray(format="rgb24") for f in container.decode(video=0)]
    expected = [f[0] for _, f in show_source.frames(_source(plan))]
    error = max(float(np.abs(d.astype(int) - e.astype(int)).mean()) for d, e in zip(decoded, expected))
    # 4:2:0 halves the colour resolution of the compensated frames' grain: a mean error of 2 levels in 255
    assert error == 0.0 if codec == "lossless" else error < (3.0 if codec == "h264" else 2.0)


@pytest.mark.skipif(shutil.which("ffprobe") is None, reason="the system ffprobe is not installed (apt-get install "
                                                            "ffmpeg; .ci/run installs it): the sound check cannot run")
def test_export_show_puts_the_scenes_sound_in_the_video_and_removes_its_temporary(results, tmp_path):
    import subprocess
    import wave

    show_jobs, show_source = _module("services.show.show_jobs"), _module("services.show.show_source")
    if show_source.codec_problem("h264"):
        pytest.skip(show_source.codec_problem("h264"))
    folders, _ = results
    sound_dir = tmp_path / "lapig_show_sound_x"
    sound_dir.mkdir()
    sound = sound_dir / "show_sound.wav"
    with wave.open(str(sound), "wb") as w:  # what Blender's mixdown writes: 48 kHz stereo 16-bit
        w.setnchannels(2), w.setsampwidth(2), w.setframerate(48000)
        w.writeframes(np.zeros(2 * 48000, "<i2").tobytes())
    plan = _plan([dict(result_dir=folders[0], hold_s=0.4), dict(result_dir=folders[2], hold_s=0.4)])
    job = show_jobs.ShowExportJob(_source(plan), str(tmp_path / "export"), "h264", sound=str(sound),
                                  sound_is_temporary=True)
    out = job.run_to_completion()
    for output in out["outputs"]:
        streams = subprocess.run(["ffprobe", "-v", "error", "-show_entries", "stream=codec_type,codec_name", "-of",
                                  "csv=p=0", output["path"]], capture_output=True, text=True, check=True).stdout
        assert sorted(streams.split()) == ["aac,audio", "h264,video"], output["path"]
    assert len(out["outputs"]) == 1 and not sound_dir.exists()  # the mixdown's folder removed after the work


def test_the_show_lists_every_video_codec_and_png():
    from lapig.lapig_core.export import codecs

    show_source = _module("services.show.show_source")
    assert show_source.CODECS == codecs.NAMES + ("png",)


def test_16_bit_show_frames_go_into_h264_at_8_bits_and_the_job_says_so(results, tmp_path):
    show_jobs, show_source = _module("services.show.show_jobs"), _module("services.show.show_source")
    if show_source.codec_problem("h264"):
        pytest.skip(show_source.codec_problem("h264"))
    folders, _ = results
    plan = _plan([dict(result_dir=folders[0], hold_s=0.3)])
    out = show_jobs.ShowExportJob(_source(plan, bit_depth=16), str(tmp_path / "export"), "h264").run_to_completion()
    assert "16-bit frames written at H.264's 8 bits" in out["notes"]
    side = json.loads((tmp_path / "export" / "show.json").read_text())
    assert side["video"]["bit_depth"] == 8 and side["video"]["pixel_format"] == "yuv420p"

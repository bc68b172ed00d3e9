# SPDX-License-Identifier: GPL-3.0-or-later
"""The frame producer on a small fake surface: holds once, morphs, moving looks without flicker, dissolves,
cancel, and a look's state on disk."""
import json
import threading

import numpy as np
import pytest

torch = pytest.importorskip("torch")  # the producer is torch's: the torch-free tier skips this file

from show_fakes import CountingCompensator, StripesBackend, fake_models, keyed_look

from lapig.lapig_core.export.projector_image import blend_linear_light
from lapig.lapig_core.lgst.base import BACKENDS, register_backend
from lapig.lapig_core.show.frames import FrameMaker, FrameSettings, ShowSetup, look_from_result, show_frames
from lapig.lapig_core.show.look_state import LOOK_STATE_FILE, load_look_state, save_look_state
from lapig.lapig_core.show.model import Look, Motion, Show, ShowError, Transition
from lapig.lapig_core.show.morph import morph_base


def _setup():
    models = fake_models()
    models.compensator = CountingCompensator(models.compensator)
    return ShowSetup(models, load_look=keyed_look)


def _two_looks(kind="morph", fps=10, hold=0.5, seconds=0.8, motion=None):
    return Show([Look("/r/a", "warm stripes", seed=1, hold_s=hold),
                 Look("/r/b", "cool stripes", seed=7, hold_s=hold, motion=motion)],
                [Transition(kind, seconds)], fps=fps)


def _simulate(models, frame):
    with torch.no_grad():
        return models.simulate(torch.from_numpy(frame).permute(2, 0, 1)[None])


def test_holds_are_compensated_once_and_frames_are_sane():
    setup = _setup()
    show = _two_looks("dissolve", fps=10, hold=1.0, seconds=0.5)
    out = list(show_frames(show, setup, settings=FrameSettings(dissolve="crossfade")))
    assert [i for i, _ in out] == list(range(25))
    assert setup.models.compensator.calls == 2  # two holds; the dissolve's frames are blends
    for _, frame in out:
        assert frame.dtype == np.float32 and frame.shape == (48, 64, 3)
        assert 0.0 <= frame.min() and frame.max() <= 1.0 and frame.mean() > 0.05
    first, last = out[0][1], out[-1][1]
    assert all(np.array_equal(f, first) for _, f in out[:10])
    # a dissolve frame is the linear-light blend of the compensated ends (export/projector_image)
    mid = out[10 + 2][1]  # w = 3/6
    g = np.float32(2.2)
    assert np.allclose(mid, blend_linear_light(first, last, first ** g, last ** g, 0.5, 2.2), atol=1e-6)


def test_morph_midpoint_is_a_new_look_and_its_ends_are_the_keyed_looks():
    models = fake_models()
    a, b = (keyed_look(Look("/r/x", p, seed=s), models) for p, s in (("a", 1), ("b", 7)))
    assert torch.equal(morph_base(a, b, 0.0), a.base) and torch.equal(morph_base(a, b, 1.0), b.base)
    near_a, mid, near_b = (morph_base(a, b, w) for w in (1e-4, 0.5, 1 - 1e-4))
    assert torch.allclose(near_a, a.base, atol=1e-3) and torch.allclose(near_b, b.base, atol=1e-3)
    assert (mid - a.base).abs().mean() > 0.02 and (mid - b.base).abs().mean() > 0.02
    # theta interpolated: the stripes' frequency in between, not a double exposure of the two
    linear_mix = ((a.base ** 2.2 + b.base ** 2.2) / 2) ** (1 / 2.2)
    assert (mid - linear_mix).abs().mean() > 0.01

    setup = ShowSetup(models, load_look=keyed_look)
    show = _two_looks("morph", fps=10, hold=0.3, seconds=0.9)
    frames = dict(show_frames(show, setup))
    hold_a, hold_b, middle = frames[0], frames[len(frames) - 1], frames[3 + 4]  # w = 5/10
    assert np.abs(middle - hold_a).mean() > 0.02 and np.abs(middle - hold_b).mean() > 0.02
    # the morph's first and last frames are near the looks they leave and reach
    assert np.abs(frames[3] - hold_a).mean() < np.abs(middle - hold_a).mean()
    assert np.abs(frames[11] - hold_b).mean() < np.abs(middle - hold_b).mean()


@pytest.mark.parametrize("preset", ["drift", "pulse"])
def test_a_moving_look_does_not_flicker(preset):
    setup = ShowSetup(fake_models(), load_look=keyed_look)
    show = Show([Look("/r/a", "moving stripes", seed=2, hold_s=1.0, motion=Motion(preset, 0.8, 2.0))], [], fps=12)
    maker = FrameMaker(show, setup)
    still = FrameMaker(show, setup, settings=FrameSettings(field_steps=0))  # the keyed field, not adapted
    captured, targets, unadapted = [], [], []
    for index in range(10):
        key = maker.schedule.at(index)
        frame = maker.frame(key)
        still.frame(key)
        captured.append(_simulate(setup.models, frame))
        targets.append(maker.target_of(key))
        unadapted.append(still.target_of(key))
    change = lambda xs: torch.stack([xs[k + 1] - xs[k] for k in range(len(xs) - 1)])  # noqa: E731
    d_cap, d_tgt, d_still = change(captured), change(targets), change(unadapted)
    assert d_tgt.abs().mean() > 1e-3  # it moves
    flicker = float((d_cap - d_tgt).abs().mean() / d_tgt.abs().mean())
    assert flicker < 0.1, flicker
    # the per-frame adaptation moves the field a little and smoothly: its own change of the target is a
    # small share of the motion's
    shake = float((d_tgt - d_still).abs().mean() / d_still.abs().mean())
    assert shake < 0.3, shake


def test_cancel_stops_before_the_next_frame_and_yields_nothing_more():
    setup = _setup()
    cancel = threading.Event()
    seen, progress = [], []
    show = _two_looks("morph", fps=10)
    with pytest.raises(InterruptedError):
        for index, _ in show_frames(show, setup, cancel_event=cancel, on_progress=lambda p, m: progress.append(p)):
            seen.append(index)
            if index == 2:
                cancel.set()
    assert seen == [0, 1, 2]
    assert progress[-1] == pytest.approx(3 / 18)
    cancel.set()
    with pytest.raises(InterruptedError):
        next(show_frames(show, setup, cancel_event=cancel))


def test_start_and_stop_and_a_bad_range():
    setup = _setup()
    show = _two_looks("dissolve", fps=10)
    assert [i for i, _ in show_frames(show, setup, start=4, stop=7)] == [4, 5, 6]
    with pytest.raises(ShowError):
        list(show_frames(show, setup, start=50))
    with pytest.raises(ShowError, match="frame rate"):
        list(show_frames(Show(show.looks, show.transitions, fps=0), setup))


@pytest.fixture
def stripes_registered():
    register_backend(StripesBackend.name, StripesBackend)
    yield
    BACKENDS.pop(StripesBackend.name, None)


def test_a_result_folder_gives_its_look_with_or_without_a_saved_state(tmp_path, stripes_registered):
    models = fake_models()
    folder = tmp_path / "result_a"
    folder.mkdir()
    (folder / "result.json").write_text(json.dumps({
        "prompt": "warm stripes", "backend": StripesBackend.name, "seed": 4, "psa": True,
        "psa_settings": {"max_iterations": 2, "warm_start_steps": 3, "terms": ["pc", "cs", "ps"]}}))
    look = Look(str(folder))
    adapted = look_from_result(look, models)  # no look_state.npz: PSA runs once
    assert adapted.name == StripesBackend.name and len(adapted.state["tone_field"]) == 4
    assert not (folder / LOOK_STATE_FILE).exists()  # nothing written into the result by reading it

    state = {"theta": [t * 1.1 for t in adapted.state["theta"]], "tone_field": adapted.state["tone_field"]}
    save_look_state(folder, state)
    loaded = load_look_state(folder)
    assert all(torch.equal(x, y) for x, y in zip(loaded["theta"], state["theta"]))
    from_file = look_from_result(look, models)
    assert all(torch.allclose(x, y) for x, y in zip(from_file.state["theta"], state["theta"]))
    assert not torch.allclose(from_file.base, adapted.base)

    with pytest.raises(ShowError, match="no result.json"):
        look_from_result(Look(str(tmp_path)), models)

    stale = json.loads((folder / "result.json").read_text())
    (folder / "result.json").write_text(json.dumps({**stale, "fingerprint": "an older capture"}))
    with pytest.raises(ShowError, match="made on another capture of the rig"):
        ShowSetup(models, fingerprint="this capture").keyed(0, look)
    assert look_from_result(look, models, fingerprint="an older capture").name == StripesBackend.name


def test_look_at_a_strip_of_frames():
    """Not a check: a strip of frames for a person to look at (/tmp/show/frames_strip.png)."""
    import cv2
    setup = ShowSetup(fake_models(), load_look=keyed_look)
    show = Show([Look("/r/a", "a", seed=1, hold_s=0.2, motion=Motion("colour_cycle", 1.0, 0.8)),
                 Look("/r/b", "b", seed=7, hold_s=0.4, motion=Motion("rise", 1.0, 0.4))],
                [Transition("morph", 0.6)], fps=10)
    frames = [f for _, f in show_frames(show, setup)]
    strip = np.concatenate(frames[::2], axis=1)
    cv2.imwrite("/tmp/show/frames_strip.png", (strip[..., ::-1] * 255).round().astype(np.uint8))
    assert len(frames) == 12


def test_another_output_size_renders_and_compensates_there():
    from lapig.lapig_core.capture.native_references import References

    models = fake_models()
    def image(t, w, h):
        return torch.nn.functional.interpolate(t, size=(h, w), mode="bilinear")[0].permute(1, 2, 0).numpy()

    def refs(w, h):
        return References(image(models.i_min, w, h), image(models.i_max, w, h), image(models.s, w, h),
                          np.ones((h, w), bool))

    setup = ShowSetup(models, load_look=keyed_look, references=refs)
    show = Show([Look("/r/a", "a", seed=1, hold_s=0.2), Look("/r/b", "b", seed=3, hold_s=0.2, motion=Motion("rise"))],
                [Transition("morph", 0.2)], fps=10)
    small = dict(show_frames(show, setup))
    big = dict(show_frames(show, setup, size=(128, 96)))
    assert set(big) == set(small) == set(range(6))
    for index, frame in big.items():
        assert frame.shape == (96, 128, 3) and frame.dtype == np.float32
        # the same look at twice the size: close to the working frame's, upsampled
        down = torch.nn.functional.avg_pool2d(torch.from_numpy(frame).permute(2, 0, 1)[None], 2)[0].permute(1, 2, 0)
        assert np.abs(down.numpy() - small[index]).mean() < 0.05


def test_a_morph_out_of_a_moving_look_starts_where_the_look_stands():
    setup = ShowSetup(fake_models(), load_look=keyed_look)
    show = Show([Look("/r/a", "a", seed=1, hold_s=0.7, motion=Motion("drift", 1.0, 2.0)), Look("/r/b", "b", seed=7)],
                [Transition("morph", 1.0)], fps=10)
    frames = dict(show_frames(show, setup, stop=9))
    last_moving, first_morph = frames[6], frames[7]
    still = FrameMaker(show, setup).frame(("hold", 0, 0.0))
    # the first in-between frame is near the look as it last stood, not the look at rest
    assert np.abs(first_morph - last_moving).mean() < 0.5 * np.abs(first_morph - still).mean()


def test_a_cancel_while_a_look_is_made_keeps_no_half_made_look():
    cancel = threading.Event()

    def load(look, models):
        cancel.set()  # as a cancel arriving during the look's PSA
        return keyed_look(look, models)

    setup = ShowSetup(fake_models(), load_look=load)
    messages = []
    with pytest.raises(InterruptedError):
        next(show_frames(_two_looks(), setup, cancel_event=cancel, on_progress=lambda p, m: messages.append(m)))
    assert setup._looks == {} and messages == ["preparing look 1 (1 of 2)"]


def test_a_refined_look_carries_its_correction_onto_its_frames(tmp_path, stripes_registered):
    from lapig.lapig_core.common.imageio import write_png
    from lapig.lapig_core.show.look_state import refine_offset

    models = fake_models()
    plain = ShowSetup(models, load_look=keyed_look)
    show = _two_looks("morph", fps=10, hold=0.2, seconds=0.1)  # frames: a, a, morph w=0.5, b, b

    def with_offset(look, m):
        keyed = keyed_look(look, m)
        keyed.offset = torch.full((1, 3, 48, 64), 0.05) if look.prompt == "warm stripes" else None
        return keyed

    base = dict(show_frames(show, plain))
    corrected = dict(show_frames(show, ShowSetup(models, load_look=with_offset)))
    assert np.allclose(corrected[0], np.clip(base[0] + 0.05, 0, 1), atol=1e-6)
    assert np.allclose(corrected[2], np.clip(base[2] + 0.025, 0, 1), atol=1e-5)  # the morph: half of it
    assert np.array_equal(corrected[4], base[4])

    # on disk: the refined working image minus the open-loop one, as result.json names them
    folder = tmp_path / "refined"
    folder.mkdir()
    open_loop = np.full((48, 64, 3), 0.4, np.float32)
    write_png(folder / "projector.png", open_loop, 16)
    write_png(folder / "projector_refined.png", open_loop + 0.1, 16)
    (folder / "result.json").write_text(json.dumps({"refine": {"images": {"projector_working": "projector_refined",
                                                                          "projector": "projector_refined"}}}))
    offset = refine_offset(folder)
    assert offset.shape == (1, 3, 48, 64) and torch.allclose(offset, torch.full_like(offset, 0.1), atol=1e-4)
    assert refine_offset(tmp_path) is None


def test_a_captured_setup_plays_at_the_projector_frame(tmp_path, stripes_registered):
    """The device check's capture (shipped), its first look fitted: from_capture, the registered references
    at the projector's 160x120, a look made from its result.json (no look_state.npz: PSA once)."""
    import shutil

    from lapig.lapig_core.capture.dataset import load_capture_set, setup_dir_of
    from lapig.lapig_core.photometric.first_look import fit_first_look
    from lapig.tools.bench.device_fixture import FIXTURE

    root = tmp_path / "fixture"
    shutil.copytree(FIXTURE, root)
    cs = load_capture_set(root)
    with pytest.raises(ShowError, match="neither trained models nor a first look"):
        ShowSetup.from_capture(setup_dir_of(cs))
    fit_first_look(cs, setup_dir_of(cs))
    setup = ShowSetup.from_capture(setup_dir_of(cs))
    result = tmp_path / "result"
    result.mkdir()
    (result / "result.json").write_text(json.dumps({
        "prompt": "warm stripes", "backend": StripesBackend.name, "seed": 2, "psa": True,
        "psa_settings": {"max_iterations": 1, "warm_start_steps": 0}}))
    show = Show([Look(str(result), hold_s=0.3, motion=Motion("pulse", 0.8, 0.3))], [], fps=10)
    frames = dict(show_frames(show, setup, size=(160, 120)))
    assert sorted(frames) == [0, 1, 2]
    for frame in frames.values():
        assert frame.shape == (120, 160, 3) and frame.mean() > 0.05
    assert np.abs(frames[1] - frames[0]).mean() > 1e-3  # it pulses


def test_a_compensated_dissolve_compensates_the_mixed_targets():
    from lapig.lapig_core.native_output import compensate_frame
    from lapig.lapig_core.show.morph import mix_linear

    setup = ShowSetup(fake_models(), load_look=keyed_look)
    show = _two_looks("dissolve", fps=10, hold=0.2, seconds=0.1)  # frames: a, a, dissolve w=0.5, b, b
    crossfade = dict(show_frames(show, setup, settings=FrameSettings(dissolve="crossfade")))
    maker = FrameMaker(show, setup, settings=FrameSettings(dissolve="compensated"))
    mid = maker.frame(maker.schedule.at(2))
    target = mix_linear(maker.target_of(("hold", 0, 0.0)), maker.target_of(("hold", 1, 0.0)), 0.5)
    with torch.no_grad():
        expected = compensate_frame(setup.models.compensator, target, setup.models.s, maker.tile)
    assert np.allclose(mid, expected[0].permute(1, 2, 0).numpy(), atol=1e-6)
    assert np.abs(mid - crossfade[2]).mean() > 1e-4  # not the crossfade
    assert np.array_equal(maker.frame(("hold", 0, 0.0)), crossfade[0])
    with pytest.raises(ShowError, match="keyed, compensated, crossfade"):
        FrameMaker(show, setup, settings=FrameSettings(dissolve="wipe"))


def test_a_keyed_dissolve_compensates_its_keys_and_crossfades_between_them():
    setup = _setup()
    show = _two_looks("dissolve", fps=10, hold=0.2, seconds=0.7)  # frames: a, a, 7 dissolve frames (w = n/8), b, b
    out = dict(show_frames(show, setup))  # the default: keyed
    assert setup.models.compensator.calls == 2 + 3  # the two looks and the keys at 1/4, 1/2 and 3/4, once each
    exact = FrameMaker(show, setup, settings=FrameSettings(dissolve="compensated"))
    for n in (2, 4, 6):  # frame 1 + n has the weight n/8: the keys are compensated as their own targets
        key = exact.schedule.at(1 + n)
        assert key[3] == pytest.approx(n / 8)
        assert np.allclose(out[1 + n], exact.frame(key), atol=1e-6)
    # between two keys: their linear-light blend, halfway from 1/4 to 1/2 at w = 3/8
    g = np.float32(2.2)
    a, b = out[3], out[5]
    assert np.allclose(out[4], blend_linear_light(a, b, a ** g, b ** g, 0.5, 2.2), atol=1e-6)
    # and not the plain crossfade of the looks, whose midpoint misses what the surface can show of the mix
    plain = dict(show_frames(show, ShowSetup(fake_models(), load_look=keyed_look),
                             settings=FrameSettings(dissolve="crossfade")))
    assert np.abs(out[5] - plain[5]).mean() > 1e-4

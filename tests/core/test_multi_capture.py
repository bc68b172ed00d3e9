# SPDX-License-Identifier: GPL-3.0-or-later
"""Several projectors (issue 36): the capture sequence on the numpy fake rig, its capture set and the first look."""
import json

import numpy as np
import pytest

from lapig.lapig_core.capture.settings import CaptureError, CaptureSettings
from lapig.tools.fakes import fake_rig
from lapig.lapig_core.multi.capture import run_multi_capture
from lapig.lapig_core.multi.capture_set import is_multi, joint_model_path, load_multi_capture
from lapig.lapig_core.multi.first_look import fit_joint_first_look, load_joint_model

CAMERA = (96, 72)  # finer than the projectors: their finest Gray-code stripes decode
PROJECTOR = (48, 36)


def _run(device, tmp_path, names=("left", "right"), **settings):
    s = CaptureSettings(out_dir=str(tmp_path / "data"), setup_name="bust", train_count=settings.pop("train_count", 8),
                        chunk=6, **settings)
    gen = run_multi_capture(device, s, list(names), extra_meta={"fingerprint": "abc"})
    steps = []
    while True:
        try:
            steps.append(next(gen))
        except StopIteration as done:
            return done.value, steps


def _rig(**kw):
    return fake_rig.side_by_side_rig(CAMERA, PROJECTOR, noise=0.002, **kw)


def test_the_capture_registers_each_projector_and_the_first_look_fits_them_jointly(tmp_path):
    rig = _rig()
    device = fake_rig.FakeRigDevice(rig)
    result, steps = _run(device, tmp_path)
    assert [p for p, _ in steps] == sorted(p for p, _ in steps) and steps[-1][0] == 1.0
    setup = result["setup_dir"]
    assert is_multi(setup) and is_multi(tmp_path / "data")
    cs = load_multi_capture(setup)
    assert cs.names == ("left", "right") and cs.sizes == (PROJECTOR, PROJECTOR)
    assert [f.shape for f in cs.frames] == [(8, 36, 48, 3)] * 2
    assert [c.shape for c in cs.captures] == [(8, 72, 96, 3)] * 2
    # each registration lands where the rig's truth says, within a fraction of a projector pixel
    for k, m in enumerate(cs.maps):
        truth = rig.camera_map(k)
        both = m.valid & truth.valid
        assert both.sum() > 0.9 * truth.valid.sum()
        err = np.hypot(m.map_x - truth.map_x, m.map_y - truth.map_y)[both]
        assert np.median(err) < 0.5, np.median(err)
    # frame sets: K x (Gray code + training) + black + together + the blend probe, no more
    from lapig.lapig_core.capture.structured_light import pattern_count

    assert device.captured == 2 * (pattern_count(*PROJECTOR) + 8) + 3
    meta = result["meta"]
    assert meta["coverage"]["reached"] > meta["coverage"]["per_projector"][0] + 0.15

    look = fit_joint_first_look(cs)
    assert look.coverage_joint > 0.9 and look.coverage_joint >= look.coverage_single + 0.15
    assert "black is" in look.uplift.sentence() and "contrast falls" in look.status_line()
    # the light of separately captured projectors adds up (the RMS counts the frames' edges, which decoded maps
    # place within a pixel)
    assert look.model.together_rms < 0.06, look.model.together_rms
    predicted = look.model.predict(cs.together_frames())
    reached = look.model.reached.any(axis=0)
    assert np.median(np.abs(predicted - cs.together / 255.0)[reached]) < 0.02
    saved = load_joint_model(setup)
    assert saved is not None and saved.count == 2 and joint_model_path(setup).is_file()
    record = json.loads((setup / "models" / "first_look.json").read_text())
    assert record["fingerprint"] == "abc" and record["coverage_joint"] == pytest.approx(look.coverage_joint)


def test_projectors_of_different_resolutions_are_captured_and_fitted(tmp_path):
    rig = _rig()
    small = fake_rig.FakeProjector((32, 24), fake_rig.homography_onto((32, 24), CAMERA, [(0.37, -0.04), (0.97, -0.01),
                                                                                         (0.98, 1.02), (0.39, 1.05)]))
    rig = fake_rig.FakeRig([rig.projectors[0], small], CAMERA, noise=0.002)
    result, _ = _run(fake_rig.FakeRigDevice(rig), tmp_path)
    cs = load_multi_capture(result["setup_dir"])
    assert cs.sizes == (PROJECTOR, (32, 24))
    look = fit_joint_first_look(cs)
    assert look.model.count == 2 and look.coverage_joint > 0.9


def test_a_projector_that_reaches_nothing_stops_the_capture_by_name_and_keeps_the_previous_one(tmp_path):
    result, _ = _run(fake_rig.FakeRigDevice(_rig()), tmp_path)
    before = (result["setup_dir"] / "setup.json").read_bytes()
    rig = _rig()
    away = fake_rig.FakeProjector(PROJECTOR, fake_rig.homography_onto(PROJECTOR, CAMERA, [(2.0, 2.0), (3.0, 2.0),
                                                                                         (3.0, 3.0), (2.0, 3.0)]))
    broken = fake_rig.FakeRig([rig.projectors[0], away], CAMERA, noise=0.002)
    device = fake_rig.FakeRigDevice(broken)
    with pytest.raises(CaptureError, match="projector 'astray' reaches nothing the camera sees"):
        _run(device, tmp_path, names=("left", "astray"))
    assert (result["setup_dir"] / "setup.json").read_bytes() == before
    assert load_multi_capture(result["setup_dir"]).names == ("left", "right")
    from lapig.lapig_core.capture.structured_light import pattern_count

    assert device.captured == 2 * pattern_count(*PROJECTOR)  # stopped after its Gray code, before any training frame


def test_too_few_training_frames_are_refused_before_anything_is_shown(tmp_path):
    device = fake_rig.FakeRigDevice(_rig())
    with pytest.raises(CaptureError, match="at least 3 training images"):
        _run(device, tmp_path, train_count=2)
    assert device.captured == 0


def test_the_camera_gamma_comes_from_the_overlaps_additivity(tmp_path):
    from lapig.lapig_core.multi.additivity import additive_gamma
    from lapig.lapig_core.multi.first_look import joint_gammas

    rig = _rig()
    result, _ = _run(fake_rig.FakeRigDevice(rig), tmp_path)
    cs = load_multi_capture(result["setup_dir"])
    reached = np.stack([m.valid for m in cs.maps])
    assert abs(additive_gamma(cs.together, [c[0] for c in cs.captures], cs.black, reached) - rig.camera_gamma) < 0.1
    gamma_c, gamma_p = joint_gammas(cs)
    for gp, proj in zip(gamma_p, rig.projectors):
        assert abs(gp - proj.gamma) < 0.25
    # projectors that do not overlap say nothing of it: the joint model's own search stands
    assert additive_gamma(cs.together, [c[0] for c in cs.captures], cs.black, reached & [[[True]], [[False]]]) is None

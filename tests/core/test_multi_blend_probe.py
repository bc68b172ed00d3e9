# SPDX-License-Identifier: GPL-3.0-or-later
"""Several projectors (issue 36): the blend checked by the camera (multi/blend_probe). The capture shows the
blend's alpha maps once; the first look fits the gamma each alpha map is encoded with from it, so the blended
white in the overlap matches the light of each projector alone even where the joint fit split the camera's and
the projectors' curves wrongly."""
import json

import numpy as np
import pytest

from lapig.lapig_core.capture.settings import CaptureSettings
from lapig.tools.fakes import fake_rig
from lapig.lapig_core.multi.blend import alpha_maps, blend_weights, encode_alpha
from lapig.lapig_core.multi.blend_probe import PROBE_GAMMA, fit_blend_gammas, probe_frames
from lapig.lapig_core.multi.capture import run_multi_capture
from lapig.lapig_core.multi.capture_set import BLEND_PROBE, load_multi_capture
from lapig.lapig_core.multi.first_look import fit_joint_first_look, load_joint_model
from lapig.lapig_core.multi.joint_model import JointModel

CAMERA = (96, 72)
PROJECTOR = (48, 36)
TRUE_GAMMAS = (2.6, 2.4)  # neither is the probe's 2.2


def _capture(tmp_path, gammas=TRUE_GAMMAS):
    rig = fake_rig.side_by_side_rig(CAMERA, PROJECTOR, noise=0.002)
    for proj, g in zip(rig.projectors, gammas):
        proj.gamma = g
    s = CaptureSettings(out_dir=str(tmp_path / "data"), setup_name="wall", train_count=8, chunk=6)
    gen = run_multi_capture(fake_rig.FakeRigDevice(rig), s, ["left", "right"])
    while True:
        try:
            next(gen)
        except StopIteration as done:
            return rig, load_multi_capture(done.value["setup_dir"])


@pytest.fixture(scope="module")
def captured(tmp_path_factory):
    return _capture(tmp_path_factory.mktemp("probe"))


def _fit(cs, gamma_c, gamma_p):
    return fit_blend_gammas(cs.maps, gamma_p, gamma_c, cs.probe_frames, cs.probe, [c[0] for c in cs.captures],
                            cs.black, cs.object_mask)


def _overlap_error(rig, cs, gammas) -> float:
    """The median relative error of the fake rig's blended white against the exact blend of its whites alone,
    in the rig's true linear light, over the overlap's mixed pixels."""
    weights = blend_weights(cs.maps)
    frames = [np.repeat(encode_alpha(a, g)[..., None], 3, axis=-1) for a, g in zip(alpha_maps(cs.maps, weights), gammas)]
    lin = lambda img: np.power(np.asarray(img, np.float64) / 255.0, rig.camera_gamma).mean(axis=-1)  # noqa: E731
    black = lin(rig.capture([None, None]))
    blended = lin(rig.capture(frames)) - black
    alone = [lin(c[0]) - black for c in cs.captures]
    exact = sum(w * a for w, a in zip(weights, alone))
    mixed = cs.object_mask & (weights.max(axis=0) < 0.9) & (exact > 0.02)
    assert mixed.sum() > 200
    return float(np.median(blended[mixed] / exact[mixed]) - 1.0)


def test_the_capture_shows_the_blend_once_and_keeps_it(captured):
    rig, cs = captured
    assert (cs.setup_dir / BLEND_PROBE).is_file()
    assert len(cs.probe_frames) == 2 and cs.probe.shape == CAMERA[::-1] + (3,)
    # what each projector showed is its alpha map encoded with the probe's gamma, 8-bit
    expected = probe_frames(cs.maps)
    for shown, want in zip(cs.probe_frames, expected):
        assert np.abs(shown.astype(int) - want.astype(int)).max() <= 1
    alpha = np.power(cs.probe_frames[0][..., 0] / 255.0, PROBE_GAMMA)
    assert alpha.max() > 0.99 and alpha.min() < 0.05  # it fades out across the overlap


def test_each_projectors_curve_comes_back_from_the_probe(captured):
    rig, cs = captured
    fit = _fit(cs, rig.camera_gamma, TRUE_GAMMAS)
    assert fit is not None and fit.pixels > 500
    assert fit.gammas == pytest.approx(TRUE_GAMMAS, abs=0.06)
    # the probe, encoded with 2.2 for projectors of 2.6 and 2.4, left the overlap too dark
    assert fit.probe_error < -0.04
    # a joint fit that got the camera wrong (the curves' split is what captures alone cannot fix) moves the
    # probe's answer little: the blend is referred to the light of each projector alone
    for gamma_c, gamma_p in ((1.8, (2.1, 1.95)), (2.6, (3.1, 2.85))):
        wrong = _fit(cs, gamma_c, gamma_p)
        assert wrong is not None and wrong.gammas == pytest.approx(TRUE_GAMMAS, abs=0.15), (gamma_c, wrong)
        assert abs(wrong.gamma_p_error) > 0.05  # the old encoding would have missed by more than 5 %
    # gammas in the wrong order (what the joint fit of this rig gives): curves this alike are not told apart by
    # the overlap (each projector's own fit explains the probe no better), and a wrong split of them costs the
    # blend little: within 1.5 % of the exact blend
    swapped = _fit(cs, rig.camera_gamma, (2.49, 2.65))
    assert swapped.shared
    assert abs(_overlap_error(rig, cs, swapped.gammas)) < 0.015


def test_curves_far_apart_are_told_apart(tmp_path):
    rig, cs = _capture(tmp_path, gammas=(2.8, 1.8))
    for given in ((2.2, 2.2), (1.8, 2.8)):  # no ratio, the wrong ratio
        fit = _fit(cs, rig.camera_gamma, given)
        assert not fit.shared and fit.gammas == pytest.approx((2.8, 1.8), abs=0.06), (given, fit)
    assert abs(_overlap_error(rig, cs, fit.gammas)) < 0.01
    assert abs(_overlap_error(rig, cs, (2.2, 2.2))) > 0.02  # one gamma for both would leave the overlap uneven


def test_the_fitted_gammas_make_the_blended_white_match_the_light_alone(captured):
    rig, cs = captured
    wrong_gamma_p = (2.1, 1.95)  # a joint fit with the camera's curve at 1.8 instead of 2.2
    fit = _fit(cs, 1.8, wrong_gamma_p)
    before = _overlap_error(rig, cs, wrong_gamma_p)
    after = _overlap_error(rig, cs, fit.gammas)
    assert before < -0.05, before  # too dark: alphas encoded with too small a gamma (a ** (2.6 / 2.1) < a)
    assert abs(after) < 0.015, after
    assert fit.gamma_p_error == pytest.approx(before, abs=0.02)  # the fit predicted the old path's error


def test_the_first_look_stores_the_gammas_and_everything_that_encodes_alphas_uses_them(captured, tmp_path):
    from lapig.lapig_core.multi.mpcdi_export import mpcdi_buffers

    rig, cs = captured
    look = fit_joint_first_look(cs)
    model = look.model
    assert look.blend_fit is not None and model.blend_gamma == look.blend_fit.gammas
    assert abs(_overlap_error(rig, cs, model.alpha_gammas)) < 0.015
    record = json.loads((cs.setup_dir / "models" / "first_look.json").read_text())
    assert record["blend_gamma"]["gammas"] == pytest.approx(list(model.blend_gamma), abs=1e-3)
    assert load_joint_model(cs.setup_dir).blend_gamma == pytest.approx(model.blend_gamma)
    regions = [b.regions[0] for b in mpcdi_buffers(model, cs.names)]
    assert [r.gamma for r in regions] == list(model.alpha_gammas)
    assert [r.signal_gamma for r in regions] == list(model.alpha_gammas)


def test_a_model_without_a_probe_encodes_alphas_with_its_fitted_gammas(captured, tmp_path):
    rig, cs = captured
    model = fit_joint_first_look(cs).model
    plain = JointModel(model.gamma_c, model.gamma_p, model.M, model.o, model.maps)
    assert plain.blend_gamma is None and plain.alpha_gammas == plain.gamma_p
    path = tmp_path / "old.npz"
    plain.save(path)
    assert JointModel.load(path).blend_gamma is None
    with pytest.raises(ValueError, match="one blend gamma per projector"):
        JointModel(model.gamma_c, model.gamma_p, model.M, model.o, model.maps, blend_gamma=(2.2,))


def test_the_probe_says_nothing_without_an_overlap(captured):
    rig, cs = captured
    apart = [fake_rig.CameraMap(m.map_x, m.map_y, m.valid & (np.arange(CAMERA[0]) < CAMERA[0] // 2 if k == 0
                                                             else np.arange(CAMERA[0]) >= CAMERA[0] // 2),
                                m.projector_size) for k, m in enumerate(cs.maps)]
    assert fit_blend_gammas(apart, TRUE_GAMMAS, 2.2, cs.probe_frames, cs.probe, [c[0] for c in cs.captures],
                            cs.black) is None
    assert fit_blend_gammas(cs.maps[:1], TRUE_GAMMAS[:1], 2.2, cs.probe_frames[:1], cs.probe,
                            [cs.captures[0][0]], cs.black) is None

"""Choosing the compensator by measurement on held-back pairs (learned against classical)."""
import numpy as np
import pytest

torch = pytest.importorskip("torch")

from lapig.lapig_core.photometric import choice  # noqa: E402
from lapig.lapig_core.photometric.classical import ClassicalModel  # noqa: E402
from lapig.lapig_core.photometric.classical_compensator import ClassicalCompensator  # noqa: E402
from lapig.tools.research import projector_space_choice as by_pairs  # noqa: E402


def _pairs(n, seed, size=32):
    """Direct light only: capture = (albedo * p^2.2 + 0.02)^(1/2.2), the classical model's own world."""
    rng = np.random.default_rng(seed)
    albedo = rng.uniform(0.3, 0.9, (size, size, 3)).astype(np.float32)
    prj = rng.uniform(0, 1, (n, size, size, 3)).astype(np.float32)
    cam = np.power(albedo * prj ** 2.2 + 0.02, 1 / 2.2).astype(np.float32)
    return prj, cam


def test_the_classical_model_is_chosen_where_the_learned_one_measures_worse():
    prj, cam = _pairs(24, 0)
    classical = ClassicalModel.fit(prj[:16], cam[:16])

    def poor_network(c):  # a fake learned compensator that lags: the target itself, slightly blurred
        return np.clip(c * 0.9 + 0.05, 0, 1)

    picked = by_pairs.choose(poor_network, classical.compensate, cam[16:], prj[16:])
    assert picked.chosen == choice.CLASSICAL
    assert picked.classical_psnr > picked.learned_psnr
    assert picked.margin_db == pytest.approx(picked.classical_psnr - picked.learned_psnr, abs=1e-3)
    assert "classical" in picked.line() and "held-back" in picked.line()
    # and a learned one that does better wins
    exact = by_pairs.choose(lambda c: prj[16:], classical.compensate, cam[16:], prj[16:])
    assert exact.chosen == choice.LEARNED


def test_clipped_captures_do_not_decide_the_choice():
    """Where a capture sits at I- or I+ many projector values make it: the choice counts only the
    pixels whose capture identifies the projector value."""
    rng = np.random.default_rng(3)
    black, white = np.full((32, 32, 3), 0.1, np.float32), np.full((32, 32, 3), 0.9, np.float32)
    prj = rng.uniform(0, 1, (6, 32, 32, 3)).astype(np.float32)
    prj[:, :, :16] = np.where(prj[:, :, :16] > 0.5, 1.0, 0.0)  # the left half: black or white only
    cam = np.clip(prj, 0.1, 0.9).astype(np.float32)  # ...so the left half's captures are clipped
    clipped = (cam <= 0.1 + by_pairs.UNCLIPPED_MARGIN) | (cam >= 0.9 - by_pairs.UNCLIPPED_MARGIN)
    assert not by_pairs.identifiable(cam, black, white, None)[clipped].any()

    def right_where_identifiable(c):  # exact inside the range, wrong at its ends
        return np.where(clipped, 0.5, prj).astype(np.float32)

    def right_where_clipped(c):  # exact at the ends (where nothing can be known), off inside
        return np.where(clipped, prj, np.clip(prj + 0.08, 0, 1)).astype(np.float32)

    blind = by_pairs.choose(right_where_clipped, right_where_identifiable, cam, prj)  # without I- and I+
    assert blind.chosen == choice.LEARNED  # the clipped half decided it
    picked = by_pairs.choose(right_where_clipped, right_where_identifiable, cam, prj, None, black, white)
    assert picked.chosen == choice.CLASSICAL and picked.classical_psnr == choice.MAX_PSNR
    nothing = by_pairs.choose(right_where_clipped, right_where_identifiable, cam[:, :, :16], prj[:, :, :16], None,
                            black[:, :16], white[:, :16])
    assert nothing.chosen == choice.LEARNED and "clipped everywhere" in nothing.line()


def test_the_choice_in_simulated_captures_picks_what_the_camera_would_see_better():
    """Judged in camera space: the compensator whose projected (simulated) images come nearer the
    desired captures wins, even one the projector-space comparison cannot rank."""
    prj, cam = _pairs(24, 4)
    classical = ClassicalModel.fit(prj[:16], cam[:16])
    black = classical.simulate(np.zeros((1,) + prj.shape[1:], np.float32))[0]
    white = classical.simulate(np.ones((1,) + prj.shape[1:], np.float32))[0]

    def blurred(c):  # a compensator that is right on average but loses detail
        import cv2
        return np.stack([cv2.GaussianBlur(x, (0, 0), 2.0) for x in classical.compensate(c)])

    picked = choice.choose_by_simulation(blurred, classical.compensate, classical.simulate, prj[16:], black, white)
    assert picked.chosen == choice.CLASSICAL and picked.judge == choice.PCNET_JUDGE
    assert picked.classical_psnr > picked.learned_psnr + 3
    assert "simulated captures" in picked.line() and "held-back images" in picked.line()
    # the camera sees the sharper one better, whichever side it is on
    swapped = choice.choose_by_simulation(classical.compensate, blurred, classical.simulate, prj[16:], black, white)
    assert swapped.chosen == choice.LEARNED
    none = choice.choose_by_simulation(blurred, classical.compensate, classical.simulate, prj[:0], black, white)
    assert none.chosen == choice.LEARNED and "no held-back" in none.line()


def test_the_learned_compensator_must_lead_by_more_than_the_judges_bias():
    """PCNet favours CompenNeSt's images: a lead smaller than LEARNED_LEAD_DB keeps the classical model, and the
    line says why; a larger one picks the network."""
    prj, cam = _pairs(24, 4)
    classical = ClassicalModel.fit(prj[:16], cam[:16])
    black = classical.simulate(np.zeros((1,) + prj.shape[1:], np.float32))[0]
    white = classical.simulate(np.ones((1,) + prj.shape[1:], np.float32))[0]

    def blurred(c, sigma):
        import cv2
        return np.stack([cv2.GaussianBlur(x, (0, 0), sigma) for x in classical.compensate(c)])

    plain = choice.choose_by_simulation(lambda c: blurred(c, 0.7), lambda c: blurred(c, 0.8), classical.simulate,
                                        prj[16:], black, white, required_lead_db=0.0)
    lead = plain.learned_psnr - plain.classical_psnr
    assert plain.chosen == choice.LEARNED and 0 < lead < choice.LEARNED_LEAD_DB
    held = choice.choose_by_simulation(lambda c: blurred(c, 0.7), lambda c: blurred(c, 0.8), classical.simulate,
                                       prj[16:], black, white)
    assert held.chosen == choice.CLASSICAL and held.required_lead_db == choice.LEARNED_LEAD_DB
    assert f"only {lead:.2f} dB ahead" in held.line() and "1.0 dB it needs" in held.line()
    far = choice.choose_by_simulation(classical.compensate, lambda c: blurred(c, 2.0), classical.simulate,
                                      prj[16:], black, white)
    assert far.chosen == choice.LEARNED and far.learned_psnr > far.classical_psnr + choice.LEARNED_LEAD_DB


def test_no_held_back_pairs_keeps_the_learned_one_and_says_why():
    prj, cam = _pairs(4, 1)
    picked = by_pairs.choose(lambda c: c, lambda c: c, cam[:0], prj[:0])
    assert picked.chosen == choice.LEARNED and "no held-back" in picked.line()


def test_the_classical_compensator_module_matches_the_model_at_any_size(tmp_path):
    prj, cam = _pairs(16, 2)
    model = ClassicalModel.fit(prj, cam)
    module = ClassicalCompensator(model)
    t = torch.from_numpy(cam[:2].transpose(0, 3, 1, 2).copy())
    out, raw = module(t, None, return_raw=True)
    expected = model.compensate(cam[:2]).transpose(0, 3, 1, 2)
    assert np.abs(out.numpy() - expected).max() < 2e-3
    assert raw.shape == out.shape
    big = torch.nn.functional.interpolate(t, (64, 64), mode="bilinear", align_corners=False)
    assert module(big, None, *module.frame_inputs(64, 64)).shape == (2, 3, 64, 64)
    # saved and loaded beside the models
    picked = choice.CompensatorChoice(choice.CLASSICAL, 20.0, 22.5, 8, "", choice.PCNET_JUDGE)
    choice.save_choice(tmp_path, picked, model)
    loaded, again = choice.load_choice(tmp_path)
    assert loaded == picked and np.allclose(again.M, model.M)
    assert choice.load_choice(tmp_path / "none") is None


def test_fine_tuning_measures_both_and_the_setup_compensates_with_the_better(tmp_path):
    """train_models measures the fine-tuned network against the classical model and records the better one,
    and surface_models hands out that compensator with the choice: the network where it won, the classical
    model where the saved choice says classical."""
    from lapig.lapig_core.capture.dataset import load_capture_set
    from lapig.lapig_core.capture.fake_device import FakeDevice
    from lapig.lapig_core.capture.sequence import GeometryChecks, run_capture
    from lapig.lapig_core.capture.settings import CaptureSettings
    from lapig.lapig_core.common.steps import run_to_end
    from lapig.lapig_core.capture.dataset import setup_dir_of
    from lapig.lapig_core.pipeline import surface_models, train_models

    device = FakeDevice(projector_size=(48, 36), camera_size=(96, 72))
    settings = CaptureSettings(out_dir=str(tmp_path), train_count=12, test_count=4, working_size=48, chunk=8)
    checks = GeometryChecks(coverage=device.coverage, exact_projector_to_camera=device.exact_projector_to_camera)
    cs = load_capture_set(run_to_end(run_capture(device, settings, checks))["setup_dir"])
    trained = train_models(cs, iterations=2)
    picked = trained["choice"]
    assert picked.validation_pairs == 4 and picked.judge == choice.PCNET_JUDGE
    assert picked.required_lead_db == choice.LEARNED_LEAD_DB
    assert picked.chosen == (choice.LEARNED if picked.learned_psnr > picked.classical_psnr + picked.required_lead_db
                             else choice.CLASSICAL)
    assert (setup_dir_of(cs) / "models" / choice.CHOICE_FILE).is_file()
    models = surface_models(cs)
    assert models.choice == picked
    assert isinstance(models.compensator, ClassicalCompensator) == (picked.chosen == choice.CLASSICAL)
    # a setup whose measurement chose the classical model compensates with it
    classical_won = choice.CompensatorChoice(choice.CLASSICAL, 20.0, 22.5, 4, "", choice.PCNET_JUDGE)
    choice.save_choice(setup_dir_of(cs) / "models", classical_won, trained["classical"])
    models = surface_models(cs)
    assert isinstance(models.compensator, ClassicalCompensator)
    assert models.choice == classical_won
    out = models.compensate(models.i_max)
    assert out.shape == models.i_max.shape and 0 <= float(out.min()) and float(out.max()) <= 1


def test_the_rendered_choice_takes_the_compensator_whose_captures_come_nearer():
    """choose_by_captures: the rig's captures of both compensations decide, with no lead asked of either."""
    rng = np.random.default_rng(5)
    targets = rng.uniform(0.2, 0.8, (3, 16, 16, 3)).astype(np.float32)
    reach = np.ones((16, 16), bool)
    reach[:, :4] = False  # off the object: whatever lands there does not count
    v = choice.Verification(targets, reach, targets, targets)
    near = targets + rng.normal(0, 0.01, targets.shape).astype(np.float32)
    far = targets + rng.normal(0, 0.03, targets.shape).astype(np.float32)
    far[:, :, :4] = near[:, :, :4] = 0.0
    learned_won = choice.choose_by_captures(v, np.concatenate([near, far]))
    assert learned_won.chosen == choice.LEARNED and learned_won.judge == choice.RENDERED_JUDGE
    assert learned_won.learned_psnr == pytest.approx(40.0, abs=0.3) and learned_won.required_lead_db == 0.0
    assert "Cycles captures of 3 held-back images" in learned_won.line()
    classical_won = choice.choose_by_captures(v, np.concatenate([far, near]))
    assert classical_won.chosen == choice.CLASSICAL
    assert classical_won.margin_db == pytest.approx(learned_won.margin_db, abs=1e-3)
    tie = choice.choose_by_captures(v, np.concatenate([near, near]))
    assert tie.chosen == choice.CLASSICAL
    with pytest.raises(ValueError, match="expected 6 captures"):
        choice.choose_by_captures(v, near)


def test_the_verification_compensates_held_back_images_both_ways_inside_the_surfaces_range():
    from lapig.lapig_core.capture.dataset import CaptureSet
    from lapig.lapig_core.photometric.checkpoints import new_model

    prj, cam = _pairs(24, 6)
    classical = ClassicalModel.fit(prj[:16], cam[:16])
    black = classical.simulate(np.zeros(prj.shape[1:], np.float32))
    white = classical.simulate(np.ones(prj.shape[1:], np.float32))
    valid = np.ones(prj.shape[1:3], bool)
    valid[:4] = False
    cs = CaptureSet(prj_train=prj[:16], cam_train=cam[:16], prj_test=prj[16:], cam_test=cam[16:], cam_black=black,
                    cam_white=white, cam_gray=classical.simulate(np.full(prj.shape[1:], 0.5, np.float32)),
                    gray_level=0.5,
                    projector_valid=valid)
    v = choice.verification(cs, new_model("CompenNeSt", 0), classical)
    assert v.targets.shape == (choice.VERIFY_IMAGES,) + prj.shape[1:] and v.images.shape[0] == 2 * choice.VERIFY_IMAGES
    assert not v.reach[:4].any() and v.reach[4:].all()
    assert np.allclose(v.classical, classical.compensate(v.targets))
    assert 0 <= v.learned.min() and v.learned.max() <= 1
    assert choice.verification(cs, new_model("CompenNeSt", 0), classical, images=prj[:0]) is None

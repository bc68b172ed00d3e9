# SPDX-License-Identifier: GPL-3.0-or-later
import datetime
import json

import numpy as np
import pytest

from lapig.lapig_core.common.imageio import read_image
from lapig.lapig_core.export.result_files import (folder_name, heat_overlay, output_name, read_output_image,
                                            read_result_image, read_summary, stored_bit_depth, write_new_result,
                                            write_result)
from lapig.lapig_core.photometric.targets import desired_targets, reachable_mask, reachable_range


def test_desired_targets_live_in_the_reachable_range():
    rng = np.random.default_rng(0)
    black = np.full((16, 16, 3), 0.05, np.float32)
    white = np.clip(0.6 + 0.3 * rng.random((16, 16, 3)), 0, 1).astype(np.float32)
    white[:4] = black[:4]  # off the object: the projector does not reach it
    mask = reachable_mask(black, white)
    assert not mask[:4].any() and mask[4:].all()
    lo, hi = reachable_range(black, white, mask)
    images = rng.random((3, 16, 16, 3)).astype(np.float32)
    t = desired_targets(images, black, white, mask)
    assert np.allclose(t[:, :4], black[:4])  # nothing can be done there
    assert (t[:, 4:] >= lo - 1e-6).all() and (t[:, 4:] <= hi + 1e-6).all()
    with pytest.raises(ValueError, match="does not reach"):
        reachable_range(black, black)


@pytest.mark.torch
def test_masked_psnr_ignores_pixels_outside_the_mask():
    from lapig.lapig_core.common import metrics

    a = np.zeros((8, 8, 3), np.float32)
    b = a.copy()
    b[:4] = 1.0  # huge error only where the mask is off
    mask = np.zeros((8, 8), bool)
    mask[4:] = True
    b[4:] = 0.1
    assert metrics.masked_psnr(b, a, mask) == pytest.approx(20.0, abs=1e-4)
    assert metrics.psnr(b, a) < 5


@pytest.mark.torch
def test_masked_psnr_takes_a_mask_per_image():
    from lapig.lapig_core.common import metrics

    target = np.zeros((2, 8, 8, 3), np.float32)
    pred = target.copy()
    pred[0, :4], pred[0, 4:], pred[1] = 1.0, 0.1, 0.01  # image 0: bad top, image 1: good everywhere
    masks = np.zeros((2, 8, 8), bool)
    masks[0, 4:], masks[1] = True, True  # 32 + 64 pixels at errors 0.01 and 0.0001
    expected = 10 * np.log10(1 / ((32 * 0.01 + 64 * 1e-4) / 96))
    assert metrics.masked_psnr(pred, target, masks) == pytest.approx(expected, abs=1e-3)
    # one (H, W) mask is the same mask on every image
    assert metrics.masked_psnr(pred, target, masks[0]) == pytest.approx(
        metrics.masked_psnr(pred, target, np.stack([masks[0]] * 2)), abs=1e-6)


@pytest.mark.torch
def test_figures_on_the_object_leave_the_frame_around_it_out():
    from lapig.lapig_core.common import metrics

    rng = np.random.default_rng(0)
    target = rng.random((48, 64, 3)).astype(np.float32)
    capture = target.copy()
    capture[:, 40:] = 0.0  # off the object: dark whatever was projected
    capture[:, :40] += 0.05  # on it: a small, even error
    mask = np.zeros((48, 64), bool)
    mask[:, :40] = True
    on = metrics.evaluate_on(capture, target, mask)
    assert on["psnr"] == pytest.approx(26.02, abs=0.01)  # 10 log10(1 / 0.05^2)
    assert on["rmse"] == pytest.approx(0.05 * np.sqrt(3), abs=1e-4)
    assert on["ssim"] > 0.95 > metrics.ssim(capture, target)
    assert metrics.evaluate(capture, target)["psnr"] < 10
    assert metrics.masked_ssim(target, target, mask) == pytest.approx(1.0)


def test_result_folder_round_trip(tmp_path):
    img = np.full((32, 32, 3), 0.5, np.float32)
    heat = heat_overlay(img, np.linspace(0, 1, 32 * 32).reshape(32, 32))
    assert heat.shape == (32, 32, 3) and heat[-1, -1, 0] > heat[-1, -1, 2]  # hot = red/yellow
    folder = write_result(tmp_path / "r", {"target": img, "target_nopsa": img, "simulated": img,
                                           "simulated_nopsa": img, "compensability": heat},
                          {"prompt": "Make it ünïcode", "value": np.float32(1.5)})
    assert read_summary(folder)["value"] == 1.5
    assert json.loads((folder / "result.json").read_text(encoding="utf-8"))["prompt"] == "Make it ünïcode"
    assert (folder / "comparison.png").exists()
    assert np.allclose(read_result_image(folder, "target"), 0.5, atol=1 / 255)
    with pytest.raises(FileNotFoundError, match="no 'rendered' image"):
        read_result_image(folder, "rendered")
    with pytest.raises(FileNotFoundError, match="generate one first"):
        read_summary(tmp_path / "none")


def test_render_adds_its_images_to_a_result_and_leaves_the_others_alone(tmp_path):
    rng = np.random.default_rng(1)
    images = {n: rng.random((32, 32, 3)).astype(np.float32)
              for n in ("target", "target_nopsa", "simulated", "simulated_nopsa", "projector")}
    folder = write_result(tmp_path / "r", images, {"prompt": "p"})
    assert all(stored_bit_depth(folder, n) == 16 for n in images)  # float results, stored losslessly
    before = {n: (folder / f"{n}.png").read_bytes() for n in images}
    assert read_image(folder / "comparison.png").shape[1] == 2 * 256
    write_result(folder, {"rendered": images["target"], "rendered_nopsa": images["target"]},
                 {"prompt": "p", "metrics": {"rendered_psnr": 30.0}})
    assert {n: (folder / f"{n}.png").read_bytes() for n in images} == before
    assert read_summary(folder)["metrics"]["rendered_psnr"] == 30.0
    assert read_image(folder / "comparison.png").shape[1] == 3 * 256  # the sheet shows the renders too
    assert stored_bit_depth(folder, "comparison") == 8  # a sheet for people


def test_result_folder_names_keep_the_words_of_any_script():
    when = datetime.datetime(2026, 1, 2, 3, 4, 5)
    assert folder_name("Make it a Stained-Glass artwork!", when) == "20260102_030405_make_it_a_stained_glass_artwork"
    assert folder_name("桜の花びら", when) == "20260102_030405_桜の花びら"
    assert folder_name("Ｎｅｏｎ ＮＩＧＨＴ", when) == "20260102_030405_neon_night"  # NFKC: full-width letters
    assert folder_name("नमस्ते दुनिया", when) == "20260102_030405_नमस्ते_दुनिया"  # vowel signs stay
    emoji = folder_name("🌸🔥", when)
    assert emoji.startswith("20260102_030405_look_") and emoji != folder_name("🌊", when)
    assert emoji == folder_name("🌸🔥", when)


def test_new_results_never_share_a_folder_and_a_failed_one_leaves_nothing(tmp_path):
    img = np.full((8, 8, 3), 0.5, np.float32)
    folders = [write_new_result(tmp_path, "20260102_030405_look", {"target": img}, {"prompt": p}) for p in "ab"]
    assert [f.name for f in folders] == ["20260102_030405_look", "20260102_030405_look_2"]
    assert [read_summary(f)["prompt"] for f in folders] == ["a", "b"]
    with pytest.raises(ValueError, match="image"):
        write_new_result(tmp_path, "20260102_030405_bad", {"target": img, "projector": img[..., :2]}, {})
    assert sorted(p.name for p in tmp_path.iterdir()) == ["20260102_030405_look", "20260102_030405_look_2"]


def test_the_output_size_image_is_what_a_result_shows_where_it_has_one(tmp_path):
    working, native = np.full((24, 32, 3), 0.25, np.float32), np.full((48, 64, 3), 0.75, np.float32)
    folder = write_result(tmp_path / "r", {"projector": working, "target": working}, {"prompt": "p"})
    assert output_name(folder, "projector") == "projector"
    assert read_output_image(folder, "projector").shape == (24, 32, 3)
    write_result(folder, {"projector_native": native}, {"prompt": "p"})
    assert output_name(folder, "projector") == "projector_native"
    assert np.allclose(read_output_image(folder, "projector"), 0.75, atol=1e-4)
    assert output_name(folder, "target") == "target"  # per image
    # a sheet of 4:3 images has 4:3 cells
    assert read_image(folder / "comparison.png").shape[0] < 256

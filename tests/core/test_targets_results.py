# SPDX-License-Identifier: GPL-3.0-or-later
import json

import numpy as np
import pytest

from lapig_core.common.imageio import read_image
from lapig_core.export.result_files import (heat_overlay, read_result_image, read_summary, stored_bit_depth,
                                            write_result)
from lapig_core.photometric.targets import desired_targets, reachable_mask, reachable_range


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
    from lapig_core.common import metrics

    a = np.zeros((8, 8, 3), np.float32)
    b = a.copy()
    b[:4] = 1.0  # huge error only where the mask is off
    mask = np.zeros((8, 8), bool)
    mask[4:] = True
    b[4:] = 0.1
    assert metrics.masked_psnr(b, a, mask) == pytest.approx(20.0, abs=1e-4)
    assert metrics.psnr(b, a) < 5


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

# SPDX-License-Identifier: GPL-3.0-or-later
"""Several projectors (issue 36): the look jointly compensated, its result folder and the MPCDI package."""
import functools
import json

import cv2
import numpy as np
import pytest

from lapig.lapig_core.capture.settings import CaptureSettings
from lapig.tools.checks.mpcdi_read import read_mpcdi
from lapig.tools.fakes import fake_rig
from lapig.lapig_core.multi.capture import run_multi_capture
from lapig.lapig_core.multi.capture_set import load_multi_capture
from lapig.lapig_core.multi.first_look import fit_joint_first_look
from lapig.lapig_core.multi.mpcdi_export import write_rig_mpcdi

CAMERA, PROJECTOR = (96, 72), (48, 36)


@functools.lru_cache(maxsize=None)
def _captured(root):
    rig = fake_rig.side_by_side_rig(CAMERA, PROJECTOR, noise=0.002)
    s = CaptureSettings(out_dir=root, setup_name="wall", train_count=8, chunk=8)
    gen = run_multi_capture(fake_rig.FakeRigDevice(rig), s, ["left", "right"], extra_meta={"fingerprint": "f"})
    try:
        while True:
            next(gen)
    except StopIteration as done:
        cs = load_multi_capture(done.value["setup_dir"])
    return rig, cs, fit_joint_first_look(cs)


@pytest.fixture(scope="module")
def captured(tmp_path_factory):
    return _captured(str(tmp_path_factory.mktemp("multi") / "data"))


def test_the_mpcdi_package_holds_each_projectors_warp_and_an_alpha_that_sums_to_one(captured, tmp_path):
    rig, cs, look = captured
    path = write_rig_mpcdi(tmp_path / "rig.mpcdi", look.model, cs.names)
    package = read_mpcdi(path)
    assert package.profile == "2d" and [b.id for b in package.buffers] == ["left", "right"]
    alphas = []
    for buffer, camera_map in zip(package.buffers, look.model.maps):
        (region,) = buffer.regions
        assert buffer.resolution == PROJECTOR and region.resolution == PROJECTOR
        warp = package.warp(region.id)
        assert warp.shape == (36, 48, 3)
        known = ~np.isnan(warp[..., 0])
        assert known.mean() > 0.3 and np.nanmin(warp[..., :2]) >= 0 and np.nanmax(warp[..., :2]) <= 1
        # the warp sends a projector pixel to the camera pixel that sees it: back through the camera map
        ys, xs = np.nonzero(camera_map.valid)
        u = camera_map.map_x[ys, xs].round().astype(int).clip(0, PROJECTOR[0] - 1)
        v = camera_map.map_y[ys, xs].round().astype(int).clip(0, PROJECTOR[1] - 1)
        seen = warp[v, u, :2] * np.array(CAMERA)
        ok = np.isfinite(seen[:, 0])
        assert np.median(np.hypot(seen[ok, 0] - xs[ok] - 0.5, seen[ok, 1] - ys[ok] - 0.5)) < 1.5
        alphas.append(camera_map.sample(package.alpha(region.id)))
    # in camera space the alphas sum to 1 in linear light, away from the reach's edges (a projector pixel spans
    # four camera pixels there: where one frame ends, the others' alpha cannot follow within a pixel)
    inner = look.model.reached.any(axis=0)
    for valid in look.model.reached:
        edge = cv2.dilate(valid.astype(np.uint8), np.ones((7, 7), np.uint8)) > cv2.erode(valid.astype(np.uint8),
                                                                                        np.ones((7, 7), np.uint8))
        inner &= ~edge
    error = np.abs(np.sum(alphas, axis=0) - 1)[inner]
    assert np.percentile(error, 95) < 0.02, np.percentile(error, 95)


def test_an_mpcdi_path_that_cannot_be_written_is_one_line_and_keeps_the_file_there(captured, tmp_path):
    _, cs, look = captured
    blocker = tmp_path / "a file"
    blocker.write_text("not a folder")
    with pytest.raises(OSError, match="cannot write the MPCDI package") as err:
        write_rig_mpcdi(blocker / "rig.mpcdi", look.model, cs.names)
    assert "\n" not in str(err.value)
    kept = tmp_path / "rig.mpcdi"
    kept.write_bytes(b"previous")
    with pytest.raises(ValueError, match="ends in .mpcdi"):
        write_rig_mpcdi(tmp_path / "rig.zip", look.model, cs.names)
    assert kept.read_bytes() == b"previous"


@pytest.mark.torch
def test_the_look_is_jointly_compensated_and_each_projectors_frame_written(captured, tmp_path):
    from lapig.lapig_core.multi.result_files import is_multi_result, projector_images, write_joint_result
    from lapig.lapig_core.multi.stylize import PSA_NOTE, stylize_joint

    rig, cs, look = captured
    surface = cs.together.astype(np.float32) / 255
    joint = stylize_joint(look.model, surface, "Make it a stained glass artwork", "styletransfer",
                          working_size=64, object_mask=cs.object_mask)
    assert joint.target.shape == surface.shape and len(joint.frames) == 2
    assert [f.shape for f in joint.frames] == [(36, 48, 3)] * 2
    # what the rig shows of the frames is what the model predicts of them, on the object they can change, and
    # nearer the look than the surface under plain white is
    shown = rig.capture(joint.frames).astype(np.float32) / 255
    reached = look.model.reached.any(axis=0) & cs.object_mask
    assert np.median(np.abs(shown - look.model.predict(joint.frames))[reached]) < 0.03
    from lapig.lapig_core.common.metrics import masked_psnr

    assert masked_psnr(shown, joint.target, reached) > masked_psnr(surface, joint.target, reached) + 3
    folder, summary = write_joint_result(tmp_path / "results", "glass", joint, surface, cs.names, cs.sizes,
                                         {"prompt": "glass", "backend": "styletransfer"}, reached)
    assert is_multi_result(folder) and PSA_NOTE not in summary["notes"]
    saved = json.loads((folder / "result.json").read_text())
    assert [p["image"] for p in saved["projectors"]] == ["projector_1.png", "projector_2.png"]
    assert (folder / "comparison.png").is_file() and "PSA on their joint reach" in saved["summary_line"]
    # PSA ran on the joint reach, and the look without it is kept beside it, as one projector's result keeps it
    assert saved["psa"]["warm_start_steps"] > 0 and saved["metrics"]["simulated_psnr_nopsa"] is not None
    assert all((folder / f"{n}.png").is_file() for n in ("look_nopsa", "predicted_nopsa", "projector_1_nopsa",
                                                         "projector_2_nopsa"))
    images = projector_images(folder)
    assert [e["name"] for e, _ in images] == ["left", "right"] and images[1][1].shape == (36, 48, 3)


def test_problem_areas_of_several_heat_where_the_joint_capture_falls_short_of_the_look(tmp_path):
    """Problem areas of a result of several: the joint model's capture against the look, as a heat map over the
    surface, made from the folder's own images without writing into it."""
    from lapig.lapig_core.common.imageio import write_png
    from lapig.lapig_core.multi.result_files import problem_areas

    rng = np.random.default_rng(3)
    look = rng.uniform(0.2, 0.8, (24, 32, 3)).astype(np.float32)
    surface = np.full_like(look, 0.5)
    predicted = look + 0.004  # the projectors reach the look almost everywhere ...
    predicted[4:10, 20:28] -= 0.3  # ... but fall short here
    for name, image in (("look", look), ("predicted", predicted), ("surface", surface)):
        write_png(tmp_path / f"{name}.png", np.clip(image, 0, 1), bit_depth=16)
    before = {p.name: p.stat().st_mtime_ns for p in tmp_path.iterdir()}
    heat = problem_areas(tmp_path)
    assert heat.shape == look.shape
    short, fine = heat[4:10, 20:28], np.delete(heat, np.s_[2:12], axis=0)
    assert short[..., 0].min() > 0.8 and short[..., 2].max() < 0.1  # red over the shortfall
    gray = 0.5 * 0.6  # heat_overlay's dimmed surface
    assert np.abs(fine - gray).max() < 0.02  # a miss of 0.4 % beside one of 30 % is the surface
    assert {p.name: p.stat().st_mtime_ns for p in tmp_path.iterdir()} == before
    # a result that misses by 0.4 % everywhere is not painted red by its own 99th percentile: the scale's floor
    write_png(tmp_path / "predicted.png", np.clip(look + 0.004, 0, 1), bit_depth=16)
    faint = problem_areas(tmp_path)
    assert 0.03 < faint[..., 0].mean() - gray < 0.12 and faint[..., 2].max() < gray

# SPDX-License-Identifier: GPL-3.0-or-later
"""Tests for lapig_core.registration, on the synthetic rig of test_structured_light.py."""
from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

import numpy as np
import pytest

from lapig.lapig_core.capture.registration import (Registration, RegistrationError, frame_grid, supersampled_map, warp_to_projector, working_map)
from lapig.lapig_core.capture.structured_light import projector_to_camera_map

# The rig lives beside us. Reuse that module if pytest already imported it (its renders are
# cached), else load it by path, so this works whatever pytest's import mode.
_rig_file = Path(__file__).with_name("test_structured_light.py")
sl = next((m for m in list(sys.modules.values()) if getattr(m, "__file__", None) == str(_rig_file)), None)
if sl is None:
    _spec = importlib.util.spec_from_file_location("_sl_rig", _rig_file)
    sl = sys.modules.setdefault("_sl_rig", importlib.util.module_from_spec(_spec))
    _spec.loader.exec_module(sl)
PW, PH, CW, CH, MASK = sl.PW, sl.PH, sl.CW, sl.CH, sl.MASK
FW, FH = 256, 192  # the working frame of the 800x600 projector


def smooth_image(X, Y):
    return 0.5 + 0.4 * np.sin(2 * np.pi * X / 97.0) * np.cos(2 * np.pi * Y / 131.0)


@pytest.fixture(scope="module", params=[0.55, 1.5], ids=["coarse-camera", "fine-camera"])
def reg_scene(request):
    rig, view, _, dec = sl.rendered(request.param)
    reg = Registration.from_decoded(dec, PW, PH, FW, FH, supersample=2)
    cam_xy, valid = projector_to_camera_map(dec, PW, PH)
    return dict(rig=rig, view=view, reg=reg, dense=(cam_xy, valid))


def test_from_decoded_equals_from_map(reg_scene):
    reg = reg_scene["reg"]
    ref = Registration.from_map(*reg_scene["dense"], PW, PH, FW, FH, 2, camera_shape=(CH, CW))
    assert reg.camera_shape == ref.camera_shape == (CH, CW)
    for name in ("map_x", "map_y", "valid", "fine_x", "fine_y", "fine_valid"):
        assert np.array_equal(getattr(reg, name), getattr(ref, name))
    assert reg.fine_x.shape == (2 * FH, 2 * FW)


# -- grid and map sampling ------------------------------------------------------------------


def test_frame_grid_covers_the_whole_native_frame():
    xs, ys = frame_grid(800, 600, 256, 192)
    assert np.allclose(xs, (np.arange(256) + 0.5) * 800 / 256 - 0.5)
    assert np.allclose(ys, (np.arange(192) + 0.5) * 600 / 192 - 0.5)
    assert np.isclose(xs.mean(), 399.5) and np.isclose(ys.mean(), 299.5)  # centred on the frame
    assert np.isclose(xs[0] - 0.5 * 800 / 256, -0.5) and np.isclose(xs[-1] + 0.5 * 800 / 256, 799.5)  # edge to edge
    xs, ys = frame_grid(600, 800, 600, 800)  # native size: the native pixel centres
    assert np.allclose(xs, np.arange(600)) and np.allclose(ys, np.arange(800))
    with pytest.raises(ValueError):
        frame_grid(800, 600, 0, 10)


def test_working_map_is_bilinear_and_propagates_invalid():
    Y, X = np.mgrid[0:PH, 0:PW].astype(np.float64)
    cam = np.dstack([0.5 * X + 0.1 * Y + 3.0, -0.05 * X + 0.6 * Y + 7.0]).astype(np.float32)
    valid = np.ones((PH, PW), bool)
    valid[301, 401] = False
    mx, my, ok = working_map(cam, valid, PW, PH, FW, FH)
    assert mx.shape == my.shape == ok.shape == (FH, FW) and mx.dtype == np.float32
    xs, ys = frame_grid(PW, PH, FW, FH)
    gx, gy = np.meshgrid(xs, ys)
    bad = (np.abs(gx - 401) < 1) & (np.abs(gy - 301) < 1)  # footprints touching the bad pixel
    assert (ok == ~bad).all() and bad.sum() >= 1
    assert np.allclose(mx[ok], (0.5 * gx + 0.1 * gy + 3.0)[ok], atol=2e-3)
    assert np.allclose(my[ok], (-0.05 * gx + 0.6 * gy + 7.0)[ok], atol=2e-3)
    assert (mx[~ok] == -1).all()
    with pytest.raises(ValueError, match="cam_xy has shape"):
        working_map(cam[:, :-1], valid, PW, PH, FW, FH)


def test_working_map_matches_geometry(reg_scene):
    rig, reg = reg_scene["rig"], reg_scene["reg"]
    xs, ys = frame_grid(PW, PH, FW, FH)
    gx, gy = np.meshgrid(xs, ys)
    u, v = rig.forward(gx, gy)
    ex, ey = sl.solve2(rig.jacobian(gx, gy), reg.map_x - u, reg.map_y - v)
    err = np.hypot(ex, ey)[reg.valid]  # projector pixels
    assert reg.valid.mean() > 0.2
    assert np.median(err) < 0.3 and np.percentile(err, 95) < 1.0


# -- warping --------------------------------------------------------------------------------


def _expected(reg, white=0.8, black=0.05):
    xs, ys = frame_grid(PW, PH, FW, FH)
    gx, gy = np.meshgrid(xs, ys)
    return black + (white - black) * smooth_image(gx, gy)


def test_registered_smooth_image_matches(reg_scene):
    rig, view, reg = reg_scene["rig"], reg_scene["view"], reg_scene["reg"]
    Y, X = np.mgrid[0:PH, 0:PW].astype(np.float64)
    cap = rig.capture(smooth_image(X, Y), view, noise=0.003)
    cap8 = np.round(cap * 255).astype(np.uint8)
    out, ok = reg.warp(cap8, return_valid=True)
    assert out.shape == (FH, FW) and out.dtype == np.float32
    assert (out[~ok] == 0).all() and (ok <= reg.valid).all()
    err = np.abs(out - _expected(reg))[ok]
    assert ok.mean() > 0.2
    assert err.mean() < 0.01 and np.percentile(err, 99) < 0.03
    # Colour captures keep their channels; float input behaves like uint8 / 255.
    rgb = np.dstack([cap, 0.5 * cap, cap**2]).astype(np.float32)
    out3 = reg.warp(rgb)
    assert out3.shape == (FH, FW, 3)
    assert np.allclose(out3[..., 0], reg.warp(cap.astype(np.float32)), atol=1e-5)
    assert np.allclose(out3[..., 1][ok], 0.5 * out3[..., 0][ok], atol=1e-5)


def test_masked_region_comes_back_invalid(reg_scene):
    reg = reg_scene["reg"]
    xs, ys = frame_grid(PW, PH, FW, FH)
    x0, x1, y0, y1 = MASK
    cols = (xs > x0 + 2) & (xs < x1 - 2)
    rows = (ys > y0 + 2) & (ys < y1 - 2)
    assert not reg.valid[np.ix_(rows, cols)].any()
    out = reg.warp(np.ones((CH, CW), np.float32))
    assert (out[np.ix_(rows, cols)] == 0).all()


def test_supersampling_reduces_aliasing():
    """Fine camera, projector stripes one native pixel wide: a working pixel (3.1 native px)
    should see roughly their mean; point sampling (supersample=1) aliases far more."""
    rig, view, _, dec = sl.rendered(1.5)
    cam_xy, valid = projector_to_camera_map(dec, PW, PH)
    stripes = np.tile(np.arange(PW) % 2, (PH, 1)).astype(np.float64)
    cap = rig.capture(stripes, view, white=1.0, black=0.0, noise=0.0)
    spread = []
    for ss in (1, 2, 4):
        out, ok = warp_to_projector(cap, *supersampled_map(cam_xy, valid, PW, PH, FW, FH, ss), ss, return_valid=True)
        spread.append(np.std(out[ok]))
    assert spread[0] > 0.3 and spread[1] < 0.8 * spread[0] and spread[2] < 0.5 * spread[0]


# -- Registration object --------------------------------------------------------------------


def test_registration_save_load_roundtrip(reg_scene, tmp_path):
    reg = reg_scene["reg"]
    cap = np.random.default_rng(0).random((CH, CW, 3)).astype(np.float32)
    path = tmp_path / "reg.npz"
    reg.save(path)
    back = Registration.load(path)
    assert (back.proj_width, back.proj_height, back.frame_size, back.supersample) == (PW, PH, (FW, FH), 2)
    assert back.camera_shape == (CH, CW)
    assert np.array_equal(back.warp(cap), reg.warp(cap))
    assert np.array_equal(back.dense_xy, reg.dense_xy) and np.array_equal(back.dense_valid, reg.dense_valid)
    # Without cached fine maps it still works (plain remap of the working map).
    bare = Registration(PW, PH, FW, FH, reg.map_x, reg.map_y, reg.valid)
    bare.save(tmp_path / "bare.npz")
    assert np.array_equal(Registration.load(tmp_path / "bare.npz").warp(cap), bare.warp(cap))
    with pytest.raises(RegistrationError, match="no dense map"):
        bare.resized(PW, PH)


def test_a_central_square_registration_of_an_older_version_is_refused(reg_scene, tmp_path):
    reg = reg_scene["reg"]
    np.savez(tmp_path / "old.npz", proj_size=np.array([PW, PH]), size=np.array(FW), supersample=np.array(2),
             camera_shape=np.array([CH, CW]), map_x=reg.map_x, map_y=reg.map_y, valid=reg.valid)
    with pytest.raises(RegistrationError, match="central square"):
        Registration.load(tmp_path / "old.npz")


def test_resized_registers_at_native_resolution(reg_scene):
    """From the dense map, the same captures register at the projector's own pixels."""
    rig, view, reg = reg_scene["rig"], reg_scene["view"], reg_scene["reg"]
    native = reg.resized(PW, PH)
    assert native.frame_size == (PW, PH)
    assert np.array_equal(native.map_x[native.valid], reg.dense_xy[..., 0][native.valid])  # exact pixel centres
    Y, X = np.mgrid[0:PH, 0:PW].astype(np.float64)
    cap = rig.capture(smooth_image(X, Y), view, noise=0.0)
    out, ok = native.warp(cap.astype(np.float32), return_valid=True)
    assert out.shape == (PH, PW) and ok.mean() > 0.2
    expected = 0.05 + 0.75 * smooth_image(X, Y)
    assert np.median(np.abs(out - expected)[ok]) < 0.01
    # the working frame's validity is the native one, area-reduced
    assert abs(native.frame_valid.mean() - reg.frame_valid.mean()) < 0.03
    with pytest.raises(ValueError, match="finer than the projector"):
        reg.resized(PW + 4, PH)



def test_bad_inputs_raise(reg_scene):
    reg = reg_scene["reg"]
    with pytest.raises(ValueError, match="registration was made for 640x480"):
        reg.warp(np.zeros((100, 120), np.float32))
    with pytest.raises(ValueError, match="dtype"):
        reg.warp(np.zeros((CH, CW), np.int32))
    with pytest.raises(ValueError, match="must be equal 2-D shapes"):
        warp_to_projector(np.zeros((CH, CW)), reg.map_x, reg.map_y[:-1])
    with pytest.raises(ValueError, match="not a multiple of supersample"):
        warp_to_projector(np.zeros((CH, CW)), reg.map_x[:-1, :-1], reg.map_y[:-1, :-1], supersample=2)
    with pytest.raises(ValueError, match="valid_w has shape"):
        warp_to_projector(np.zeros((CH, CW)), reg.map_x, reg.map_y, reg.valid[:-1], supersample=1)
    with pytest.raises(ValueError, match="expected"):
        Registration(PW, PH, 128, 96, reg.map_x, reg.map_y, reg.valid)

# SPDX-License-Identifier: GPL-3.0-or-later
"""Tests for lapig_core.structured_light on a synthetic projector-camera pair.

The rig (also used by test_registration.py): a camera sees the projector frame through a known
smooth warp F: projector (X, Y) -> camera (u, v), a homography plus a mild non-linear term. Each
camera pixel centre is pulled back to its exact continuous projector position and point-samples
the projected image at the nearest projector pixel (floor(X + 0.5), OpenCV convention).
"""
from __future__ import annotations

import functools
from dataclasses import dataclass

import cv2
import numpy as np
import pytest

from lapig.lapig_core.capture.structured_light import (BLACK_THRESHOLD, WHITE_THRESHOLD, decode_graycode, graycode_patterns, pattern_count, projector_to_camera_map)

PW, PH = 800, 600
CW, CH = 640, 480
MASK = (450, 560, 330, 420)  # projector-space box (x0, x1, y0, y1) where the surface is missing


def solve2(J, a, b):
    """Solve J [x, y] = [a, b] for stacks of 2x2 matrices J (..., 2, 2)."""
    det = J[..., 0, 0] * J[..., 1, 1] - J[..., 0, 1] * J[..., 1, 0]
    return (J[..., 1, 1] * a - J[..., 0, 1] * b) / det, (J[..., 0, 0] * b - J[..., 1, 0] * a) / det


@dataclass
class Rig:
    scale: float  # camera px per projector px
    angle: float = 0.06
    persp: tuple = (2.5e-4, -1.5e-4)
    wobble: float = 1.5  # non-linear term, in camera px at scale 1
    mask: tuple | None = MASK

    def forward(self, X, Y):
        """Projector (X, Y) -> camera (u, v), OpenCV pixel-centre coordinates."""
        x, y = X - (PW - 1) / 2, Y - (PH - 1) / 2
        den = 1 + self.persp[0] * x + self.persp[1] * y
        c, s = np.cos(self.angle), np.sin(self.angle)
        u = self.scale * ((c * x - s * y) / den + self.wobble * np.sin(y / 90.0))
        v = self.scale * ((s * x + c * y) / den + self.wobble * np.cos(x / 110.0))
        return u + (CW - 1) / 2, v + (CH - 1) / 2

    def jacobian(self, X, Y, e=1e-3):
        ux1, vx1 = self.forward(X + e, Y)
        ux0, vx0 = self.forward(X - e, Y)
        uy1, vy1 = self.forward(X, Y + e)
        uy0, vy0 = self.forward(X, Y - e)
        return np.stack([np.stack([ux1 - ux0, uy1 - uy0], -1), np.stack([vx1 - vx0, vy1 - vy0], -1)], -2) / (2 * e)

    def inverse(self, u, v, iters=4):
        """Camera -> projector by Newton's method from the linear guess."""
        X = (u - (CW - 1) / 2) / self.scale + (PW - 1) / 2
        Y = (v - (CH - 1) / 2) / self.scale + (PH - 1) / 2
        for _ in range(iters):
            fu, fv = self.forward(X, Y)
            dX, dY = solve2(self.jacobian(X, Y), u - fu, v - fv)
            X, Y = X + dX, Y + dY
        return X, Y

    def camera_view(self):
        """Exact projector pixel seen by every camera pixel centre, and where the surface is lit."""
        v, u = np.mgrid[0:CH, 0:CW].astype(np.float64)
        X, Y = self.inverse(u, v)
        px, py = np.floor(X + 0.5).astype(np.int64), np.floor(Y + 0.5).astype(np.int64)
        lit = (px >= 0) & (px < PW) & (py >= 0) & (py < PH)
        if self.mask is not None:
            x0, x1, y0, y1 = self.mask
            lit &= ~((X >= x0) & (X < x1) & (Y >= y0) & (Y < y1))
        return np.where(lit, px, 0), np.where(lit, py, 0), lit

    def capture(self, proj_img, view, white=0.8, black=0.05, ambient=0.02, noise=0.01, rng=None):
        """Float camera image of a projector image in [0, 1] (uint8 images are scaled by 1/255)."""
        px, py, lit = view
        p = proj_img.astype(np.float64)
        if proj_img.dtype == np.uint8:
            p = p / 255.0
        img = np.where(lit, black + (white - black) * p[py, px], ambient)
        if noise:
            img = img + (rng or np.random.default_rng(0)).normal(0.0, noise, img.shape)
        return np.clip(img, 0.0, 1.0)

    def render(self, patterns, view, seed=0, as_uint8=True):
        rng = np.random.default_rng(seed)
        caps = [self.capture(p, view, rng=rng) for p in patterns]
        if as_uint8:
            caps = [np.round(c * 255).astype(np.uint8) for c in caps]
        return caps


@pytest.fixture(scope="module")
def patterns():
    return graycode_patterns(PW, PH)


@functools.lru_cache(maxsize=None)
def rendered(scale: float):
    """(rig, view, uint8 captures, decode) for the default rig at ``scale``; shared by both files."""
    rig = Rig(scale)
    view = rig.camera_view()
    caps = rig.render(graycode_patterns(PW, PH), view)
    return rig, view, caps, decode_graycode(caps, PW, PH)


@pytest.fixture(scope="module", params=[0.55, 1.5], ids=["coarse-camera", "fine-camera"])
def scene(request):
    rig, view, caps, dec = rendered(request.param)  # how fast: `bench capture`, not a timed test
    cam_xy, valid = projector_to_camera_map(dec, PW, PH)
    return dict(rig=rig, view=view, caps=caps, dec=dec, cam_xy=cam_xy, valid=valid)


def map_errors(rig, cam_xy, valid, border=3):
    """Map error converted to projector pixels, over valid pixels away from the frame border."""
    Y, X = np.mgrid[0:PH, 0:PW].astype(np.float64)
    u, v = rig.forward(X, Y)
    ex, ey = solve2(rig.jacobian(X, Y), cam_xy[..., 0] - u, cam_xy[..., 1] - v)
    err = np.hypot(ex, ey)
    inner = np.zeros_like(valid)
    inner[border:-border, border:-border] = True
    inner &= (u > border) & (u < CW - 1 - border) & (v > border) & (v < CH - 1 - border)
    return err[valid & inner], (u, v, inner)


# -- patterns -------------------------------------------------------------------------------


def test_pattern_count_and_order(patterns):
    assert len(patterns) == pattern_count(PW, PH) == 42
    assert all(p.shape == (PH, PW) and p.dtype == np.uint8 for p in patterns)
    assert (patterns[-2] == 255).all() and (patterns[-1] == 0).all()
    for k in range(0, 40, 2):  # pattern, then its complement
        assert (patterns[k].astype(int) + patterns[k + 1] == 255).all()
    # First pair: column MSB (10 bits for 800: white from column 512); then rows start at 20.
    assert (patterns[0][0, :512] == 0).all() and (patterns[0][0, 512:] == 255).all()
    assert (patterns[0] == patterns[0][:1]).all()  # column patterns are constant down a column
    assert (patterns[20][:512, 0] == 0).all() and (patterns[20][512:, 0] == 255).all()
    assert (patterns[20] == patterns[20][:, :1]).all()


@pytest.mark.parametrize("w,h", [(800, 600), (37, 23), (64, 2)])
def test_decoding_the_patterns_themselves_is_identity(w, h):
    pats = graycode_patterns(w, h)
    dec = decode_graycode(pats, w, h)
    yy, xx = np.mgrid[0:h, 0:w]
    assert dec.valid.all()
    assert (dec.proj_x == xx).all() and (dec.proj_y == yy).all()
    assert dec.proj_x.dtype == np.int32 and dec.valid.dtype == bool


# -- decoding -------------------------------------------------------------------------------


def test_decode_matches_exact_geometry(scene):
    dec, (px, py, lit) = scene["dec"], scene["view"]
    v = dec.valid
    assert v.sum() > 0.98 * lit.sum()  # almost every lit pixel decodes
    assert not (v & ~lit).any()  # nothing decodes where the projector does not reach
    exact = (dec.proj_x[v] == px[v]) & (dec.proj_y[v] == py[v])
    assert exact.mean() > 0.99
    assert (dec.proj_x[~v] == -1).all() and (dec.proj_y[~v] == -1).all()


def _compare_with_opencv(caps, dec, pixels):
    """Our decode vs GrayCodePattern.getProjPixel (+ OpenCV's shadow-mask rule) at (x, y) pixels."""
    gc = cv2.structured_light.GrayCodePattern.create(PW, PH)
    gc.setWhiteThreshold(int(WHITE_THRESHOLD))
    gc.setBlackThreshold(int(BLACK_THRESHOLD))
    n_ok = 0
    for i, j in pixels:
        err, (x, y) = gc.getProjPixel(list(caps[:-2]), int(i), int(j))
        lit = int(caps[-2][j, i]) - int(caps[-1][j, i]) > BLACK_THRESHOLD
        assert (not err and lit) == bool(dec.valid[j, i]), (i, j)
        if not err and lit:
            assert (x, y) == (dec.proj_x[j, i], dec.proj_y[j, i]), (i, j)
            n_ok += 1
    return n_ok


def test_decode_agrees_with_opencv_getprojpixel(scene):
    js, is_ = np.nonzero(scene["view"][2])
    pick = np.random.default_rng(1).choice(len(js), 120, replace=False)
    assert _compare_with_opencv(scene["caps"], scene["dec"], zip(is_[pick], js[pick])) > 110


def test_decode_agrees_with_opencv_on_random_images():
    """Random captures exercise the thresholds and out-of-frame codes (800 < 1024, 600 < 1024)."""
    rng = np.random.default_rng(2)
    caps = list(rng.integers(0, 256, (pattern_count(PW, PH), 40, 50), dtype=np.uint8))
    dec = decode_graycode(caps, PW, PH)
    assert 0 < dec.valid.mean() < 0.5
    assert _compare_with_opencv(caps, dec, [(i, j) for j in range(40) for i in range(50)]) == dec.valid.sum()


def test_decode_float_colour_and_array_inputs_agree(scene):
    ref = scene["dec"]
    caps_f = [c.astype(np.float32) / 255 for c in scene["caps"]]
    rgb = [np.repeat(c[..., None], 3, axis=2) for c in caps_f]
    for alt in (decode_graycode(caps_f, PW, PH), decode_graycode(rgb, PW, PH), decode_graycode(np.stack(caps_f), PW, PH)):
        assert (alt.valid == ref.valid).mean() > 0.9999  # float rounding at threshold ties only
        both = alt.valid & ref.valid
        assert (alt.proj_x[both] == ref.proj_x[both]).all() and (alt.proj_y[both] == ref.proj_y[both]).all()


def test_decode_rejects_bad_input(patterns):
    caps = [np.zeros((48, 64), np.uint8)] * len(patterns)
    with pytest.raises(ValueError, match="expected 42 captures"):
        decode_graycode(caps[:-1], PW, PH)
    bad = list(caps)
    bad[5] = np.zeros((48, 65), np.uint8)
    with pytest.raises(ValueError, match="capture 5 has shape"):
        decode_graycode(bad, PW, PH)
    with pytest.raises(ValueError, match="dtype"):
        decode_graycode([c.astype(np.int32) for c in caps], PW, PH)
    with pytest.raises(ValueError, match="shape"):
        decode_graycode([np.zeros((48, 64, 2), np.uint8)] * 42, PW, PH)
    with pytest.raises(ValueError, match="at least 2x2"):
        graycode_patterns(1, 600)
    with pytest.raises(ValueError, match="DecodeResult"):
        projector_to_camera_map(np.zeros((48, 64)), PW, PH)


# -- projector -> camera map ----------------------------------------------------------------


def test_map_accuracy(scene):
    cam_xy, valid = scene["cam_xy"], scene["valid"]
    assert cam_xy.shape == (PH, PW, 2) and cam_xy.dtype == np.float32 and valid.dtype == bool
    err, (u, v, inner) = map_errors(scene["rig"], cam_xy, valid)
    assert np.median(err) < 0.3
    assert np.percentile(err, 95) < 1.0
    # Coverage: projector pixels the camera sees, away from the frame and the hole, are valid.
    x0, x1, y0, y1 = MASK
    Y, X = np.mgrid[0:PH, 0:PW]
    near_hole = (X >= x0 - 4) & (X < x1 + 4) & (Y >= y0 - 4) & (Y < y1 + 4)
    seen = inner & ~near_hole
    assert valid[seen].mean() > 0.98
    assert (cam_xy[~valid] == -1).all()


def test_masked_region_is_invalid(scene):
    valid = scene["valid"]
    x0, x1, y0, y1 = MASK
    assert not valid[y0 + 2 : y1 - 2, x0 + 2 : x1 - 2].any()
    # ...and right next to the hole the map is still there.
    assert valid[y0 + 10 : y1 - 10, x0 - 4].mean() > 0.95 and valid[y0 + 10 : y1 - 10, x1 + 3].mean() > 0.95


def test_map_outside_camera_view_is_invalid(scene):
    valid = scene["valid"]
    _, (u, v, _) = map_errors(scene["rig"], scene["cam_xy"], valid)
    outside = (u < -3) | (u > CW + 2) | (v < -3) | (v > CH + 2)
    assert not valid[outside].any()


def test_map_with_a_depth_discontinuity():
    """Camera columns right of a line see the surface shifted right by 6 px (a depth step);
    the band they vacate is in the projector's shadow (dark). Near the step the map must be either
    accurate or invalid, and it must stay valid on both sides."""
    pats = graycode_patterns(PW, PH)
    rig = Rig(0.55, wobble=0.0, mask=None)
    px, py, lit = rig.camera_view()
    gap, cut = 6, CW // 2
    px2, py2, lit2 = px.copy(), py.copy(), lit.copy()
    px2[:, cut + gap :], py2[:, cut + gap :], lit2[:, cut + gap :] = px[:, cut:-gap], py[:, cut:-gap], lit[:, cut:-gap]
    lit2[:, cut : cut + gap] = False
    caps = rig.render(pats, (px2, py2, lit2))
    dec = decode_graycode(caps, PW, PH)
    cam_xy, valid = projector_to_camera_map(dec, PW, PH)
    # Ground truth: projector pixels seen right of the cut sit `gap` camera px further right.
    Y, X = np.mgrid[0:PH, 0:PW].astype(np.float64)
    u, v = rig.forward(X, Y)
    u = np.where(u >= cut - 0.5, u + gap, u)
    e = np.stack([cam_xy[..., 0] - u, cam_xy[..., 1] - v], -1) / rig.scale
    err = np.hypot(e[..., 0], e[..., 1])
    inner = np.zeros_like(valid)
    inner[3:-3, 3:-3] = True
    inner &= (u > 3) & (u < CW - 4) & (v > 3) & (v < CH - 4)
    ok = valid & inner
    assert np.percentile(err[ok], 99) < 1.5
    band = inner & (np.abs(u - cut) < 4 * gap)
    assert valid[band].mean() > 0.5  # the step does not wipe out a wide strip


def test_frame_border_is_extended_by_linear_extrapolation():
    from lapig.lapig_core.capture.structured_light import _extend_frame_border

    ys, xs = np.mgrid[0:20, 0:30].astype(np.float32)
    cam = np.stack([0.5 * xs + 0.1 * ys + 3, 0.4 * ys - 0.05 * xs + 7], -1)  # an affine map
    valid = np.ones((20, 30), bool)
    valid[0, ::3] = valid[-1, 1::4] = valid[:, 0] = False
    valid[5, 5] = False  # an interior hole stays a hole
    masked = np.where(valid[..., None], cam, -1.0)
    filled, ok = _extend_frame_border(masked, valid)
    assert ok[0].all() and ok[-1].all() and ok[:, 0].all() and not ok[5, 5]
    np.testing.assert_allclose(filled[ok], cam[ok], atol=1e-4)

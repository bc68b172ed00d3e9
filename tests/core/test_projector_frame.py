# SPDX-License-Identifier: GPL-3.0-or-later
"""The one placement of the working image in the projector frame, and its resampling."""
import cv2
import numpy as np
import pytest

from lapig.lapig_core.common.imageio import to_bit_depth
from lapig.lapig_core.common.resample import DOWNSCALE, SAME_SIZE, UPSCALE, resampling, resize_image
from lapig.lapig_core.optics.projector_model import ProjectorModel, frame_from_working_image, quantised_frame

W, H, WW, WH = 64, 48, 32, 24  # native 64x48 projector, its 32x24 working frame
S = 32  # side of the square test images


def _working(seed=0, size=S, height=None):
    return np.random.default_rng(seed).random((height or size, size, 3)).astype(np.float32)


def resize_square(img, side):
    return resize_image(img, side, side)


def _clamp_reference(img, width, height):
    """Lanczos clamped to the 2x2 bilinear footprint, gathered pixel by pixel."""
    h, w = img.shape[:2]
    sharp = cv2.resize(img, (width, height), interpolation=cv2.INTER_LANCZOS4)

    def pair(n, out):
        f = np.floor((np.arange(out) + 0.5) * n / out - 0.5).astype(int)
        return np.clip(f, 0, n - 1), np.clip(f + 1, 0, n - 1)

    (r0, r1), (c0, c1) = pair(h, height), pair(w, width)
    corners = [img[a][:, b] for a in (r0, r1) for b in (c0, c1)]
    return np.clip(sharp, np.minimum.reduce(corners), np.maximum.reduce(corners))


@pytest.mark.parametrize("w, h, width, height", [(32, 32, 48, 48), (32, 24, 64, 48), (17, 17, 100, 100),
                                                 (256, 192, 800, 600), (320, 180, 1920, 1080), (20, 30, 37, 41)])
def test_upscale_is_lanczos_clamped_to_the_bilinear_footprint(w, h, width, height):
    img = _working(1, w, h)
    np.testing.assert_array_equal(resize_image(img, width, height), _clamp_reference(img, width, height))
    assert resampling((h, w), (height, width)) == UPSCALE


def test_no_ringing_at_hard_edges_and_values_stay_in_range():
    step = np.zeros((S, S, 3), np.float32)
    step[:, S // 2:] = 1.0
    lanczos = cv2.resize(step, (100, 100), interpolation=cv2.INTER_LANCZOS4)
    assert lanczos.min() < -0.05 and lanczos.max() > 1.05  # what plain Lanczos would send
    up = resize_square(step, 100)
    assert up.min() == 0.0 and up.max() == 1.0
    # flat on both sides right up to the edge: no halo
    edge = int(np.argmax(up[50, :, 0] > 0))
    np.testing.assert_array_equal(up[:, :edge], 0.0)
    assert (up[:, edge + 4:] == 1.0).all()
    checker = (np.indices((S, S)).sum(0) % 2).astype(np.float32)
    up = resize_square(np.repeat(checker[..., None], 3, -1), 77)
    assert up.min() >= 0.0 and up.max() <= 1.0


def test_upscale_is_sharper_than_bilinear_and_not_shifted():
    x = np.arange(S)
    wave = np.tile(0.5 + 0.4 * np.cos(2 * np.pi * 0.3 * x), (S, 1)).astype(np.float32)
    img = np.repeat(wave[..., None], 3, -1)
    ours = resize_square(img, 4 * S)[S, 20:-20, 0]
    linear = cv2.resize(img, (4 * S, 4 * S), interpolation=cv2.INTER_LINEAR)[S, 20:-20, 0]
    assert np.ptp(ours) > np.ptp(linear) + 0.1  # keeps the texture's contrast
    # a linear ramp is reproduced in place: a half-pixel shift would show as a 1/64 offset
    ramp = np.linspace(0.1, 0.9, S, dtype=np.float32)
    img = np.stack([np.add.outer(ramp, ramp) / 2] * 3, axis=-1)
    linear = cv2.resize(img, (48, 48), interpolation=cv2.INTER_LINEAR)
    np.testing.assert_allclose(resize_square(img, 48)[6:-6, 6:-6], linear[6:-6, 6:-6], atol=2e-3)


def test_same_size_is_copied_and_shrinking_averages_areas():
    img = _working(2)
    same = resize_square(img, S)
    np.testing.assert_array_equal(same, img)
    assert same is not img and resampling((S, S), (S, S)) == SAME_SIZE
    big = _working(3, 96, 72)
    np.testing.assert_array_equal(resize_image(big, 48, 36), cv2.resize(big, (48, 36), interpolation=cv2.INTER_AREA))
    assert resampling((72, 96), (36, 48)) == DOWNSCALE


def test_frame_is_the_working_frame_resized_over_the_whole_native_frame():
    img = _working(4, WW, WH)
    frame = frame_from_working_image(img, W, H)
    assert frame.shape == (H, W, 3) and frame.dtype == np.float32
    np.testing.assert_array_equal(frame, resize_image(img, W, H))
    assert frame[:, :4].max() > 0 and frame[:, -4:].max() > 0  # no black bars: the whole frame is lit
    tall = frame_from_working_image(_working(4, WH, WW), H, W)  # portrait projector
    np.testing.assert_array_equal(tall, resize_image(_working(4, WH, WW), H, W))
    native = _working(6, W, H)
    np.testing.assert_array_equal(frame_from_working_image(native, W, H), native)  # already native: kept
    gray = frame_from_working_image(img[..., 0], W, H)  # (H, W) images are gray
    np.testing.assert_array_equal(gray[..., 2], frame_from_working_image(np.repeat(img[..., :1], 3, -1), W, H)[..., 2])
    wild = img * 3 - 1
    wild[0, 0] = np.nan
    assert frame_from_working_image(wild, W, H).min() >= 0 and frame_from_working_image(wild, W, H).max() <= 1


@pytest.mark.parametrize("bit_depth, dtype", [(8, np.uint8), (16, np.uint16)])
def test_quantised_frame_is_the_frame_rounded_and_the_light_is_its_light(bit_depth, dtype):
    model = ProjectorModel(W, H, gamma=2.3, black_level=0.01)
    img = _working(5, WW, WH)
    pixels = quantised_frame(img, W, H, bit_depth)
    assert pixels.dtype == dtype
    np.testing.assert_array_equal(pixels, to_bit_depth(frame_from_working_image(img, W, H), bit_depth))
    light = model.frame_light(img, bit_depth)
    np.testing.assert_array_equal(light, model.emitted(pixels))
    levels = (1 << bit_depth) - 1
    np.testing.assert_allclose(light, model.emitted(pixels.astype(np.float64) / levels), atol=1e-6)


def test_capture_frames_are_the_8bit_light():
    # the device's 8-bit lookup and the light of the quantised frame agree
    model = ProjectorModel(W, H)
    img = _working(6, WW, WH)
    np.testing.assert_array_equal(model.emitted_8bit(frame_from_working_image(img, W, H)), model.frame_light(img, 8))

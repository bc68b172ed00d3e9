"""4:2:0 chroma (issue 52): the BT.709 limited-range conversion's values, the luma correction against plain
subsampling on thin coloured lines (decoded the way FFmpeg's decoder does, bilinear), and the metrics."""
import cv2
import numpy as np

from lapig.lapig_core.export import chroma


def _decode(planes, w, h):
    """A decoder's view: bilinear chroma (centre sited), BT.709 limited range back to RGB in [0, 1]."""
    y = (planes[:h].astype(np.float32) - 16) / 219
    rest = planes[h:].reshape(-1).astype(np.float32)
    q = (h // 2) * (w // 2)
    cb = cv2.resize(((rest[:q] - 128) / 224).reshape(h // 2, w // 2), (w, h), interpolation=cv2.INTER_LINEAR)
    cr = cv2.resize(((rest[q:] - 128) / 224).reshape(h // 2, w // 2), (w, h), interpolation=cv2.INTER_LINEAR)
    r = y + 2 * (1 - chroma.KR) * cr
    b = y + 2 * (1 - chroma.KB) * cb
    g = (y - chroma.KR * r - chroma.KB * b) / chroma.KG
    return np.clip(np.stack([r, g, b], -1), 0, 1)


def test_bt709_limited_range_values():
    img = np.zeros((4, 4, 3), np.uint8)
    img[:, :2] = (255, 255, 255)
    img[:, 2:] = (255, 0, 0)
    planes = chroma.to_yuv420(img, correct_luma=False)
    assert planes.shape == (6, 4) and planes.dtype == np.uint8
    assert list(planes[0]) == [235, 235, 63, 63]  # white 235; red 16 + 219 * 0.2126
    cb, cr = planes[4:].reshape(-1)[:4], planes[4:].reshape(-1)[4:]
    assert list(cb) == [128, 102, 128, 102] and list(cr) == [128, 240, 128, 240]  # white's, then red's
    deep = chroma.to_yuv420(np.full((2, 2, 3), 65535, np.uint16), depth=10)
    assert deep.dtype == np.uint16 and deep[0, 0] == 940 and deep[2, 0] == 512


def _thin_lines(w=96, h=64):
    img = np.full((h, w, 3), 90, np.uint8)
    for k, colour in enumerate([(255, 0, 0), (0, 200, 0), (0, 0, 255), (255, 255, 0)]):
        img[6 + 14 * k, 4:-4] = colour  # one pixel high
        img[4:-4, 10 + 20 * k] = colour  # one pixel wide
    return img


def test_the_luma_correction_keeps_the_light_of_thin_coloured_lines():
    """Plain 4:2:0 keeps Y' but moves the light at colour edges (fringes); the correction keeps the luminance."""
    src = _thin_lines()
    h, w = src.shape[:2]
    plain = _decode(chroma.to_yuv420(src, correct_luma=False), w, h)
    corrected = _decode(chroma.to_yuv420(src), w, h)
    mask = chroma.edge_mask(src)
    assert 0.05 < mask.mean() < 0.5
    luminance = lambda rgb: chroma.srgb_to_linear(rgb) @ np.array([chroma.KR, chroma.KG, chroma.KB])  # noqa: E731
    target = luminance(src)
    plain_error = np.abs(luminance(plain) - target)[mask].mean()
    corrected_error = np.abs(luminance(corrected) - target)[mask].mean()
    assert corrected_error < plain_error / 5, (plain_error, corrected_error)
    assert chroma.linear_psnr(src, corrected) > chroma.linear_psnr(src, plain) + 1.0
    assert chroma.edge_psnr(src, corrected, mask, linear=True) > chroma.edge_psnr(src, plain, mask, linear=True)
    # away from the lines nothing changes
    flat = chroma.to_yuv420(src)[:h] == chroma.to_yuv420(src, correct_luma=False)[:h]
    assert flat[30:34, 90:94].all()


def test_metrics_are_infinite_for_equal_images_and_fall_with_noise():
    src = _thin_lines()
    assert chroma.linear_psnr(src, src) == float("inf") and chroma.edge_psnr(src, src) == float("inf")
    noisy = np.clip(src.astype(int) + np.random.default_rng(0).integers(-8, 9, src.shape), 0, 255).astype(np.uint8)
    assert 20 < chroma.edge_psnr(src, noisy) < 40 and 20 < chroma.linear_psnr(src, noisy) < 60

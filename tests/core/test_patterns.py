# SPDX-License-Identifier: GPL-3.0-or-later

import cv2
import numpy as np
import pytest

from lapig.lapig_core.common.imageio import write_png
from lapig.lapig_core.capture.patterns import (PatternFolderError, generate_pattern, generate_patterns, load_image_folder, reference_patterns)


@pytest.fixture(scope="module")
def set_of_100():
    return generate_patterns(100, 64, 64, seed=0)


def test_shape_dtype_range(set_of_100):
    assert set_of_100.shape == (100, 64, 64, 3)
    assert set_of_100.dtype == np.float32
    assert set_of_100.min() >= 0.0 and set_of_100.max() <= 1.0
    assert np.isfinite(set_of_100).all()


def test_deterministic_per_seed():
    a = generate_patterns(4, 48, 48, seed=7)
    b = generate_patterns(4, 48, 48, seed=7)
    c = generate_patterns(4, 48, 48, seed=8)
    assert np.array_equal(a, b)
    assert np.abs(a - c).mean() > 0.05


def test_image_k_independent_of_count():
    few = generate_patterns(3, 48, 48, seed=3)
    many = generate_patterns(9, 48, 48, seed=3)
    assert np.array_equal(few, many[:3])
    assert np.array_equal(many[6], generate_pattern(6, 48, 48, seed=3))


def test_colour_coverage(set_of_100):
    pixels = set_of_100.reshape(-1, 3)
    for channel in range(3):
        hist, _ = np.histogram(pixels[:, channel], bins=10, range=(0.0, 1.0))
        fractions = hist / hist.sum()
        assert fractions.min() > 0.03, fractions  # every tenth of the range is used
    # the corners and interior of the RGB cube are all reached
    cells = np.unique(np.minimum((pixels * 4).astype(int), 3), axis=0)
    assert len(cells) == 64


def test_variety(set_of_100):
    flat = set_of_100.reshape(100, -1)
    diffs = [np.abs(flat[i] - flat[j]).mean() for i in range(0, 100, 3) for j in range(i + 1, 100, 3)]
    assert np.mean(diffs) > 0.2
    assert min(diffs) > 0.02  # no two near-identical images
    # each image has structure, not a flat field
    assert (set_of_100.reshape(100, -1, 3).std(axis=1).mean(axis=1) > 0.03).mean() > 0.95


def test_contains_fine_detail(set_of_100):
    # strong pixel-to-pixel differences: hard edges and high frequencies exist
    gradient = np.abs(np.diff(set_of_100, axis=2)).max(axis=3)
    assert (gradient > 0.5).mean(axis=(1, 2)).max() > 0.01
    assert ((gradient > 0.3).any(axis=(1, 2))).mean() > 0.8


def test_invalid_arguments():
    with pytest.raises(ValueError):
        generate_patterns(-1)
    with pytest.raises(ValueError):
        generate_patterns(1, 4, 4)
    assert generate_patterns(0, 16, 16).shape == (0, 16, 16, 3)


def test_a_frame_pattern_is_the_centre_of_the_long_side_square():
    wide = generate_patterns(3, 64, 36, seed=4)
    assert wide.shape == (3, 36, 64, 3)
    np.testing.assert_array_equal(wide[1], generate_pattern(1, 64, 64, seed=4)[14:50])
    tall = generate_pattern(1, 36, 64, seed=4)
    np.testing.assert_array_equal(tall, generate_pattern(1, 64, 64, seed=4)[:, 14:50])


def test_load_image_folder_crops_to_the_frame_aspect(tmp_path):
    square = np.zeros((40, 40, 3), np.float32)
    square[:10] = square[30:] = (0.0, 0.0, 1.0)  # blue bands cropped away by a 2:1 frame
    square[10:30] = (1.0, 0.0, 0.0)
    write_png(tmp_path / "a.png", square)
    images = load_image_folder(tmp_path, 32, 16)
    assert images.shape == (1, 16, 32, 3)
    assert np.allclose(images[0], (1.0, 0.0, 0.0), atol=0.01)


def test_reference_patterns():
    refs = reference_patterns(16, 12, gray_level=0.25)
    assert set(refs) == {"black", "white", "gray"} and refs["gray"].shape == (12, 16, 3)
    assert refs["black"].max() == 0.0 and refs["white"].min() == 1.0
    assert np.allclose(refs["gray"], 0.25) and refs["gray"].dtype == np.float32
    with pytest.raises(ValueError):
        reference_patterns(gray_level=1.5)


def _write_raw(path, array):
    ok, data = cv2.imencode(path.suffix, array)
    assert ok
    path.write_bytes(data.tobytes())


def test_load_image_folder_formats(tmp_path):
    wide = np.zeros((40, 80, 3), np.float32)
    wide[:, 20:60] = (1.0, 0.0, 0.0)  # red centre square, blue borders cropped away
    wide[:, :20] = wide[:, 60:] = (0.0, 0.0, 1.0)
    write_png(tmp_path / "a_wide.png", wide)
    _write_raw(tmp_path / "b_gray16.png", np.full((32, 32), 65535, np.uint16))
    bgra = np.zeros((32, 32, 4), np.uint8)
    bgra[..., 1] = 255  # green
    bgra[:16, :, 3] = 255  # top half opaque, bottom transparent
    _write_raw(tmp_path / "c_alpha.png", bgra)
    _write_raw(tmp_path / "d.jpg", np.full((32, 32, 3), (255, 0, 0), np.uint8))  # BGR blue
    _write_raw(tmp_path / "e.bmp", np.full((32, 32, 3), 128, np.uint8))
    _write_raw(tmp_path / "f.tif", np.full((32, 32, 3), 64, np.uint8))
    (tmp_path / "notes.txt").write_text("ignored")

    images = load_image_folder(tmp_path, 16, 16)
    assert images.shape == (6, 16, 16, 3) and images.dtype == np.float32
    assert np.allclose(images[0], (1.0, 0.0, 0.0), atol=0.01)  # centre crop, RGB order
    assert np.allclose(images[1], 1.0)
    assert np.allclose(images[2][:6], (0.0, 1.0, 0.0), atol=0.01)
    assert np.allclose(images[2][10:], 0.0, atol=0.01)
    assert images[3][..., 2].mean() > 0.9 and images[3][..., 0].mean() < 0.1
    assert np.allclose(images[4], 128 / 255, atol=0.01)
    assert load_image_folder(tmp_path, 16, 16, count=2).shape == (2, 16, 16, 3)


def test_load_image_folder_errors(tmp_path):
    missing = tmp_path / "nowhere"
    with pytest.raises(PatternFolderError, match="nowhere"):
        load_image_folder(missing)
    (tmp_path / "readme.txt").write_text("no images here")
    with pytest.raises(PatternFolderError, match=str(tmp_path.name)):
        load_image_folder(tmp_path)
    write_png(tmp_path / "good.png", np.zeros((8, 8, 3)))
    (tmp_path / "broken.png").write_bytes(b"\x89PNG\r\n\x1a\n garbage")
    with pytest.raises(PatternFolderError, match="broken.png"):
        load_image_folder(tmp_path, 8, 8)
    with pytest.raises(PatternFolderError, match="requested"):
        load_image_folder(tmp_path, 8, 8, count=5)

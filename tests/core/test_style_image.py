"""Reading reference images for the arbitrary-style backend: bad input gets one clear line (no torch)."""
import cv2
import numpy as np
import pytest

from lapig.lapig_core.common.style_image import (MAX_SIDE, MIN_SIDE, StyleImageError, check_path, load_style_image,
                                         parse_style_image_spec, prepare_array)


def _write(path, img):
    assert cv2.imwrite(str(path), img)
    return path


def test_a_colour_png_reads_as_rgb(tmp_path):
    bgr = np.zeros((40, 50, 3), np.uint8)
    bgr[..., 2] = 255  # red in OpenCV's order
    bgr[1::2, :, 1] = 100  # stripes: not one flat colour
    out = load_style_image(_write(tmp_path / "red.png", bgr))
    assert out.image.shape == (40, 50, 3) and out.image.dtype == np.float32
    assert np.allclose(out.image[0, 0], [1, 0, 0])
    assert out.original_size == (50, 40) and out.notes == []


def test_missing_file_and_folder(tmp_path):
    with pytest.raises(StyleImageError, match="style image not found"):
        load_style_image(tmp_path / "nope.jpg")
    with pytest.raises(StyleImageError, match="is a folder"):
        load_style_image(tmp_path)
    with pytest.raises(StyleImageError, match="no style image"):
        check_path("  ")


def test_not_an_image_and_empty_file(tmp_path):
    text = tmp_path / "painting.png"
    text.write_text("this is not a picture")
    with pytest.raises(StyleImageError, match="not an image OpenCV can read"):
        load_style_image(text)
    empty = tmp_path / "empty.png"
    empty.write_bytes(b"")
    with pytest.raises(StyleImageError, match="is empty"):
        load_style_image(empty)


def test_tiny_image_is_refused(tmp_path):
    path = _write(tmp_path / "tiny.png", np.full((16, 200, 3), 128, np.uint8))
    with pytest.raises(StyleImageError, match=f"too small \\(200x16 px\\).*at least {MIN_SIDE} px"):
        load_style_image(path)


def test_huge_image_is_resized_with_a_note(tmp_path):
    img = (np.random.default_rng(0).random((1200, 2000, 3)) * 255).astype(np.uint8)
    out = load_style_image(_write(tmp_path / "huge.jpg", img))
    assert max(out.image.shape[:2]) == MAX_SIDE and out.image.shape[:2] == (614, 1024)
    assert out.original_size == (2000, 1200)
    assert any("2000x1200" in n and "resized to 1024x614" in n for n in out.notes)


def test_grayscale_is_expanded_with_a_note(tmp_path):
    gray = np.tile(np.linspace(0, 255, 64, dtype=np.uint8), (48, 1))
    out = load_style_image(_write(tmp_path / "gray.png", gray))
    assert out.image.shape == (48, 64, 3)
    assert np.allclose(out.image[..., 0], out.image[..., 2])
    assert any("grayscale" in n for n in out.notes)


def test_alpha_is_filled_with_white_and_16_bit_kept(tmp_path):
    bgra = np.zeros((40, 40, 4), np.uint8)
    bgra[..., 0] = 255  # blue, fully transparent on the left half
    bgra[:, 20:, 3] = 255
    out = load_style_image(_write(tmp_path / "alpha.png", bgra))
    assert np.allclose(out.image[0, 0], [1, 1, 1]) and np.allclose(out.image[0, 39], [0, 0, 1])
    assert any("white" in n for n in out.notes)
    deep = np.full((40, 40, 3), 30000, np.uint16)
    out = load_style_image(_write(tmp_path / "deep.png", deep))
    assert abs(float(out.image[0, 0, 0]) - 30000 / 65535) < 1e-6
    assert any("16-bit" in n for n in out.notes)


def test_arrays_from_code_and_flat_images():
    rgb = np.zeros((40, 40, 3), np.float32)
    rgb[..., 0] = 1.0
    out = prepare_array(rgb)
    assert np.allclose(out.image[0, 0], [1, 0, 0])  # RGB stays RGB
    assert any("flat colour" in n for n in out.notes)
    with pytest.raises(StyleImageError, match="layout"):
        prepare_array(np.zeros((40, 40, 5), np.float32))


def test_weight_specs():
    assert parse_style_image_spec("a.png") == ("a.png", 1.0)
    assert parse_style_image_spec(" a.png:0.3 ") == ("a.png", 0.3)
    assert parse_style_image_spec("C:\\art\\a.png") == ("C:\\art\\a.png", 1.0)
    assert parse_style_image_spec("C:\\art\\a.png:2") == ("C:\\art\\a.png", 2.0)
    assert parse_style_image_spec("odd:name.png") == ("odd:name.png", 1.0)
    with pytest.raises(StyleImageError, match="negative"):
        parse_style_image_spec("a.png:-1")

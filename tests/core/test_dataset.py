# SPDX-License-Identifier: GPL-3.0-or-later
import json
import re
import os

import cv2
import numpy as np
import pytest

from lapig.lapig_core.common import atomic
from lapig.lapig_core.capture.dataset import (PRJ_DIGEST_KEY, DatasetError, DatasetLayout, list_images, load_capture_set, projector_images_digest, setup_dir_of, summarize, write_capture, write_projector_images, write_setup_json)
from lapig.lapig_core.common.imageio import ImageReadError, read_image, to_float, to_uint8, write_png
from lapig.lapig_core.capture.patterns import generate_patterns, reference_patterns

SIZE = 32


def _fake_response(prj):
    """A plausible surface: tinted, attenuated, with an ambient floor."""
    return np.clip(0.05 + 0.8 * prj * np.array([0.9, 0.7, 0.5], np.float32), 0, 1)


def make_dataset(root, setup="desk", n_train=4, n_test=2, gray_level=0.5):
    layout = DatasetLayout(root, setup)
    refs = reference_patterns(SIZE, SIZE, gray_level)
    ref_images = [refs["black"], refs["white"], refs["gray"]]
    train = generate_patterns(n_train, SIZE, SIZE, seed=1)
    test = generate_patterns(n_test, SIZE, SIZE, seed=2)
    write_projector_images(layout, "ref", ref_images)
    write_projector_images(layout, "train", train)
    if n_test:
        write_projector_images(layout, "test", test)
    for kind, images in (("ref", ref_images), ("train", train), ("test", test)):
        for index, prj in enumerate(images, start=1):
            write_capture(layout, "raw", kind, index, np.zeros((24, 40, 3), np.uint8))
            write_capture(layout, "warp", kind, index, _fake_response(prj))
    write_setup_json(layout, {"gray_level": gray_level, "camera": {"exposure": np.float32(0.01)}})
    return layout, train, test


# -- imageio -------------------------------------------------------------------


def test_png_round_trip_8_and_16_bit(tmp_path):
    img = np.random.default_rng(0).random((5, 7, 3)).astype(np.float32)
    write_png(tmp_path / "a" / "b" / "x8.png", img)  # parents are created
    write_png(tmp_path / "x16.png", img, bit_depth=16)
    assert np.abs(read_image(tmp_path / "a" / "b" / "x8.png") - img).max() <= 0.5 / 255 + 1e-6
    assert np.abs(read_image(tmp_path / "x16.png") - img).max() <= 0.5 / 65535 + 1e-6
    raw16 = cv2.imread(str(tmp_path / "x16.png"), cv2.IMREAD_UNCHANGED)
    assert raw16.dtype == np.uint16
    assert np.array_equal(raw16[..., ::-1], (img * 65535 + 0.5).astype(np.uint16))  # stored as BGR
    with pytest.raises(ValueError):
        write_png(tmp_path / "bad.png", img, bit_depth=12)


def test_channel_order_and_conversions(tmp_path):
    red = np.zeros((2, 2, 3), np.uint8)
    red[..., 0] = 255
    write_png(tmp_path / "red.png", red)
    assert cv2.imread(str(tmp_path / "red.png"))[0, 0].tolist() == [0, 0, 255]
    assert read_image(tmp_path / "red.png")[0, 0].tolist() == [1.0, 0.0, 0.0]
    assert to_uint8(np.array([-1.0, 0.5, 2.0])).tolist() == [0, 128, 255]
    assert to_uint8(np.array([65535], np.uint16)).tolist() == [255]
    assert to_float(np.array([255], np.uint8)).dtype == np.float32


def test_read_image_errors_name_the_file(tmp_path):
    with pytest.raises(ImageReadError, match="missing.png"):
        read_image(tmp_path / "missing.png")
    corrupt = tmp_path / "corrupt.png"
    corrupt.write_bytes(b"not a png at all")
    with pytest.raises(ImageReadError, match="corrupt.png"):
        read_image(corrupt)
    empty = tmp_path / "empty.png"
    empty.write_bytes(b"")
    with pytest.raises(ImageReadError, match="empty.png"):
        read_image(empty)


def test_atomic_write_leaves_no_temp_files(tmp_path, monkeypatch):
    target = tmp_path / "img_0001.png"
    write_png(target, np.ones((4, 4, 3)))
    write_png(target, np.zeros((4, 4, 3)))  # overwrite in place
    assert [p.name for p in tmp_path.iterdir()] == ["img_0001.png"]

    def full_disk(*_args):
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(atomic.os, "replace", full_disk)
    with pytest.raises(OSError):
        write_png(target, np.ones((4, 4, 3)))
    with pytest.raises(OSError):
        write_png(tmp_path / "img_0002.png", np.ones((4, 4, 3)))
    monkeypatch.undo()
    assert [p.name for p in tmp_path.iterdir()] == ["img_0001.png"]  # no temp, no partial file
    assert read_image(target).max() == 0.0  # previous content intact


# -- layout and writing ------------------------------------------------------------


def test_layout_paths(tmp_path):
    layout = DatasetLayout(tmp_path, "s1")
    assert layout.prj_dir("train") == tmp_path / "prj" / "train"
    assert layout.cam_raw_dir("sl") == tmp_path / "setups" / "s1" / "cam" / "raw" / "sl"
    assert layout.cam_warp_dir("cmp") == tmp_path / "setups" / "s1" / "cam" / "warp" / "cmp"
    assert layout.prj_setup_dir("sl") == tmp_path / "setups" / "s1" / "prj" / "sl"
    assert layout.setup_json == tmp_path / "setups" / "s1" / "setup.json"
    assert layout.image_path(layout.prj_dir("ref"), 3).name == "img_0003.png"
    with pytest.raises(DatasetError):
        layout.cam_warp_dir("sl")  # structured light is never warped
    with pytest.raises(DatasetError):
        layout.image_path(tmp_path, 0)
    with pytest.raises(DatasetError):
        DatasetLayout(tmp_path, "../escape")


def test_the_setup_folder_rule(tmp_path):
    layout = DatasetLayout(tmp_path, "s1")
    assert DatasetLayout.of_setup_dir(layout.setup_dir) == layout
    assert setup_dir_of(layout) == tmp_path  # no setups/ yet: the root holds the setup's files
    layout.setup_dir.mkdir(parents=True)
    assert setup_dir_of(layout) == layout.setup_dir


def test_write_projector_images_routes_and_trims(tmp_path):
    layout = DatasetLayout(tmp_path, "s1")
    write_projector_images(layout, "sl", np.zeros((3, 8, 12, 3), np.uint8))
    assert [p.name for p in list_images(layout.prj_setup_dir("sl"))] == ["img_0001.png", "img_0002.png", "img_0003.png"]
    write_projector_images(layout, "sl", np.zeros((2, 8, 12, 3), np.uint8))
    assert len(list_images(layout.prj_setup_dir("sl"))) == 2  # stale img_0003 removed
    assert read_image(layout.image_path(layout.prj_setup_dir("sl"), 1)).shape == (8, 12, 3)


def test_setup_json_atomic_and_numpy_friendly(tmp_path):
    layout = DatasetLayout(tmp_path, "s1")
    write_setup_json(layout, {"gray_level": np.float64(0.4), "size": np.array([256, 256])})
    assert json.loads(layout.setup_json.read_text()) == {"gray_level": 0.4, "size": [256, 256]}
    assert [p.name for p in layout.setup_dir.iterdir()] == ["setup.json"]
    with pytest.raises(DatasetError):
        write_setup_json(layout, ["not", "a", "dict"])


# -- loading -------------------------------------------------------------------------


def test_round_trip(tmp_path):
    layout, train, test = make_dataset(tmp_path)
    for path in (tmp_path, layout.setup_dir):  # dataset root or setup folder
        cs = load_capture_set(path)
        assert cs.setup == "desk" and cs.root == tmp_path
        assert cs.prj_train.shape == cs.cam_train.shape == (4, SIZE, SIZE, 3)
        assert cs.prj_test.shape == cs.cam_test.shape == (2, SIZE, SIZE, 3)
        assert cs.prj_train.dtype == cs.cam_train.dtype == np.float32
        assert np.abs(cs.prj_train - train).max() <= 0.5 / 255 + 1e-6
        assert np.abs(cs.cam_test - _fake_response(test)).max() <= 0.5 / 255 + 1e-6
        assert np.allclose(cs.cam_black, 0.05, atol=0.003)
        assert np.allclose(cs.cam_white, [0.77, 0.61, 0.45], atol=0.003)
        assert cs.gray_level == 0.5 and cs.meta["camera"]["exposure"] == pytest.approx(0.01)
        assert cs.has_test
    resized = load_capture_set(tmp_path, frame=(16, 12))
    assert resized.cam_train.shape == (4, 12, 16, 3) and resized.cam_gray.shape == (12, 16, 3)
    # a public square set: one aspect among others, said so; no registration, nothing masked
    assert cs.frame_size == (SIZE, SIZE) and cs.projector_valid is None
    text = summarize(cs)
    assert "desk" in text and "4 training pairs" in text and "2 test pairs" in text and "32x32" in text
    assert "aspect 1.000" in text


def test_test_set_optional_and_gray_level_fallback(tmp_path):
    layout, _, _ = make_dataset(tmp_path, n_test=0)
    layout.setup_json.unlink()  # public datasets have no setup.json
    cs = load_capture_set(tmp_path)
    assert cs.prj_test.shape == (0, SIZE, SIZE, 3) and cs.cam_test.shape[0] == 0
    assert not cs.has_test and "no test set" in summarize(cs)
    assert cs.gray_level == pytest.approx(128 / 255) and cs.meta == {}


def test_error_missing_folders(tmp_path):
    with pytest.raises(DatasetError, match="not found"):
        load_capture_set(tmp_path / "nothing")
    with pytest.raises(DatasetError, match="neither"):
        load_capture_set(tmp_path)
    layout, _, _ = make_dataset(tmp_path)
    for image in list_images(layout.cam_warp_dir("ref")):
        image.unlink()
    layout.cam_warp_dir("ref").rmdir()
    with pytest.raises(DatasetError, match="reference") as info:
        load_capture_set(tmp_path)
    assert str(layout.cam_warp_dir("ref")) in str(info.value)


def test_error_several_setups(tmp_path):
    make_dataset(tmp_path, setup="a")
    (tmp_path / "setups" / "b").mkdir()
    with pytest.raises(DatasetError, match="2 setups"):
        load_capture_set(tmp_path)
    assert load_capture_set(tmp_path / "setups" / "a").setup == "a"


def test_error_count_mismatch(tmp_path):
    layout, _, _ = make_dataset(tmp_path)
    list_images(layout.cam_warp_dir("train"))[-1].unlink()
    with pytest.raises(DatasetError) as info:
        load_capture_set(tmp_path)
    message = str(info.value)
    assert "4" in message and "3" in message
    assert str(layout.prj_dir("train")) in message and str(layout.cam_warp_dir("train")) in message


def test_error_gap_in_numbering(tmp_path):
    layout, _, _ = make_dataset(tmp_path)
    os.remove(layout.image_path(layout.cam_warp_dir("train"), 2))
    with pytest.raises(DatasetError, match="img_0002.png"):
        list_images(layout.cam_warp_dir("train"))
    with pytest.raises(DatasetError, match="img_0002.png"):
        load_capture_set(tmp_path)


def test_error_corrupt_png_names_file(tmp_path):
    layout, _, _ = make_dataset(tmp_path)
    bad = layout.image_path(layout.cam_warp_dir("train"), 3)
    bad.write_bytes(bad.read_bytes()[:40])  # truncated
    with pytest.raises(DatasetError, match=re.escape(str(bad))):
        load_capture_set(tmp_path)


def test_error_size_mismatch(tmp_path):
    layout, _, _ = make_dataset(tmp_path)
    odd = layout.image_path(layout.cam_warp_dir("train"), 2)
    write_png(odd, np.zeros((SIZE, SIZE + 8, 3)))
    with pytest.raises(DatasetError, match="img_0002.png") as info:
        load_capture_set(tmp_path)
    assert "cam" in str(info.value) and "40x32" in str(info.value)
    assert load_capture_set(tmp_path, frame=(SIZE, SIZE)).cam_train.shape == (4, SIZE, SIZE, 3)


def test_error_bad_setup_json(tmp_path):
    layout, _, _ = make_dataset(tmp_path)
    layout.setup_json.write_text("{not json")
    with pytest.raises(DatasetError, match="setup.json"):
        load_capture_set(tmp_path)
    layout.setup_json.write_text(json.dumps({"gray_level": 3}))
    with pytest.raises(DatasetError, match="gray_level"):
        load_capture_set(tmp_path)


def test_projector_images_that_changed_since_the_capture_are_refused(tmp_path):
    layout, _, _ = make_dataset(tmp_path)
    write_setup_json(layout, {"gray_level": 0.5, PRJ_DIGEST_KEY: projector_images_digest(tmp_path)})
    assert load_capture_set(tmp_path).setup == "desk"
    write_png(layout.image_path(layout.prj_dir("train"), 2), np.zeros((SIZE, SIZE, 3)))  # another capture's
    with pytest.raises(DatasetError, match="not the ones setup 'desk' was captured with"):
        load_capture_set(tmp_path)
    write_setup_json(layout, {"gray_level": 0.5})  # public data sets record no digest: trusted
    assert load_capture_set(tmp_path).setup == "desk"


def test_partial_writes_that_a_kill_left_are_removed(tmp_path):
    target = tmp_path / "pcnet.pt"
    target.write_bytes(b"good")
    for name in (".pcnet.pt.abc123.tmp", ".pcnet.pt.x_y.tmp"):  # killed between write and rename
        (tmp_path / name).write_bytes(b"half")
    (tmp_path / ".compennest.pt.abc123.tmp").write_bytes(b"another file's")
    atomic.remove_partial_writes(target)
    assert sorted(p.name for p in tmp_path.iterdir()) == [".compennest.pt.abc123.tmp", "pcnet.pt"]

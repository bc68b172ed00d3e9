# SPDX-License-Identifier: GPL-3.0-or-later
"""Export of projector images: the placed frame's pixels, PNG bit depths, sidecars, atomic writes, crossfades.

The placement and its resampling are tested in test_projector_frame.py; here, that the file holds
exactly its pixels and that the light Blender emits is those pixels' light.
"""
import datetime as dt
import json

import cv2
import numpy as np
import pytest

from lapig.lapig_core.common import atomic
from lapig.lapig_core.export.projector_image import ExportError, crossfade_sequence, export_projector_image
from lapig.lapig_core.export.result_files import read_result_image, stored_bit_depth, write_result
from lapig.lapig_core.common.imageio import to_bit_depth, to_float, to_uint8, to_uint16, write_png
from lapig.lapig_core.common.resample import SAME_SIZE, UPSCALE
from lapig.lapig_core.optics.projector_model import ProjectorModel, frame_from_working_image, quantised_frame

W, H, WW, WH = 64, 48, 32, 24  # native 64x48 projector, its 32x24 working frame


def _working(seed=0, width=WW, height=WH):
    return np.random.default_rng(seed).random((height, width, 3)).astype(np.float32)


def _read(path):
    """Raw pixels as stored (BGR, uint8/uint16); np.fromfile so non-ASCII paths work."""
    img = cv2.imdecode(np.fromfile(str(path), np.uint8), cv2.IMREAD_UNCHANGED)
    assert img is not None, path
    return img


def _files(folder):
    return sorted(p.name for p in folder.iterdir())


def _gradient(width, height):
    """A smooth two-colour gradient with far more than 256 levels, and its extremes."""
    y, x = np.linspace(0.0, 1.0, height, dtype=np.float64), np.linspace(0.0, 1.0, width, dtype=np.float64)
    img = np.stack([np.add.outer(y, x) / 2, np.add.outer(y, 1 - x) / 2, np.outer(y, x) ** 0.5], -1)
    return img.astype(np.float32)


# ----------------------------------------------------------------------------- exact pixels


def test_16bit_export_without_resampling_keeps_the_float_values(tmp_path):
    img = _gradient(400, 300)  # an image at the native size (native output): not resampled
    out = export_projector_image(tmp_path / "g", img, 400, 300, bit_depth=16)
    raw = _read(out["image"])[:, :, ::-1]
    assert len(np.unique(raw)) > 5000  # not 8-bit data in a 16-bit file (no resampling made levels)
    error = np.abs(raw / 65535.0 - img).max()
    assert error <= 2 / 65535, error
    assert json.loads(out["sidecar"].read_text())["image"]["resampling"] == SAME_SIZE


def test_stored_result_exports_its_float_values_at_16_bits(tmp_path):
    img = _gradient(400, 300)
    folder = write_result(tmp_path / "r", {"projector": img}, {"prompt": "gradient"})
    assert stored_bit_depth(folder, "projector") == 16
    stored = read_result_image(folder, "projector")
    assert np.abs(stored - img).max() <= 0.5 / 65535 + 1e-7
    out = export_projector_image(tmp_path / "x", stored, 400, 300, bit_depth=16)
    error = np.abs(_read(out["image"])[:, :, ::-1] / 65535.0 - img).max()
    assert error <= 2 / 65535, error
    # reading and writing a result again changes nothing (Render Real Capture adds to a folder)
    before = (folder / "projector.png").read_bytes()
    write_png(folder / "projector.png", stored, bit_depth=16)
    assert (folder / "projector.png").read_bytes() == before


@pytest.mark.parametrize("bit_depth", [8, 16])
def test_exported_file_is_the_placed_frame_and_the_light_is_its_light(tmp_path, bit_depth):
    model = ProjectorModel(W, H, gamma=2.4, black_level=0.01)
    folder = write_result(tmp_path / "r", {"projector": _working(7)}, {})
    result = read_result_image(folder, "projector")  # what export, light and render all start from
    out = export_projector_image(tmp_path / "p", result, W, H, bit_depth=bit_depth)
    decoded = _read(out["image"])[:, :, ::-1]
    np.testing.assert_array_equal(decoded, to_bit_depth(frame_from_working_image(result, W, H), bit_depth))
    np.testing.assert_array_equal(decoded, quantised_frame(result, W, H, bit_depth))
    # the Blender light (result_preview.set_projector_image) and Render Real Capture emit this
    np.testing.assert_array_equal(model.frame_light(result, bit_depth), model.emitted(decoded))
    np.testing.assert_array_equal(model.emitted(decoded), model.emitted(to_float(decoded)))
    assert json.loads(out["sidecar"].read_text())["image"]["resampling"] == UPSCALE


def test_old_8bit_result_folder_is_read_as_it_is(tmp_path):
    folder = tmp_path / "old"
    img = _working(8)
    write_png(folder / "projector.png", img)  # results before 16-bit storage
    (folder / "result.json").write_text("{}")
    assert stored_bit_depth(folder, "projector") == 8
    stored = read_result_image(folder, "projector")
    np.testing.assert_allclose(stored, to_uint8(img) / 255.0, atol=1e-7)
    out = export_projector_image(tmp_path / "x", stored, W, H, bit_depth=16)
    np.testing.assert_array_equal(_read(out["image"])[:, :, ::-1], quantised_frame(stored, W, H, 16))
    (folder / "projector.png").write_bytes(b"not a png at all, 25 bytes or more")
    with pytest.raises(OSError, match="not a PNG"):
        stored_bit_depth(folder, "projector")


# ----------------------------------------------------------------------------- PNG + sidecar


@pytest.mark.parametrize("bit_depth, dtype, conv", [(8, np.uint8, to_uint8), (16, np.uint16, to_uint16)])
def test_png_round_trip(tmp_path, bit_depth, dtype, conv):
    img = _working(3)
    img[0, 0] = [1.0, 0.0, 0.0]  # red corner: checks RGB order in the file
    out = export_projector_image(tmp_path / "frame", img, W, H, bit_depth=bit_depth, metadata={})
    assert out == {"image": tmp_path / "frame.png", "sidecar": tmp_path / "frame.json"}
    raw = _read(out["image"])
    assert raw.dtype == dtype and raw.shape == (H, W, 3)
    expected = conv(frame_from_working_image(img, W, H))
    np.testing.assert_array_equal(raw[:, :, ::-1], expected)  # file is BGR, we speak RGB
    assert _files(tmp_path) == ["frame.json", "frame.png"]  # no temp files left


def test_red_is_stored_as_red(tmp_path):
    red = np.zeros((WH, WW, 3), np.float32)
    red[..., 0] = 1.0
    export_projector_image(tmp_path / "red.png", red, W, H)
    raw = _read(tmp_path / "red.png")
    assert tuple(raw[H // 2, W // 2]) == (0, 0, 255)  # BGR on disk


def test_sidecar_content_and_numpy_conversion(tmp_path):
    model = ProjectorModel(W, H, gamma=2.4)
    meta = {
        "prompt": "a marble statue",
        "backend": "lgst",
        "seed": np.int64(7),
        "psa": {"iterations": np.int32(200), "lr": np.float32(0.05), "enabled": np.bool_(True)},
        "metrics": {"psnr": np.float64(31.5), "ssim": float("nan"), "curve": np.array([1.0, np.nan, np.inf])},
        "projector": model,
        "camera": {"matrix": np.eye(3)},
        "big": np.zeros((100, 100)),
        "software": {"blender": "4.2.0"},
    }
    out = export_projector_image(tmp_path / "out.png", _working(), W, H, bit_depth=16, metadata=meta,
                                 lapig_version="0.1.0")
    text = out["sidecar"].read_text(encoding="utf-8")
    assert "NaN" not in text and "Infinity" not in text
    side = json.loads(text)
    assert side["prompt"] == "a marble statue" and side["backend"] == "lgst" and side["seed"] == 7
    assert side["psa"] == {"iterations": 200, "lr": pytest.approx(0.05), "enabled": True}
    assert side["metrics"]["ssim"] is None and side["metrics"]["curve"] == [1.0, None, None]
    assert side["projector"]["gamma"] == 2.4 and side["projector"]["width"] == W
    assert side["camera"]["matrix"] == np.eye(3).tolist()
    assert side["big"] == {"shape": [100, 100], "dtype": "float64", "min": 0.0, "max": 0.0, "mean": 0.0}
    sw = side["software"]
    assert sw["lapig"] == "0.1.0" and sw["blender"] == "4.2.0"  # ours merged with the caller's
    assert sw["numpy"] == np.__version__ and sw["opencv"] == cv2.__version__ and "python" in sw
    assert side["image"] == {
        "file": "out.png", "width": W, "height": H, "bit_depth": 16, "channels": "RGB",
        "working_frame": [WW, WH], "resampling": UPSCALE,
    }
    created = dt.datetime.fromisoformat(side["created"].replace("Z", "+00:00"))
    assert created.utcoffset() == dt.timedelta(0)
    assert abs((dt.datetime.now(dt.timezone.utc) - created).total_seconds()) < 60


def test_non_ascii_path(tmp_path):
    folder = tmp_path / "Projektion ü 投影"
    folder.mkdir()
    out = export_projector_image(folder / "статуя_é.png", _working(), W, H, metadata={"prompt": "café 雕像"})
    assert out["image"].is_file() and out["sidecar"].name == "статуя_é.json"
    assert _read(out["image"]).shape == (H, W, 3)
    assert json.loads(out["sidecar"].read_text(encoding="utf-8"))["prompt"] == "café 雕像"
    assert _files(folder) == ["статуя_é.json", "статуя_é.png"]


# ----------------------------------------------------------------------------- errors


@pytest.mark.parametrize("kwargs, message", [
    ({"bit_depth": 12}, "bit depth must be 8 or 16"),
    ({"bit_depth": True}, "bit depth must be 8 or 16"),
    ({"working_image": np.zeros(5)}, "image array"),
    ({"working_image": np.zeros((4, 4, 4))}, "image array"),
    ({"working_image": np.array([["a", "b"], ["c", "d"]])}, "unsupported pixel type"),
    ({"working_image": np.zeros((32, 32, 3))}, r"32x32 \(aspect 1.000\) but the projector is 64x48"),
    ({"width": 0}, "width"),
    ({"metadata": [1, 2]}, "metadata must be a dict"),
])
def test_bad_inputs_raise_export_error(tmp_path, kwargs, message):
    args = {"out_path": tmp_path / "x.png", "working_image": _working(), "width": W, "height": H,
            "bit_depth": 8, "metadata": {}, **kwargs}
    with pytest.raises(ExportError, match=message):
        export_projector_image(**args)
    assert _files(tmp_path) == []
    assert issubclass(ExportError, ValueError)


def test_missing_or_unusable_folder_is_named(tmp_path, monkeypatch):
    missing = tmp_path / "nope"
    with pytest.raises(ExportError, match="does not exist") as err:
        export_projector_image(missing / "x.png", _working(), W, H)
    assert str(missing) in str(err.value)
    (tmp_path / "file").write_text("")
    with pytest.raises(ExportError, match="not a folder"):
        export_projector_image(tmp_path / "file" / "x.png", _working(), W, H)

    def denied(*a, **k):  # tests may run as root, where chmod does not stop writes
        raise PermissionError(13, "Permission denied")

    monkeypatch.setattr(atomic.tempfile, "mkstemp", denied)
    with pytest.raises(ExportError, match="permission denied") as err:
        export_projector_image(tmp_path / "x.png", _working(), W, H)
    assert str(tmp_path) in str(err.value)


@pytest.mark.parametrize("fail_on_call", [1, 2])  # 1: the sidecar fails, 2: the PNG fails
def test_full_disk_leaves_no_files(tmp_path, monkeypatch, fail_on_call):
    calls = []

    def write_half_then_fail(handle, data):
        calls.append(1)
        if len(calls) == fail_on_call:
            handle.write(data[: len(data) // 2])
            raise OSError(28, "No space left on device")
        handle.write(data)

    monkeypatch.setattr(atomic, "write_all", write_half_then_fail)
    with pytest.raises(ExportError, match="disk may be full") as err:
        export_projector_image(tmp_path / "x.png", _working(), W, H, metadata={"seed": 1})
    assert isinstance(err.value.__cause__, OSError)
    assert _files(tmp_path) == []


def test_full_disk_keeps_previous_export(tmp_path, monkeypatch):
    out = export_projector_image(tmp_path / "x.png", _working(0), W, H, metadata={"seed": 1})
    before = out["image"].read_bytes(), out["sidecar"].read_bytes()

    def fail(handle, data):
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(atomic, "write_all", fail)
    with pytest.raises(ExportError):
        export_projector_image(tmp_path / "x.png", _working(1), W, H, metadata={"seed": 2})
    assert (out["image"].read_bytes(), out["sidecar"].read_bytes()) == before
    assert _files(tmp_path) == ["x.json", "x.png"]


# ----------------------------------------------------------------------------- crossfade


def test_crossfade_endpoints_middle_and_sidecar(tmp_path):
    a, b = _working(4), _working(5)
    paths = crossfade_sequence(tmp_path / "seq", a, b, 5, width=W, height=H, name="fade",
                               source_labels=("statue", "marble"), metadata={"seed": np.int64(3)})
    assert [p.name for p in paths] == [f"fade_000{i}.png" for i in range(1, 6)]
    frames = [_read(p)[:, :, ::-1].astype(np.int32) for p in paths]
    fa = quantised_frame(a, W, H, 8).astype(np.int32)
    fb = quantised_frame(b, W, H, 8).astype(np.int32)
    np.testing.assert_array_equal(frames[0], fa)  # the ends are the images' exports, bit for bit
    np.testing.assert_array_equal(frames[-1], fb)
    mid = frames[2]
    assert (mid >= np.minimum(fa, fb) - 1).all() and (mid <= np.maximum(fa, fb) + 1).all()
    # halfway in projector light, not in pixel values
    g = 2.2
    light = (mid / 255.0) ** g
    expected = 0.5 * ((fa / 255.0) ** g + (fb / 255.0) ** g)
    assert np.abs(light - expected).max() < 0.01
    side = json.loads((tmp_path / "seq" / "fade.json").read_text(encoding="utf-8"))
    cf = side["crossfade"]
    assert cf["frames"] == 5 and cf["ease"] == "linear" and cf["gamma"] == 2.2
    assert cf["weights"] == [0.0, 0.25, 0.5, 0.75, 1.0] and cf["files"][0] == "fade_0001.png"
    assert [s["label"] for s in side["sources"]] == ["statue", "marble"]
    assert side["sources"][0] == {"label": "statue", "input_size": [WH, WW], "resampling": UPSCALE}
    assert side["seed"] == 3 and "created" in side and "software" in side
    assert _files(tmp_path / "seq") == ["fade.json"] + [p.name for p in paths]


def test_crossfade_smooth_ease_is_monotonic_and_native_frames_pass_through(tmp_path):
    a = np.zeros((H, W, 3), np.float32)  # native-size inputs are used as they are
    b = np.ones((H, W, 3), np.float32)
    paths = crossfade_sequence(tmp_path, a, b, 9, width=W, height=H, ease="smooth", bit_depth=16)
    values = np.array([_read(p)[H // 2, 3, 0] for p in paths], dtype=np.int64)
    assert _read(paths[0]).dtype == np.uint16
    assert values[0] == 0 and values[-1] == 65535
    assert (np.diff(values) > 0).all()
    light = (values / 65535.0) ** 2.2  # the ease shapes the light, which is what is blended
    steps = np.diff(light)
    assert steps[0] < steps[3] and steps[-1] < steps[4]  # eases in and out
    ease = 3 * np.linspace(0, 1, 9) ** 2 - 2 * np.linspace(0, 1, 9) ** 3
    np.testing.assert_allclose(light, ease, atol=1e-4)
    side = json.loads((tmp_path / "crossfade.json").read_text(encoding="utf-8"))
    assert side["sources"][0]["resampling"] == SAME_SIZE and side["crossfade"]["ease"] == "smooth"


def test_crossfade_validation_and_cleanup(tmp_path, monkeypatch):
    a, b = _working(4), _working(5)
    with pytest.raises(ExportError, match="at least 2 frames"):
        crossfade_sequence(tmp_path, a, b, 1, width=W, height=H)
    with pytest.raises(ExportError, match="ease"):
        crossfade_sequence(tmp_path, a, b, 3, width=W, height=H, ease="bounce")
    with pytest.raises(ExportError, match="bit depth"):
        crossfade_sequence(tmp_path, a, b, 3, width=W, height=H, bit_depth=10)
    with pytest.raises(ExportError, match="plain file name"):
        crossfade_sequence(tmp_path, a, b, 3, width=W, height=H, name="../x")
    with pytest.raises(ExportError, match="does not exist"):
        crossfade_sequence(tmp_path / "a" / "b", a, b, 3, width=W, height=H)
    with pytest.raises(ExportError, match="cannot cover the projector.s frame"):
        crossfade_sequence(tmp_path, a, np.zeros((10, 20, 3)), 3, width=W, height=H)
    assert _files(tmp_path) == []

    calls = []

    def fail_third(handle, data):
        calls.append(1)
        if len(calls) == 3:
            raise OSError(28, "No space left on device")
        handle.write(data)

    monkeypatch.setattr(atomic, "write_all", fail_third)
    with pytest.raises(ExportError, match="disk may be full"):
        crossfade_sequence(tmp_path, a, b, 4, width=W, height=H)
    assert _files(tmp_path) == []

"""Video export of a show (issue 38, 52): codecs, round trips through OpenCV (RGB codecs: it ignores the colour tags)
and PyAV (which honours them), frame lock, cancel, bad input. tests/core/test_video_ffprobe.py checks the files
with the system's ffprobe and ffmpeg."""
import json
import shutil
import threading
from fractions import Fraction

import numpy as np
import pytest

av = pytest.importorskip("av")

from lapig.lapig_core.export import codecs, video  # noqa: E402
from lapig.lapig_core.export.show_output import Cancelled  # noqa: E402
from lapig.lapig_core.export.projector_image import ExportError  # noqa: E402
from lapig.lapig_core.export.video import write_video  # noqa: E402
from lapig.tools.checks.video_read import decode_with_opencv as _decode_cv2  # noqa: E402

W, H = 128, 96  # H.265 at 64x64 still crashes now and then (tools/research/x265_small_frames)


def _frames(n=6, w=W, h=H):
    """Smooth gradients with a moving block and a little texture, float32 in [0, 1] (8-bit exact)."""
    yy, xx = np.mgrid[0:h, 0:w].astype(np.float32)
    rng = np.random.default_rng(1)
    texture = rng.integers(0, 24, (h, w, 3)).astype(np.float32)
    out = []
    for i in range(n):
        f = np.stack([xx / w * 200 + 20, yy / h * 180 + 40, (xx + yy) / (w + h) * 150 + 60 + 10 * i], -1)
        f = f + texture
        f[8:20, 4 + 6 * i:16 + 6 * i] = (230, 30, 40)
        out.append((np.round(np.clip(f, 0, 255)) / 255).astype(np.float32))
    return out


def _u8(frame):
    return np.round(frame * 255).astype(np.uint8)


def _psnr(a, b):
    mse = np.mean((a.astype(np.float64) - b.astype(np.float64)) ** 2)
    return float("inf") if mse == 0 else 10 * np.log10(255 ** 2 / mse)


def _decode_av(path):
    with av.open(str(path)) as container:
        stream = container.streams.video[0]
        rate = stream.average_rate
        return [f.to_ndarray(format="rgb24") for f in container.decode(stream)], rate


def test_lossless_round_trips_exactly_through_opencv_and_pyav(tmp_path):
    frames = _frames(5, 65, 49)  # odd sizes
    out = write_video(frames, tmp_path / "show", 30, (65, 49), "lossless")
    assert out["video"].name == "show.mov" and out["frames"] == 5
    decoded, fps = _decode_cv2(out["video"])
    assert len(decoded) == 5 and abs(fps - 30) < 1e-6
    for src, got in zip(frames, decoded):
        assert got.shape == (49, 65, 3)
        assert np.array_equal(_u8(src), got)
    decoded_av, rate = _decode_av(out["video"])
    assert rate == 30 and all(np.array_equal(_u8(s), g) for s, g in zip(frames, decoded_av))


@pytest.mark.parametrize("intra_only", [False, True])
def test_h264_444_is_high_quality_and_frame_locked(tmp_path, intra_only):
    frames = _frames(6)
    out = write_video(iter(frames), tmp_path / "show.mp4", 29.97, (W, H), "h264-444", frame_count=6,
                      intra_only=intra_only)
    decoded_av, rate = _decode_av(out["video"])
    assert rate == Fraction(30000, 1001) and len(decoded_av) == 6
    assert min(_psnr(_u8(s), g) for s, g in zip(frames, decoded_av)) >= 40.0
    if intra_only:
        with av.open(str(out["video"])) as container:
            assert all(p.is_keyframe for p in container.demux(video=0) if p.size)
    side = json.loads(out["sidecar"].read_text())
    assert side["video"]["frame_count"] == 6 and side["video"]["fps_rational"] == "30000/1001"
    assert side["video"]["pixel_format"] == "yuv444p" and side["video"]["every_frame_keyframe"] is intra_only
    assert side["video"]["colour"].startswith("BT.709 primaries, transfer and matrix, limited range")


# the frames' per-pixel colour noise is the worst case of 4:2:0 (half the colour resolution): about 30 dB
@pytest.mark.parametrize("codec,depth,min_db", [("h265-444", 8, 38.0), ("prores4444", 8, 40.0),
                                                ("prores4444", 10, 40.0), ("h264-444", 10, 40.0),
                                                ("h264", 8, 30.0), ("h265", 8, 30.0), ("h265", 10, 28.0),
                                                ("prores422hq", 8, 32.0)])
def test_other_codecs_keep_frames_count_and_rate(tmp_path, codec, depth, min_db):
    frames = _frames(4)
    out = write_video(frames, tmp_path / "show", 25, (W, H), codec, bit_depth=depth)
    decoded, rate = _decode_av(out["video"])
    assert len(decoded) == 4 and rate == 25 and decoded[0].shape == (H, W, 3)
    assert min(_psnr(_u8(s), g) for s, g in zip(frames, decoded)) >= min_db


def test_sidecar_holds_the_show_and_the_video(tmp_path):
    show = {"looks": [{"name": "gold", "hold_s": 1.0}], "transitions": [{"kind": "dissolve", "s": 0.5}],
            "motions": [], "fps": 24, "spread": np.float32(0.5)}
    frames = _frames(3)
    out = write_video(frames, tmp_path / "show.mov", Fraction(24), (W, H), "lossless",
                      metadata={"projector": 1}, show=show, lapig_version="9.9")
    side = json.loads(out["sidecar"].read_text())
    assert out["sidecar"].name == "show.json"
    assert side["show"]["looks"][0]["name"] == "gold" and side["show"]["spread"] == 0.5
    assert side["projector"] == 1 and side["software"]["lapig"] == "9.9" and side["software"]["av"]
    v = side["video"]
    assert (v["codec"], v["pixel_format"], v["width"], v["height"], v["frame_count"], v["bit_depth"]) == \
        ("lossless", "rgb24", W, H, 3, 8)
    assert v["fps"] == 24 and v["duration_s"] == pytest.approx(3 / 24)


def test_holds_given_as_one_array_are_written_as_frames(tmp_path):
    a, b = _frames(2)
    seq = [a] * 4 + [b] * 3
    out = write_video(seq, tmp_path / "hold.mov", 30, (W, H), "lossless")
    decoded, _ = _decode_cv2(out["video"])
    assert len(decoded) == 7
    assert np.array_equal(decoded[3], _u8(a)) and np.array_equal(decoded[4], _u8(b))


def test_uint8_and_uint16_frames(tmp_path):
    a = _u8(_frames(1)[0])
    out = write_video([a, a.astype(np.uint16) * 257], tmp_path / "ints.mov", 60, (W, H), "lossless")
    decoded, fps = _decode_cv2(out["video"])
    assert len(decoded) == 2 and fps == 60 and all(np.array_equal(d, a) for d in decoded)


def _cancel_after(frames, event, n):
    for i, frame in enumerate(frames):
        if i == n:
            event.set()
        yield frame


def test_cancel_leaves_the_previous_video_untouched_and_no_temporary(tmp_path):
    old = write_video(_frames(2), tmp_path / "show.mov", 30, (W, H), "lossless")
    before_video, before_side = old["video"].read_bytes(), old["sidecar"].read_bytes()
    event = threading.Event()
    with pytest.raises(Cancelled):
        write_video(_cancel_after(_frames(6), event, 3), tmp_path / "show.mov", 30, (W, H), "lossless",
                    cancel_event=event, frame_count=6)
    assert old["video"].read_bytes() == before_video and old["sidecar"].read_bytes() == before_side
    assert sorted(p.name for p in tmp_path.iterdir()) == ["show.json", "show.mov"]


def test_cancel_with_no_previous_leaves_nothing(tmp_path):
    event = threading.Event()
    with pytest.raises(Cancelled):
        write_video(_cancel_after(_frames(6), event, 2), tmp_path / "new.mp4", 30, (W, H), "h264",
                    cancel_event=event)
    assert list(tmp_path.iterdir()) == []


def test_an_error_mid_way_removes_the_temporary_and_keeps_the_previous(tmp_path):
    old = write_video(_frames(2), tmp_path / "show.mov", 30, (W, H), "lossless")
    before = old["video"].read_bytes()
    bad = _frames(3) + [np.zeros((H + 2, W, 3), np.float32)]
    with pytest.raises(ExportError, match="frame 4 is 128x98, the export is 128x96"):
        write_video(bad, tmp_path / "show.mov", 30, (W, H), "lossless")
    with pytest.raises(ExportError, match="the show has 5 frames, but 3 came"):
        write_video(iter(_frames(3)), tmp_path / "show.mov", 30, (W, H), "lossless", frame_count=5)
    assert old["video"].read_bytes() == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["show.json", "show.mov"]


def test_hap_where_neither_pyav_nor_a_system_ffmpeg_has_it_says_how_to_get_it(tmp_path, monkeypatch):
    if codecs.route("hap", None) == ("pyav", None):
        pytest.skip("this PyAV has a HAP encoder")
    monkeypatch.setenv(codecs.FFMPEG_ENV, str(tmp_path / "no_ffmpeg_here"))
    with pytest.raises(codecs.VideoExportError) as info:
        write_video(_frames(2), tmp_path / "show.mov", 30, (W, H), "hap")
    line = str(info.value)
    assert "\n" not in line and line.startswith("HAP needs an FFmpeg built with snappy: install one")
    assert "apt-get install ffmpeg" in line and f"av {av.__version__}" in line
    assert f"the FFmpeg set ({tmp_path / 'no_ffmpeg_here'}) is not there" in line
    assert line.endswith("Available here: h264, h265, h264-444, h265-444, prores422hq, prores4444, lossless")
    assert list(tmp_path.iterdir()) == []


def test_unknown_codec_and_bit_depth_are_one_line(tmp_path):
    with pytest.raises(codecs.VideoExportError, match="unknown video codec 'vp9'; the choices are h264"):
        write_video(_frames(1), tmp_path / "a", 30, (W, H), "vp9")
    with pytest.raises(codecs.VideoExportError,
                       match="QuickTime Animation .lossless. takes frames of 8 or 16 bits, got 12"):
        write_video(_frames(1), tmp_path / "a", 30, (W, H), "lossless", bit_depth=12)
    with pytest.raises(ExportError, match=r"H.264 goes into .mp4 or .mov or .mkv files, not .avi"):
        write_video(_frames(1), tmp_path / "a.avi", 30, (W, H), "h264")


@pytest.mark.parametrize("fps", [0, -30, float("nan"), float("inf"), "0/1", "fast", None])
def test_bad_frame_rates_are_refused_before_writing(tmp_path, fps):
    with pytest.raises(ExportError) as info:
        write_video(_frames(2), tmp_path / "a.mp4", fps, (W, H), "h264")
    assert "frame rate" in str(info.value) and "\n" not in str(info.value)
    assert list(tmp_path.iterdir()) == []


def test_a_show_longer_than_the_disk_is_refused_before_writing(tmp_path, monkeypatch):
    real = shutil.disk_usage
    monkeypatch.setattr(shutil, "disk_usage", lambda p: real(p)._replace(free=50 * 2**20))
    frames_written = []

    def frames():
        for f in _frames(1):
            frames_written.append(f)
            yield f

    with pytest.raises(ExportError) as info:
        write_video(frames(), tmp_path / "long.mp4", 30, (1920, 1080), "h264", frame_count=30 * 60 * 60)
    line = str(info.value)
    assert "the show needs up to" in line and "GB" in line and "50.0 MB free" in line and "\n" not in line
    assert frames_written == [] and list(tmp_path.iterdir()) == []


def test_an_unwritable_or_missing_folder_is_one_line(tmp_path):
    blocker = tmp_path / "file"
    blocker.write_text("x")
    with pytest.raises(ExportError, match="output folder is not a folder"):
        write_video(_frames(1), blocker / "a.mp4", 30, (W, H), "h264")
    with pytest.raises(ExportError, match="output folder does not exist"):
        write_video(_frames(1), tmp_path / "no" / "a.mp4", 30, (W, H), "h264")


def test_unwritable_folder(tmp_path, monkeypatch):
    import tempfile as tf

    def refuse(*a, **k):
        raise PermissionError(13, "Permission denied")

    monkeypatch.setattr(tf, "mkstemp", refuse)
    with pytest.raises(ExportError, match=f"cannot write to folder {tmp_path}: Permission denied"):
        write_video(_frames(1), tmp_path / "a.mp4", 30, (W, H), "h264")


def test_odd_sizes_in_every_yuv_codec_padded_where_its_chroma_needs_it(tmp_path):
    for name, (w, h), padded in (("h264", (33, 17), (34, 18)), ("h265", (129, 97), (130, 98)),
                                 ("prores4444", (33, 17), (33, 17)), ("prores422hq", (33, 17), (34, 17)),
                                 ("h264-444", (33, 17), (33, 17))):
        frames = _frames(2, w, h)
        out = write_video(frames, tmp_path / f"odd_{name}", 24, (w, h), name)
        decoded, _ = _decode_av(out["video"])
        assert len(decoded) == 2 and decoded[0].shape == (padded[1], padded[0], 3), name
        assert _psnr(_u8(frames[0]), decoded[0][:h, :w]) > 24.0, name  # the picture at the top left
        side = json.loads(out["sidecar"].read_text())["video"]
        assert side["picture"] == [w, h] and [side["width"], side["height"]] == list(padded)
        if padded != (w, h):
            assert out["notes"] == side["notes"] and len(out["notes"]) == 1
            assert out["notes"][0].startswith(f"{w}x{h} padded to {padded[0]}x{padded[1]}"), name
        else:
            assert out["notes"] == []
    with pytest.raises(codecs.VideoExportError, match="H.265 needs frames at least 64x64 pixels, got 33x17"):
        write_video(_frames(2, 33, 17), tmp_path / "narrow", 24, (33, 17), "h265")
    with pytest.raises(codecs.VideoExportError, match="H.265 4:4:4 needs frames at least 64x64 pixels, got 128x48"):
        write_video(_frames(2, 128, 48), tmp_path / "low", 24, (128, 48), "h265-444")  # wide enough, too low
    assert not list(tmp_path.glob("narrow*")) and not list(tmp_path.glob("low*"))


def test_availability_lists_every_codec():
    table = codecs.availability()
    assert set(table) == set(codecs.NAMES)
    assert all(table[n] is None for n in ("h264", "h265", "h264-444", "h265-444", "prores422hq", "prores4444",
                                          "lossless"))


def test_video_path_suffixes(tmp_path):
    assert video.video_path(tmp_path / "x", codecs.CODECS["prores4444"]).name == "x.mov"
    assert video.video_path(tmp_path / "x.MKV", codecs.CODECS["h265"]).name == "x.MKV"


def test_one_buffer_filled_with_new_frames_is_not_taken_for_a_hold(tmp_path):
    frames = _frames(3)
    buffer = np.empty_like(frames[0])

    def reused():
        for f in frames:
            buffer[:] = f
            yield buffer

    out = write_video(reused(), tmp_path / "buf.mov", 30, (W, H), "lossless")
    decoded, _ = _decode_cv2(out["video"])
    assert all(np.array_equal(d, _u8(f)) for d, f in zip(decoded, frames)) and len(decoded) == 3


def test_a_failed_rename_into_place_keeps_the_previous_video_and_sidecar(tmp_path, monkeypatch):
    import os

    old = write_video(_frames(2), tmp_path / "show.mov", 30, (W, H), "lossless", metadata={"take": 1})
    before = (old["video"].read_bytes(), old["sidecar"].read_bytes())
    real_replace = os.replace

    def replace(src, dst):
        if str(dst).endswith("show.mov"):  # the sidecar is renamed first, then the video fails
            raise OSError(5, "Input/output error")
        return real_replace(src, dst)

    monkeypatch.setattr(os, "replace", replace)
    with pytest.raises(ExportError, match="could not write show.mov"):
        write_video(_frames(3), tmp_path / "show.mov", 30, (W, H), "lossless", metadata={"take": 2})
    monkeypatch.undo()
    assert (old["video"].read_bytes(), old["sidecar"].read_bytes()) == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["show.json", "show.mov"]

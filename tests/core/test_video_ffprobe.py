"""Every codec's file checked by an independent decoder (issue 52): the system ffprobe and ffmpeg, strict (-xerror),
not the PyAV that wrote it: profile, pixel format, level, colour tags, frame count, frame rate, duration and the
keyframe interval; HAP through the system FFmpeg's pipe (codec 'hap', cancel, a full disk); bad input in one line.
Skipped, saying so, where ffmpeg or ffprobe is missing (.ci/run installs them)."""
import errno
import json
import os
import shutil
import stat
import subprocess
import threading
from fractions import Fraction

import numpy as np
import pytest

av = pytest.importorskip("av")

from lapig.lapig_core.export import codecs, levels, video  # noqa: E402
from lapig.lapig_core.export.projector_image import ExportError  # noqa: E402
from lapig.lapig_core.export.show_output import Cancelled  # noqa: E402
from lapig.lapig_core.export.video import write_video  # noqa: E402
from lapig.tools.checks.video_read import decode_with_ffmpeg, probe  # noqa: E402

needs_ffmpeg = pytest.mark.skipif(shutil.which("ffprobe") is None or shutil.which("ffmpeg") is None,
                                  reason="the system ffmpeg and ffprobe are not installed (apt-get install ffmpeg; "
                                         ".ci/run installs them): the independent decoder checks cannot run")
W, H, N = 128, 96, 12  # H.265 at 64x64 still crashes now and then (tools/research/x265_small_frames)


def _frames(n=N, w=W, h=H):
    """Smooth gradients with a moving red block, float32 in [0, 1] (8-bit exact)."""
    yy, xx = np.mgrid[0:h, 0:w].astype(np.float32)
    out = []
    for i in range(n):
        f = np.stack([xx / w * 200 + 20, yy / h * 180 + 40, (xx + yy) / (w + h) * 120 + 60 + 4 * i], -1)
        f[8:20, 4 + 3 * i:16 + 3 * i] = (230, 30, 40)
        out.append((np.round(np.clip(f, 0, 255)) / 255).astype(np.float32))
    return out


def _psnr(a, b):
    mse = np.mean((a.astype(np.float64) - b.astype(np.float64)) ** 2)
    return float("inf") if mse == 0 else 10 * np.log10(255 ** 2 / mse)


def _u8(frame):
    return np.round(frame * 255).astype(np.uint8)


BT709 = {"color_primaries": "bt709", "color_transfer": "bt709", "color_space": "bt709", "color_range": "tv"}
# codec -> (ffprobe's codec_name, profile, pix_fmt(s), level (ffprobe: H.264 10x, H.265 30x), YUV, min PSNR dB)
EXPECTED = {
    "h264": ("h264", "High", ("yuv420p",), 30, True, 29.0),  # the red block's edges: 4:2:0 alone is 31-33 dB here
    "h265": ("hevc", "Main", ("yuv420p",), 90, True, 29.0),
    "h264-444": ("h264", "High 4:4:4 Predictive", ("yuv444p",), 30, True, 42.0),
    "h265-444": ("hevc", "Rext", ("yuv444p",), 90, True, 40.0),
    "prores422hq": ("prores", "HQ", ("yuv422p10le",), None, True, 31.0),
    "prores4444": ("prores", "4444", ("yuv444p10le", "yuv444p12le"), None, True, 42.0),
    "lossless": ("qtrle", None, ("rgb24",), None, False, float("inf")),
    "hap": ("hap", None, ("rgb0", "rgba"), None, False, 36.0),
    "hap-alpha": ("hap", None, ("rgba",), None, False, 36.0),
    "hap-q": ("hap", None, ("rgb0", "rgba"), None, False, 36.0),
}


@needs_ffmpeg
@pytest.mark.parametrize("name", list(EXPECTED))
def test_every_codec_decodes_strictly_with_its_tags_and_frames(tmp_path, name):
    assert set(EXPECTED) == set(codecs.NAMES)
    codec_name, profile, pix_fmts, level, yuv, min_db = EXPECTED[name]
    frames = _frames()
    out = write_video(frames, tmp_path / "show", 30, (W, H), name)
    info = probe(out["video"])
    assert info["codec_name"] == codec_name and info["pix_fmt"] in pix_fmts
    if profile is not None:
        assert info["profile"] == profile
    if level is not None:
        assert info["level"] == level  # 3.0: the floor (export/levels)
    for key, value in BT709.items():
        assert info.get(key) == (value if yuv else info.get(key)), key
    if not yuv:
        assert info.get("color_space") in (None, "unknown", "gbr")
    hap_tag = {"hap": "Hap1", "hap-alpha": "Hap5", "hap-q": "HapY"}.get(name)  # which HAP it is
    if hap_tag:
        assert info["codec_tag_string"] == hap_tag
    assert info["frames"] == N and int(info["nb_frames"]) == N
    assert info["rate"] == 30 and info["avg_rate"] == 30  # a constant frame rate
    assert info["duration_s"] == pytest.approx(N / 30, abs=1e-3)
    assert info["keyframes"][0] == 0 and max(np.diff(info["keyframes"] + [N]), default=0) <= 30
    decoded, fps = decode_with_ffmpeg(out["video"])
    assert len(decoded) == N and fps == 30 and decoded[0].shape == (H, W, 3)
    assert min(_psnr(_u8(s), d) for s, d in zip(frames, decoded)) >= min_db
    side = json.loads(out["sidecar"].read_text())["video"]
    intra = codecs.CODECS[name].intra
    assert side["profile"] == (profile or "") and side["keyframe_interval_frames"] == (1 if intra else 30)
    assert info["keyframes"] == (list(range(N)) if intra else [0])


@needs_ffmpeg
@pytest.mark.parametrize("fps,keyint", [(30, 30), (29.97, 29), (25, 25)])
def test_closed_gop_with_a_keyframe_at_least_every_second(tmp_path, fps, keyint):
    frames = _frames(70)
    out = write_video(frames, tmp_path / "gop.mp4", fps, (W, H), "h264")
    info = probe(out["video"])
    assert info["keyframes"] == list(range(0, 70, keyint))
    assert info["rate"] == Fraction(fps).limit_denominator(1001) or info["rate"] == Fraction(30000, 1001)
    assert info["duration_s"] == pytest.approx(70 / float(info["rate"]), abs=2e-3)
    # closed GOP: decoding from the second keyframe on needs nothing before it (every frame from there, no error)
    start = keyint / float(info["rate"])
    done = subprocess.run(["ffmpeg", "-v", "error", "-xerror", "-noaccurate_seek", "-ss", f"{start:.6f}", "-i",
                           str(out["video"]), "-f", "rawvideo", "-pix_fmt", "gray", "pipe:1"], stdin=subprocess.DEVNULL,
                          capture_output=True, timeout=300)
    assert done.returncode == 0 and not done.stderr.strip(), done.stderr
    assert len(done.stdout) == (70 - keyint) * W * H


@needs_ffmpeg
def test_1080p30_is_h264_level_4_1(tmp_path):
    frame = np.full((1080, 1920, 3), 0.5, np.float32)
    out = write_video([frame] * 2, tmp_path / "hd.mp4", 30, (1920, 1080), "h264")
    info = probe(out["video"])
    assert info["level"] == 41 and info["profile"] == "High" and info["pix_fmt"] == "yuv420p"
    assert out["level"] == "4.1" and info["height"] == 1080  # 1080 is even: no padding (the SPS crops 1088)


def test_levels_from_size_and_rate():
    assert [levels.h264_level(w, h, r).name for w, h, r in
            ((1920, 1080, 30), (1920, 1080, 60), (3840, 2160, 30), (3840, 2160, 60), (1280, 720, 30), (64, 48, 30),
             (4096, 2160, 30))] == ["4.1", "4.2", "5.1", "5.2", "3.1", "3", "5.2"]
    assert [levels.h265_level(w, h, r).name for w, h, r in
            ((1920, 1080, 30), (3840, 2160, 30), (3840, 2160, 60), (64, 48, 30))] == ["4", "5", "5.1", "3"]
    assert levels.h264_level(1920, 1080, 30).max_bitrate_kbps == 62500  # 50 Mbit/s times High's 1.25
    with pytest.raises(levels.LevelError) as info:
        levels.h264_level(16384, 16384, 30)
    assert "beyond H.264's highest level 6.2" in str(info.value) and "\n" not in str(info.value)


def test_a_size_beyond_the_highest_level_is_refused_before_writing(tmp_path):
    with pytest.raises(codecs.VideoExportError) as info:
        write_video(iter(()), tmp_path / "huge.mp4", 60, (16384, 16384), "h264", frame_count=1)
    line = str(info.value)
    assert line.startswith("16384x16384 at 60 fps is beyond H.264's highest level 6.2") and "\n" not in line
    assert "prores" in line and list(tmp_path.iterdir()) == []


@needs_ffmpeg
@pytest.mark.parametrize("name,size,padded", [("h264", (65, 49), (66, 50)), ("hap", (62, 45), (64, 48))])
def test_odd_sizes_are_padded_and_say_so(tmp_path, name, size, padded):
    w, h = size
    frames = _frames(3, w, h)
    out = write_video(frames, tmp_path / "odd", 30, size, name)
    info = probe(out["video"])
    assert (info["width"], info["height"]) == padded
    assert len(out["notes"]) == 1 and out["notes"][0].startswith(f"{w}x{h} padded to {padded[0]}x{padded[1]}")
    decoded, _ = decode_with_ffmpeg(out["video"])
    assert _psnr(_u8(frames[0]), decoded[0][:h, :w]) > 30
    assert np.abs(decoded[0][:h, w - 1].astype(int) - decoded[0][:h, -1]).max() < 24  # the edge repeated


@needs_ffmpeg
def test_16_bit_frames_go_into_prores_at_10_bits_with_a_note(tmp_path):
    frames = [(_u8(f).astype(np.uint16) * 257) for f in _frames(3)]
    out = write_video(frames, tmp_path / "deep.mov", 24, (W, H), "prores422hq", bit_depth=16)
    assert out["notes"] == ["16-bit frames written at ProRes 422 HQ's 10 bits"]
    info = probe(out["video"])
    assert info["pix_fmt"] == "yuv422p10le" and info["profile"] == "HQ" and info["frames"] == 3
    out = write_video(frames, tmp_path / "deep.mp4", 24, (W, H), "h265", bit_depth=16)
    assert probe(out["video"])["profile"] == "Main 10" and probe(out["video"])["pix_fmt"] == "yuv420p10le"


def _cancel_after(frames, event, n):
    for i, frame in enumerate(frames):
        if i == n:
            event.set()
        yield frame


@needs_ffmpeg
def test_hap_through_the_pipe_cancels_and_leaves_no_file_under_the_final_name(tmp_path):
    if codecs.route("hap") is None or codecs.route("hap")[0] != "ffmpeg":
        pytest.skip("HAP is not written through the system FFmpeg here (PyAV has it, or no FFmpeg has it)")
    event = threading.Event()
    progress = []
    with pytest.raises(Cancelled):
        write_video(_cancel_after(_frames(), event, 5), tmp_path / "show.mov", 30, (W, H), "hap",
                    cancel_event=event, frame_count=N, on_progress=lambda f, m: progress.append(f))
    assert list(tmp_path.iterdir()) == [] and progress and progress[-1] < 1
    out = write_video(_frames(), tmp_path / "show.mov", 30, (W, H), "hap-q", frame_count=N,
                      on_progress=lambda f, m: progress.append(f))
    assert progress[-1] == 1 and json.loads(out["sidecar"].read_text())["video"]["encoded_by"].startswith("system")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["show.json", "show.mov"]


def _fake_ffmpeg(tmp_path, body: str) -> str:
    """An 'ffmpeg' that lists the HAP encoder and then does `body` with the frames on its stdin."""
    path = tmp_path / "fake_bin" / "ffmpeg"
    path.parent.mkdir()
    path.write_text("#!/bin/sh\n"
                    "case \"$*\" in *-encoders*) echo ' V.S... hap                  Vidvox Hap'; exit 0;; esac\n"
                    f"{body}\n")
    path.chmod(path.stat().st_mode | stat.S_IXUSR)
    return str(path)


@pytest.mark.skipif(os.name != "posix", reason="the fake ffmpeg is a shell script")
def test_a_full_disk_in_the_pipe_is_one_line_and_no_file(tmp_path, monkeypatch):
    if codecs.route("hap", None) == ("pyav", None):
        pytest.skip("this PyAV has a HAP encoder: the pipe is not used")
    fake = _fake_ffmpeg(tmp_path, "head -c 20000 >/dev/null; "
                                  "echo 'Error writing trailer of out.mov: No space left on device' >&2; exit 1")
    out_dir = tmp_path / "out"
    out_dir.mkdir()
    with pytest.raises(ExportError) as info:
        write_video(_frames(), out_dir / "show.mov", 30, (W, H), "hap", ffmpeg=fake)
    line = str(info.value)
    assert line.startswith("could not write show.mov: the disk may be full") and "\n" not in line
    assert list(out_dir.iterdir()) == []


def test_a_full_disk_through_pyav_is_one_line_and_no_file(tmp_path, monkeypatch):
    calls = []

    def full(container, packet):
        calls.append(1)
        if len(calls) > 2:
            raise OSError(errno.ENOSPC, "No space left on device")
        container.mux(packet)

    monkeypatch.setattr(video, "_mux", full)
    with pytest.raises(ExportError) as info:
        write_video(_frames(), tmp_path / "show.mov", 30, (W, H), "prores422hq")
    line = str(info.value)
    assert "could not write show.mov" in line and "the disk may be full" in line and "\n" not in line
    assert list(tmp_path.iterdir()) == []


def test_unknown_codec_is_one_line(tmp_path):
    with pytest.raises(codecs.VideoExportError) as info:
        write_video(_frames(1), tmp_path / "a", 30, (W, H), "h266")
    assert str(info.value) == ("unknown video codec 'h266'; the choices are h264, h265, h264-444, h265-444, "
                               "prores422hq, prores4444, lossless, hap, hap-alpha, hap-q")
    assert list(tmp_path.iterdir()) == []


def test_every_codec_says_its_trade_off():
    for codec in codecs.CODECS.values():
        assert len(codec.help) > 40 and "\n" not in codec.help, codec.name
    assert "software decoder" in codecs.CODECS["h264-444"].help
    assert "software decoder" in codecs.CODECS["h265-444"].help


@needs_ffmpeg
def test_a_codec_pyav_lacks_goes_through_the_system_ffmpeg_with_the_same_file(tmp_path, monkeypatch):
    real = codecs._av_has_encoder
    monkeypatch.setattr(codecs, "_av_has_encoder", lambda codec: codec.encoder != "libx264" and real(codec))
    assert codecs.route("h264")[0] == "ffmpeg"
    frames = _frames()
    out = write_video(frames, tmp_path / "piped.mp4", 30, (W, H), "h264")
    info = probe(out["video"])
    assert (info["codec_name"], info["profile"], info["pix_fmt"], info["level"]) == ("h264", "High", "yuv420p", 30)
    assert {k: info.get(k) for k in BT709} == BT709 and info.get("chroma_location") == "center"
    assert info["frames"] == N and info["rate"] == 30 and info["keyframes"] == [0]
    decoded, _ = decode_with_ffmpeg(out["video"])
    assert min(_psnr(_u8(s), d) for s, d in zip(frames, decoded)) >= 29.0
    assert json.loads(out["sidecar"].read_text())["video"]["encoded_by"] == "system FFmpeg through a pipe"

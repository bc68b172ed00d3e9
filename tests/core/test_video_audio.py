"""The show's sound in its video (issue 52, item 6): AAC in .mp4, PCM in .mov (HAP's too), in sync, as long as the
video; no sound, no audio track; a sound that cannot be read is one line and no file. Checked with the system
ffprobe and ffmpeg (skipped, saying so, where they are missing)."""
import json
import shutil
import subprocess
import wave

import numpy as np
import pytest

av = pytest.importorskip("av")

from lapig.lapig_core.export import codecs  # noqa: E402
from lapig.lapig_core.export.projector_image import ExportError  # noqa: E402
from lapig.lapig_core.export.video import write_video  # noqa: E402

pytestmark = pytest.mark.skipif(shutil.which("ffprobe") is None or shutil.which("ffmpeg") is None,
                                reason="the system ffmpeg and ffprobe are not installed (apt-get install ffmpeg; "
                                       ".ci/run installs them): the sound checks cannot run")
W, H, FPS, N = 128, 96, 30, 30  # one second; H.265 at 64x64 still crashes now and then


def _sound(path, seconds, onset_s, rate=44100):
    """Mono 16-bit WAV: silence, then a 440 Hz tone from onset_s on."""
    t = np.arange(int(seconds * rate)) / rate
    samples = np.where(t >= onset_s, 0.5 * np.sin(2 * np.pi * 440 * t), 0.0)
    with wave.open(str(path), "wb") as w:
        w.setnchannels(1), w.setsampwidth(2), w.setframerate(rate)
        w.writeframes((samples * 32767).astype("<i2").tobytes())
    return path


def _frames():
    return [np.full((H, W, 3), i / N, np.float32) for i in range(N)]


def _streams(path):
    out = subprocess.run(["ffprobe", "-v", "error", "-show_streams", "-of", "json", str(path)], capture_output=True,
                         text=True, check=True)
    return {s["codec_type"]: s for s in json.loads(out.stdout)["streams"]}


def _decoded_sound(path):
    out = subprocess.run(["ffmpeg", "-v", "error", "-xerror", "-i", str(path), "-map", "0:a:0", "-ac", "1", "-ar",
                          "48000", "-f", "f32le", "pipe:1"], stdin=subprocess.DEVNULL, capture_output=True,
                         check=True, timeout=300)
    return np.frombuffer(out.stdout, "<f4")


@pytest.mark.parametrize("name,suffix,audio_codec", [("h264", ".mp4", "aac"), ("h265", ".mp4", "aac"),
                                                     ("prores422hq", ".mov", "pcm_s16le"),
                                                     ("hap", ".mov", "pcm_s16le"), ("h264", ".mov", "pcm_s16le")])
def test_the_sound_is_in_the_video_in_sync_and_as_long(tmp_path, name, suffix, audio_codec):
    if codecs.availability()[name] is not None:
        pytest.skip(codecs.availability()[name])
    sound = _sound(tmp_path / "sound.wav", 1.5, onset_s=0.5)  # longer than the video: cut at its end
    out = write_video(_frames(), tmp_path / f"show{suffix}", FPS, (W, H), name, audio=sound)
    streams = _streams(out["video"])
    assert streams["audio"]["codec_name"] == audio_codec and int(streams["audio"]["sample_rate"]) == 48000
    assert int(streams["audio"]["channels"]) == 2 and int(streams["video"]["nb_frames"]) == N
    if name == "h265":
        assert streams["video"]["codec_tag_string"] == "hvc1"  # kept through the remux
    assert float(streams["audio"]["duration"]) == pytest.approx(1.0, abs=1 / FPS)
    assert float(streams["audio"].get("start_time", 0)) == pytest.approx(0.0, abs=1e-3)
    samples = _decoded_sound(out["video"])
    onset = np.argmax(np.abs(samples) > 0.1) / 48000
    assert onset == pytest.approx(0.5, abs=1 / FPS)  # within a frame of the source's
    side = json.loads(out["sidecar"].read_text())["video"]["audio"]
    assert side["codec"] == audio_codec and side["source"] == "sound.wav" and side["duration_s"] == 1.0


def test_a_short_sound_is_padded_with_silence_to_the_video_end(tmp_path):
    sound = _sound(tmp_path / "short.wav", 0.4, onset_s=0.0)
    out = write_video(_frames(), tmp_path / "show.mov", FPS, (W, H), "prores422hq", audio=sound)
    samples = _decoded_sound(out["video"])
    assert len(samples) == pytest.approx(48000, abs=48000 / FPS)
    assert np.abs(samples[:int(0.35 * 48000)]).max() > 0.3 and np.abs(samples[int(0.45 * 48000):]).max() < 1e-3


def test_no_sound_writes_no_audio_track(tmp_path):
    out = write_video(_frames(), tmp_path / "show.mp4", FPS, (W, H), "h264")
    assert set(_streams(out["video"])) == {"video"}
    assert json.loads(out["sidecar"].read_text())["video"]["audio"] is None


def test_a_sound_that_cannot_be_read_is_one_line_and_no_file(tmp_path):
    bad = tmp_path / "sound.wav"
    bad.write_bytes(b"not a sound")
    out_dir = tmp_path / "out"
    out_dir.mkdir()
    with pytest.raises(ExportError) as info:
        write_video(_frames(), out_dir / "show.mp4", FPS, (W, H), "h264", audio=bad)
    assert "sound.wav" in str(info.value) and "\n" not in str(info.value)
    assert list(out_dir.iterdir()) == []

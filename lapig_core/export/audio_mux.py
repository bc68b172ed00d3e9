# SPDX-License-Identifier: GPL-3.0-or-later
"""A show's sound put beside its encoded video: the video stream copied as it is, the audio encoded for the
container (AAC in .mp4 and .mkv, 16-bit PCM in .mov), 48 kHz stereo, cut or padded with silence to the video's
duration so that both end together; both start at 0 (the sound is the show's range mixed down from its start).

    add_audio(video_file, audio_file, out_file, container_format, duration_s) -> dict
        {"codec", "rate", "channels", "duration_s"}; ExportError (one line) where the sound cannot be read

`av` is imported inside (the torch-free Blender tier imports the export package without PyAV).
"""
from __future__ import annotations

import heapq
import itertools
from pathlib import Path

import numpy as np

from .projector_image import ExportError

RATE = 48000
LAYOUT = "stereo"
_CODECS = {"mp4": ("aac", "fltp"), "matroska": ("aac", "fltp"), "mov": ("pcm_s16le", "s16")}
_BLOCK = 1024  # samples per frame handed to the encoder


def _source_blocks(av, audio_file: Path, total: int, sample_format: str):
    """The sound as (channels, n) arrays of `sample_format` at RATE, exactly `total` samples (cut, or padded with
    silence)."""
    resampler = av.AudioResampler(format=sample_format, layout=LAYOUT, rate=RATE)
    done = 0
    try:
        source = av.open(str(audio_file))
    except (OSError, av.FFmpegError) as exc:
        raise ExportError(f"cannot read the show's sound {Path(audio_file).name}: {exc}") from None
    with source:
        if not source.streams.audio:
            raise ExportError(f"the show's sound {Path(audio_file).name} has no audio stream")
        decoded = source.decode(source.streams.audio[0])
        for frame in itertools.chain(decoded, [None]):  # None: flush the resampler
            for out in resampler.resample(frame):
                block = out.to_ndarray()  # planar fltp: (2, n); packed s16: (1, 2n), left and right in turn
                if sample_format == "s16":
                    block = block.reshape(-1, 2).T
                take = min(block.shape[1], total - done)
                if take > 0:
                    yield np.ascontiguousarray(block[:, :take])
                    done += take
    while done < total:  # the sound ends before the video: silence to the end
        take = min(_BLOCK, total - done)
        yield np.zeros((2, take), np.float32 if sample_format == "fltp" else np.int16)
        done += take


def _frame(av, block: np.ndarray, sample_format: str, pts: int):
    data = block if sample_format == "fltp" else block.T.reshape(1, -1)
    frame = av.AudioFrame.from_ndarray(np.ascontiguousarray(data), format=sample_format, layout=LAYOUT)
    frame.sample_rate, frame.pts = RATE, pts
    return frame


def add_audio(video_file, audio_file, out_file, container_format: str, duration_s: float) -> dict:
    """Write out_file: video_file's video stream copied, and audio_file's sound (see the module docstring)."""
    import av

    codec, sample_format = _CODECS[container_format]
    total = int(round(duration_s * RATE))
    with av.open(str(video_file)) as video_in, av.open(str(out_file), mode="w", format=container_format) as out:
        video_stream = video_in.streams.video[0]
        video_out = out.add_stream_from_template(video_stream, opaque=True)
        tag = video_stream.codec_context.codec_tag if video_stream.codec_context is not None else ""
        if tag and video_out.codec_context is not None:  # H.265's 'hvc1' (Apple's players need it) kept
            video_out.codec_context.codec_tag = tag
        audio_out = out.add_stream(codec, rate=RATE, layout=LAYOUT)
        audio_out.format = sample_format

        def audio_packets():
            pts = 0
            for block in _source_blocks(av, Path(audio_file), total, sample_format):
                yield from audio_out.encode(_frame(av, block, sample_format, pts))
                pts += block.shape[1]
            yield from audio_out.encode(None)

        def video_packets():
            for packet in video_in.demux(video_stream):
                if packet.dts is None:  # the demuxer's flush packet
                    continue
                packet.stream = video_out
                yield packet

        def when(packet):
            stamp = packet.dts if packet.dts is not None else (packet.pts or 0)
            return float(stamp * packet.time_base)

        for packet in heapq.merge(video_packets(), audio_packets(), key=when):  # interleaved in time
            out.mux(packet)
    return {"codec": codec, "rate": RATE, "channels": 2, "duration_s": total / RATE}

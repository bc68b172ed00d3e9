"""`python -m lapig_addon bench video --json`: a show's video export (issue 38), per codec the installed PyAV has.

- video_roundtrip_psnr_db: the first and last frames decoded by OpenCV (cv2.VideoCapture) against the show's PNG
  export of the same frames (lapig_core/export/image_sequence, read back): lossless must be exact (inf, written
  as the string "inf"), H.264 at its high quality >= 40 dB.
- video_frames_ok: per codec, the decoded frame count, size and frame rate (OpenCV) equal the intended.
- encode_fps_1080p: frames per second through write_video at 1920x1080, per codec (frames made beforehand).
- export_fps_dissolve_1080p: a show of hold A, a dissolve (export/projector_image.crossfade_frames: the linear-light
  mix of two compensated frames, made frame by frame) and hold B, at 1920x1080, 30 fps, encoded to H.264: frames
  per second from the first frame made to the file renamed in place. A hold is one frame given again (no
  recomputation, converted once). Goal >= 10 on 2 cores.
Issue 52 adds, per codec (the file checked by the system ffprobe and decoded by the system ffmpeg, independent of
the PyAV that wrote it; skipped, saying so, where they are missing):
- ffprobe: profile, pix_fmt, level; mb_per_minute_1080p30 (the file's bytes per frame times 1800);
  encoded_by (PyAV, or the system FFmpeg through a pipe: HAP's encode_fps is through the pipe);
- roundtrip_db: PSNR of the decoded frames against the source in linear light, and on the edges (pixels whose
  Sobel gradient is in the top 10 %) in linear light and gamma-encoded; on two kinds of frames: the dissolve's
  compensated frames, and look A with thin coloured lines and text drawn on it (what 4:2:0 hurts most).
- chroma_420: the 4:2:0 conversion alone (no codec), decoded by FFmpeg: swscale's plain subsampling against
  export/chroma's (2x2 mean, luminance kept at colour edges), and 4:4:4; the same figures.
The two looks are "compensated" at native size: a drawn scene and stripes divided by a wood surface's
reflectance (what a per-pixel compensation does), clipped to [0, 1], so the frames carry the surface's grain.
The machine's load average is recorded before and after (other processes sharing the cores slow the timings).
"""
from __future__ import annotations

import math
import os
import shutil
import tempfile
import time

import cv2
import numpy as np

from ...lapig_core.common.imageio import decode_image, to_uint8
from ...lapig_core.common.surfaces import make_surface
from ...lapig_core.export import chroma, codecs
from ...lapig_core.export.image_sequence import write_image_sequence
from ...lapig_core.export.projector_image import crossfade_frames
from ...lapig_core.export.video import write_video
from ..checks.video_read import decode_with_ffmpeg, probe, system_tool
from ..checks.video_read import decode_with_opencv as _decode_cv2
from .test_images import drawn_scene

W, H = 1920, 1080
FPS = 30
ROUNDTRIP_FRAMES = 12


def _compensated_looks() -> tuple[np.ndarray, np.ndarray]:
    """Two 1080p projector images with a surface's grain in them."""
    wood = cv2.resize(make_surface("wood", 540, seed=3), (W, H), interpolation=cv2.INTER_CUBIC)
    reflectance = np.clip(0.35 + 0.65 * wood, 0.05, 1.0)
    scene = cv2.resize(drawn_scene(540), (W, H), interpolation=cv2.INTER_LINEAR)
    stripes = cv2.resize(make_surface("stripe", 540, seed=1), (W, H), interpolation=cv2.INTER_LINEAR)
    look_a = np.clip(0.3 * scene / reflectance, 0, 1).astype(np.float32)
    look_b = np.clip(0.3 * stripes / reflectance, 0, 1).astype(np.float32)
    return look_a, look_b


def _psnr(a: np.ndarray, b: np.ndarray) -> float:
    mse = float(np.mean((a.astype(np.float64) - b.astype(np.float64)) ** 2))
    return math.inf if mse == 0 else 10 * math.log10(255.0 ** 2 / mse)


def _json_db(value: float):
    return "inf" if math.isinf(value) else round(value, 2)


def _roundtrip_frames(look_a, look_b) -> list[np.ndarray]:
    """ROUNDTRIP_FRAMES distinct 8-bit frames: the dissolve from A to B."""
    return list(crossfade_frames(look_a, look_b, ROUNDTRIP_FRAMES, width=W, height=H, bit_depth=8))


def _thin_lines(look: np.ndarray) -> np.ndarray:
    """Look A (8-bit) with one-pixel coloured lines and coloured text drawn on it."""
    img = to_uint8(look).copy()
    colours = [(255, 0, 0), (0, 255, 0), (0, 0, 255), (255, 255, 0), (255, 0, 255), (0, 255, 255)]
    for k, colour in enumerate(colours):
        cv2.line(img, (40, 60 + 40 * k), (W - 40, 60 + 40 * k), colour, 1)
        cv2.line(img, (200 + 250 * k, 40), (200 + 250 * k, H - 40), colour, 1)
        cv2.putText(img, "LAPIG show 01:23:45", (60 + 300 * k, 600), cv2.FONT_HERSHEY_SIMPLEX, 0.8, colour, 1)
    return img


def _figures(sources, decoded) -> dict:
    """PSNR in linear light, on edges in linear light and gamma-encoded (the worst frame of each)."""
    out = {"linear_db": math.inf, "edges_linear_db": math.inf, "edges_gamma_db": math.inf}
    for src, got in zip(sources, decoded):
        got = got[:src.shape[0], :src.shape[1]]
        mask = chroma.edge_mask(src)
        out["linear_db"] = min(out["linear_db"], chroma.linear_psnr(src, got))
        out["edges_linear_db"] = min(out["edges_linear_db"], chroma.edge_psnr(src, got, mask, linear=True))
        out["edges_gamma_db"] = min(out["edges_gamma_db"], chroma.edge_psnr(src, got, mask))
    return {k: _json_db(v) for k, v in out.items()}


def _per_codec(name: str, frames, pngs, work: str, lines) -> dict:
    start = time.perf_counter()
    out = write_video(frames, os.path.join(work, f"show_{name}"), FPS, (W, H), name)
    seconds = time.perf_counter() - start
    independent = system_tool("ffprobe") is not None and system_tool("ffmpeg") is not None
    if independent:  # the system FFmpeg honours the colour tags (OpenCV does not)
        decoded, fps = decode_with_ffmpeg(out["video"])
    elif codecs.CODECS[name].yuv:  # PyAV honours them too (not independent of the writer)
        import av

        with av.open(str(out["video"])) as container:
            decoded, fps = [f.to_ndarray(format="rgb24") for f in container.decode(video=0)], FPS
    else:
        decoded, fps = _decode_cv2(out["video"])
    ok = (len(decoded) == len(frames) and all(d.shape == (H, W, 3) for d in decoded) and abs(fps - FPS) < 1e-6)
    first = _psnr(pngs[0], decoded[0]) if decoded else float("nan")
    last = _psnr(pngs[-1], decoded[-1]) if decoded else float("nan")
    mb_per_frame = out["bytes"] / len(frames) / 2**20
    row = {"psnr_db": {"first": _json_db(first), "last": _json_db(last)},
           "min_psnr_db": min(first, last),
           "frames_ok": bool(ok), "decoded": [len(decoded), list(decoded[0].shape[1::-1]) if decoded else None,
                                               round(fps, 4)],
           "encode_fps": round(len(frames) / seconds, 2), "mb_per_frame": round(mb_per_frame, 3),
           "mb_per_minute_1080p30": round(mb_per_frame * 60 * FPS, 1),
           "estimate_mb_per_frame": round(codecs.bytes_per_frame(codecs.CODECS[name], W, H) / 2**20, 3),
           "encoded_by": "PyAV" if codecs.route(name) == ("pyav", None) else "system FFmpeg (pipe)",
           "notes": out["notes"]}
    if independent:
        info = probe(out["video"])
        row["ffprobe"] = {"codec": info.get("codec_name"), "profile": info.get("profile"),
                          "pix_fmt": info.get("pix_fmt"), "level": info.get("level"),
                          "color": [info.get(k) for k in ("color_primaries", "color_transfer", "color_space",
                                                          "color_range")],
                          "keyframes": len(info["keyframes"]), "frames": info["frames"]}
        row["roundtrip_db"] = {"dissolve": _figures([to_uint8(f) for f in frames[:2]] + [to_uint8(frames[-1])],
                                                    decoded[:2] + decoded[-1:])}
        lined = write_video([lines] * 2, os.path.join(work, f"lines_{name}"), FPS, (W, H), name)
        row["roundtrip_db"]["thin_lines"] = _figures([lines], decode_with_ffmpeg(lined["video"])[0][:1])
    return row


def _chroma_420(lines: np.ndarray, look: np.ndarray) -> dict:
    """The 4:2:0 conversion alone, decoded by the system FFmpeg: swscale's plain subsampling (PyAV's reformat,
    bilinear), export/chroma's, and 4:4:4."""
    import subprocess

    import av
    from av.video.reformatter import ColorRange, Colorspace, Interpolation

    ffmpeg = system_tool("ffmpeg")
    if ffmpeg is None:
        return {"skipped": "the system ffmpeg is not installed"}

    def sws(rgb, fmt):
        frame = av.VideoFrame.from_ndarray(rgb, format="rgb24")
        return frame.reformat(format=fmt, src_colorspace=Colorspace.ITU709, dst_colorspace=Colorspace.ITU709,
                              src_color_range=ColorRange.JPEG, dst_color_range=ColorRange.MPEG,
                              interpolation=Interpolation.BILINEAR | Interpolation.ACCURATE_RND).to_ndarray()

    def decode(planes, fmt):
        done = subprocess.run([ffmpeg, "-v", "error", "-f", "rawvideo", "-pix_fmt", fmt, "-s", f"{W}x{H}", "-i", "-",
                               "-vf", "scale=in_color_matrix=bt709:in_range=tv:flags=bilinear+accurate_rnd+"
                                      "full_chroma_int", "-f", "rawvideo", "-pix_fmt", "rgb24", "-"],
                              input=np.ascontiguousarray(planes).tobytes(), capture_output=True, check=True)
        return np.frombuffer(done.stdout, np.uint8).reshape(H, W, 3)

    out = {}
    for label, src in (("thin_lines", lines), ("compensated", to_uint8(look))):
        start = time.perf_counter()
        ours = chroma.to_yuv420(src)
        ours_ms = (time.perf_counter() - start) * 1000
        out[label] = {"420_swscale": _figures([src], [decode(sws(src, "yuv420p"), "yuv420p")]),
                      "420_lapig": _figures([src], [decode(ours, "yuv420p")]),
                      "444": _figures([src], [decode(sws(src, "yuv444p"), "yuv444p")]),
                      "lapig_conversion_ms": round(ours_ms, 1)}
    return out


def _dissolve_show(look_a, look_b, hold: int, dissolve: int):
    """hold A, the dissolve, hold B; each hold one array given again."""
    a8, b8 = to_uint8(look_a), to_uint8(look_b)
    for _ in range(hold):
        yield a8
    yield from crossfade_frames(look_a, look_b, dissolve, width=W, height=H, bit_depth=8)
    for _ in range(hold):
        yield b8


def run(args) -> dict:
    load_before = os.getloadavg()[0]
    work = tempfile.mkdtemp(prefix="lapig_video_")
    try:
        look_a, look_b = _compensated_looks()
        frames = _roundtrip_frames(look_a, look_b)
        sequence = write_image_sequence(frames, os.path.join(work, "png"), FPS, 8)
        pngs = [decode_image(np.fromfile(p, np.uint8)) for p in (sequence["files"][0], sequence["files"][-1])]
        availability = codecs.availability()
        lines = _thin_lines(look_a)
        per_codec = {}
        for name, problem in availability.items():
            if problem is None:
                per_codec[name] = _per_codec(name, frames, pngs, work, lines)
        chroma_420 = _chroma_420(lines, look_a)

        hold, dissolve = 45, 30
        start = time.perf_counter()
        out = write_video(_dissolve_show(look_a, look_b, hold, dissolve), os.path.join(work, "dissolve.mp4"), FPS,
                          (W, H), "h264", frame_count=2 * hold + dissolve)
        dissolve_fps = out["frames"] / (time.perf_counter() - start)
        decoded, _ = _decode_cv2(out["video"])
        dissolve_frames_ok = len(decoded) == 2 * hold + dissolve
    finally:
        shutil.rmtree(work, ignore_errors=True)
    load_after = os.getloadavg()[0]
    cores = os.cpu_count() or 1
    h264 = per_codec.get("h264", {})
    lossless = per_codec.get("lossless", {})
    return {
        "benchmark": "video",
        "size": [W, H], "fps": FPS, "roundtrip_frames": ROUNDTRIP_FRAMES,
        "video_roundtrip_psnr_db": {n: r["psnr_db"] for n, r in per_codec.items()},
        "lossless_exact": bool(lossless) and math.isinf(lossless["min_psnr_db"]),
        "h264_psnr_ok": bool(h264) and h264["min_psnr_db"] >= 40.0,
        "video_frames_ok": all(r["frames_ok"] for r in per_codec.values()) and dissolve_frames_ok,
        "video_frames_decoded": {n: r["decoded"] for n, r in per_codec.items()},
        "encode_fps_1080p": {n: r["encode_fps"] for n, r in per_codec.items()},
        "mb_per_frame_1080p": {n: r["mb_per_frame"] for n, r in per_codec.items()},
        "disk_check_estimate_mb_per_frame_1080p": {n: r["estimate_mb_per_frame"] for n, r in per_codec.items()},
        "export_fps_dissolve_1080p": round(dissolve_fps, 2),
        "export_dissolve_show": {"hold_frames": hold, "dissolve_frames": dissolve, "holds": 2, "codec": "h264"},
        "export_fps_dissolve_1080p_goal": 10,
        "unavailable": {n: p for n, p in availability.items() if p is not None},
        "ffprobe": {n: r.get("ffprobe") for n, r in per_codec.items()}
        if system_tool("ffprobe") else "skipped: the system ffprobe is not installed",
        "mb_per_minute_1080p30": {n: r["mb_per_minute_1080p30"] for n, r in per_codec.items()},
        "encoded_by": {n: r["encoded_by"] for n, r in per_codec.items()},
        "hap_encode_fps_1080p_pipe": {n: r["encode_fps"] for n, r in per_codec.items()
                                      if n.startswith("hap") and r["encoded_by"].startswith("system")},
        "roundtrip_linear_edges_db": {n: r.get("roundtrip_db") for n, r in per_codec.items()},
        "chroma_420_conversion": chroma_420,
        "notes": {n: r["notes"] for n, r in per_codec.items() if r["notes"]},
        "cores": cores, "loadavg_1m_before": round(load_before, 2), "loadavg_1m_after": round(load_after, 2),
        "machine_shared": max(load_before, load_after) > 0.5 * cores,
    }

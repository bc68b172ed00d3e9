"""How often libx265 (in PyPI's PyAV wheel) crashes on small frames: one encode after another in this process, the
export's own x265 settings, until N encodes or a crash (a segfault ends the process: run it several times).
It set codecs' H.265 floor at 64x64: on 2026-12-07, 2 crashes in the encodes at 64x48 (one at 4:2:0 with
FFmpeg's threads, one with thread_count 1; about 6,700 in all) and one in 150 loops of the video tests (then at
64x48), none in 4,500 each at 64x64 and 128x96; valgrind showed x265's
lookahead (cuTree) writing out of bounds at 48x48 and no invalid write at 64x48.
Run: .venv/bin/python tools/research/x265_small_frames.py WIDTH HEIGHT [N=1500] [PIX_FMT=yuv420p] [THREADS=0]
     (about 40 s for 1,500 at 64x48; the last line is JSON)"""
import json
import os
import sys
import tempfile
import time

import av
import numpy as np

width, height = int(sys.argv[1]), int(sys.argv[2])
count = int(sys.argv[3]) if len(sys.argv) > 3 else 1500
pix_fmt = sys.argv[4] if len(sys.argv) > 4 else "yuv420p"
threads = int(sys.argv[5]) if len(sys.argv) > 5 else 0
profile = "main444-8" if pix_fmt == "yuv444p" else "main"
params = ("log-level=error:keyint=30:min-keyint=30:open-gop=0:bframes=0:level-idc=30:vbv-maxrate=10000:"
          "vbv-bufsize=10000:colorprim=bt709:transfer=bt709:colormatrix=bt709:range=limited")
frames = [np.random.default_rng(i).integers(0, 255, (height, width, 3), dtype=np.uint8) for i in range(12)]
folder = tempfile.mkdtemp()
started = time.time()
for k in range(count):
    container = av.open(os.path.join(folder, "a.mp4"), "w")
    stream = container.add_stream("libx265", rate=30)
    stream.width, stream.height, stream.pix_fmt = width, height, pix_fmt
    stream.options = {"crf": "10", "preset": "faster", "tune": "psnr", "profile": profile, "x265-params": params}
    stream.codec_context.thread_count = threads
    for pixels in frames:
        for packet in stream.encode(av.VideoFrame.from_ndarray(pixels, format="rgb24").reformat(format=pix_fmt)):
            container.mux(packet)
    for packet in stream.encode():
        container.mux(packet)
    container.close()
    if k % 250 == 0:
        print(f"{k} encodes, {time.time() - started:.1f} s", flush=True)
print(json.dumps({"size": [width, height], "pix_fmt": pix_fmt, "threads": threads, "encodes": count,
                  "crashed": False, "seconds": round(time.time() - started, 1)}))

"""How often libx265 (in PyPI's PyAV wheel) crashes on small frames: the export's own H.265 stream (video.plan_video
and _open_stream: its options, level, tags and threads) opened and flushed again and again in this process, until
N encodes or a crash (a segfault ends the process: run it several times). write_video itself refuses such sizes
now (codecs.check_frame_size), so this goes one step below it.
It set codecs' H.265 floor at 64x64: on 2026-12-07, 2 crashes in the encodes at 64x48 (one at 4:2:0 with
FFmpeg's threads, one with thread_count 1; about 6,700 in all) and one in 150 loops of the video tests (then at
64x48), none in 4,500 each at 64x64 and 128x96; valgrind showed x265's lookahead (cuTree) writing out of bounds
at 48x48 and no invalid write at 64x48. Those runs set x265's options by hand; with the export's own stream (this
form), 64x48 hung in 2 of 3 runs of 1,500 (timeout 200 s) and 64x64 segfaulted in 1 of 3: the 64x64 floor is not
shown safe.
Run: .venv/bin/python tools/research/x265_small_frames.py WIDTH HEIGHT [N=1500] [CODEC=h265] [THREADS=0]
     (about 40 s for 1,500 at 64x48; the last line is JSON)"""
import importlib.util
import json
import os
import pathlib
import sys
import tempfile
import time
from fractions import Fraction

import av
import numpy as np

ROOT = pathlib.Path(__file__).resolve().parents[2]
spec = importlib.util.spec_from_file_location("lapig", ROOT / "__init__.py", submodule_search_locations=[str(ROOT)])
pkg = importlib.util.module_from_spec(spec); sys.modules["lapig"] = pkg; spec.loader.exec_module(pkg)
from lapig.lapig_core.export import codecs, video  # noqa: E402

width, height = int(sys.argv[1]), int(sys.argv[2])
count = int(sys.argv[3]) if len(sys.argv) > 3 else 1500
codec = sys.argv[4] if len(sys.argv) > 4 else "h265"
threads = int(sys.argv[5]) if len(sys.argv) > 5 else 0
plan = video.plan_video(codecs.CODECS[codec], 8, (width, height), Fraction(30), False)
frames = [np.random.default_rng(i).integers(0, 255, (plan.size[1], plan.size[0], 3), dtype=np.uint8)
          for i in range(12)]
folder = tempfile.mkdtemp()
started = time.time()
for k in range(count):
    container = av.open(os.path.join(folder, "a.mp4"), "w")
    stream = video._open_stream(container, plan)
    stream.codec_context.thread_count = threads
    for pixels in frames:
        for packet in stream.encode(av.VideoFrame.from_ndarray(pixels, format="rgb24").reformat(format=plan.pix_fmt)):
            container.mux(packet)
    for packet in stream.encode():
        container.mux(packet)
    container.close()
    if k % 250 == 0:
        print(f"{k} encodes, {time.time() - started:.1f} s", flush=True)
print(json.dumps({"size": list(plan.size), "codec": codec, "pix_fmt": plan.pix_fmt, "threads": threads,
                  "encodes": count, "crashed": False, "seconds": round(time.time() - started, 1)}))

"""Counts of what a piece of work reads and writes: PNG decodes and encodes, checkpoint loads, setup.json
reads and files written (atomically renamed into place). For before-and-after figures of the data path
(bench preview); it patches the library functions every reader and writer goes through."""
from __future__ import annotations

import contextlib
import os
import pathlib

import cv2


@contextlib.contextmanager
def counted_io():
    """Yields a dict of counts, filled while the block runs."""
    import torch

    counts = {"png_decodes": 0, "png_encodes": 0, "checkpoint_loads": 0, "setup_json_reads": 0, "files_written": 0}
    imdecode, imencode, load, replace, read_text = cv2.imdecode, cv2.imencode, torch.load, os.replace, \
        pathlib.Path.read_text

    def counting(key, original):
        def call(*args, **kwargs):
            counts[key] += 1
            return original(*args, **kwargs)
        return call

    def reading(self, *args, **kwargs):
        if self.name == "setup.json":
            counts["setup_json_reads"] += 1
        return read_text(self, *args, **kwargs)

    cv2.imdecode, cv2.imencode = counting("png_decodes", imdecode), counting("png_encodes", imencode)
    torch.load, os.replace = counting("checkpoint_loads", load), counting("files_written", replace)
    pathlib.Path.read_text = reading
    try:
        yield counts
    finally:
        cv2.imdecode, cv2.imencode, torch.load, os.replace = imdecode, imencode, load, replace
        pathlib.Path.read_text = read_text

# SPDX-License-Identifier: GPL-3.0-or-later
"""Read an exported video back as a media server's decoder would see it: OpenCV's FFmpeg reader, RGB frames.

The round-trip checks of the show's export (its tests, `bench video`) compare these frames with the looks' PNGs;
OpenCV is the independent reader there (the writer is PyAV), so a frame the writer mislabels shows up."""
from __future__ import annotations

import cv2
import numpy as np


def decode_with_opencv(path) -> tuple[list[np.ndarray], float]:
    """Every frame of the video at path, (H, W, 3) uint8 RGB in order, and the frame rate its header gives."""
    cap = cv2.VideoCapture(str(path))
    frames = []
    try:
        while True:
            ok, frame = cap.read()
            if not ok:
                break
            frames.append(frame[:, :, ::-1])
        fps = cap.get(cv2.CAP_PROP_FPS)
    finally:
        cap.release()
    return frames, fps

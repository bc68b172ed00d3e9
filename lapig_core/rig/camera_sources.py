# SPDX-License-Identifier: GPL-3.0-or-later
"""What an OpenCVCamera opens and how: the source (an index, a URL, a video file), the backend,
and the frames' conversion to RGB."""
from __future__ import annotations

import sys
from pathlib import Path
from urllib.parse import urlsplit, urlunsplit

import cv2
import numpy as np

from ..common.imageio import to_uint8
from . import RigError

BACKENDS = {"any": cv2.CAP_ANY, "v4l2": cv2.CAP_V4L2, "dshow": cv2.CAP_DSHOW, "msmf": cv2.CAP_MSMF,
            "avfoundation": cv2.CAP_AVFOUNDATION, "ffmpeg": cv2.CAP_FFMPEG}


def native_backend(platform: str = sys.platform) -> int:
    """The camera backend of the platform: V4L2 on Linux, DirectShow on Windows (Media Foundation
    exposes no exposure control), AVFoundation on macOS."""
    if platform.startswith("linux"):
        return cv2.CAP_V4L2
    if platform.startswith("win"):
        return cv2.CAP_DSHOW
    if platform == "darwin":
        return cv2.CAP_AVFOUNDATION
    return cv2.CAP_ANY


def _has_backend(api: int) -> bool:
    try:
        return api == cv2.CAP_ANY or bool(cv2.videoio_registry.hasBackend(api))
    except (AttributeError, cv2.error):
        return True  # an OpenCV without the registry: let open() say


def backend_label(api: int) -> str:
    """The backend's name as OpenCV spells it (V4L2, DSHOW, FFMPEG, ...)."""
    if api == cv2.CAP_ANY:
        return "any backend"
    try:
        return f"the {cv2.videoio_registry.getBackendName(api)} backend"
    except (AttributeError, cv2.error):
        return f"backend {api}"


def parse_source(source) -> tuple[str, object]:
    """("index", int), ("url", str) or ("file", Path) of what OpenCVCamera was given."""
    if isinstance(source, (bool, float)):
        raise RigError(f"a camera source is an index, a URL or a video file, not {source!r}")
    if isinstance(source, int) or (isinstance(source, str) and source.strip().isdigit()):
        index = int(source)
        if index < 0:
            raise RigError(f"camera index {index} is negative: indices start at 0 (list_cameras())")
        return "index", index
    if isinstance(source, str) and "://" in source:
        return "url", source
    if isinstance(source, (str, Path)) and str(source).strip():
        return "file", Path(source)
    raise RigError(f"a camera source is an index, a URL or a video file, not {source!r}")


def redacted(url: str) -> str:
    """A URL without its password, for messages and setup.json."""
    parts = urlsplit(url)
    if parts.password is None:
        return url
    host = parts.hostname or ""
    netloc = f"{parts.username}:***@{host}" + (f":{parts.port}" if parts.port else "")
    return urlunsplit(parts._replace(netloc=netloc))


def resolve_backend(backend: str, kind: str) -> int:
    """The cv2.CAP_* to open with: "auto" is the platform's for an index, FFMPEG for a URL or file."""
    if backend == "auto":
        api = native_backend() if kind == "index" else cv2.CAP_FFMPEG
        return api if _has_backend(api) else cv2.CAP_ANY
    api = BACKENDS.get(str(backend).lower())
    if api is None:
        raise RigError(f"unknown camera backend {backend!r}: use 'auto' or one of {', '.join(BACKENDS)}")
    if not _has_backend(api):
        raise RigError(f"this OpenCV ({cv2.__version__}) has no {backend} backend: use backend='auto'")
    return api


def to_rgb(frame: np.ndarray) -> np.ndarray:
    """A frame as OpenCV returns it (BGR, BGRA or grey; 8 or 16 bits) -> uint8 (H, W, 3) RGB."""
    if frame.dtype == np.uint16:
        frame = to_uint8(frame)
    elif frame.dtype != np.uint8:
        frame = np.clip(frame, 0, 255).astype(np.uint8)
    if frame.ndim == 2 or frame.shape[2] == 1:
        return cv2.cvtColor(frame, cv2.COLOR_GRAY2RGB)
    if frame.shape[2] == 4:
        return cv2.cvtColor(frame, cv2.COLOR_BGRA2RGB)
    return cv2.cvtColor(frame, cv2.COLOR_BGR2RGB)

# SPDX-License-Identifier: GPL-3.0-or-later
"""The capture of several projectors on one object: one capture set, one camera.

Each projector in turn shows its Gray code and its training frames while the others show black; then
all show black once, all show white once, and all show their blend's alpha maps once. That gives
(capture_set.py holds the layout):
  - one CameraMap per projector (its registration per camera pixel, CameraMap.from_decoded);
  - each projector's captures alone, and the all-black one: what JointModel.fit takes;
  - the all-white capture: the object lit by every projector, the surface the look is made from, and
    the check that the light of separately captured projectors adds up (JointModel.check);
  - the blend probe: the camera's view of the blend, from which the first look fits the gamma the alpha
    maps are encoded with (blend_probe.py).
A projector whose light reaches nothing the camera sees stops the capture with its name, before the
next projector's patterns: the previous capture set stays as it was (the set is staged and swapped in
whole at the end, as one projector's, capture/staging.py).

The device is a MultiProjectorDevice: it shows one frame per projector at once (None: black) and grabs.
``run_multi_capture`` is a generator of (progress, message) for the job engine, as capture.sequence's.
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Sequence

import numpy as np

from ..capture import dataset as ds
from ..capture.settings import CaptureError, CaptureSettings
from ..capture.staging import StagedCapture
from ..capture.structured_light import decode_graycode_partial, graycode_patterns
from ..common.closing import Closing
from ..common.imageio import write_png
from . import capture_set as layout
from .blend_probe import probe_frames
from .camera_map import CameraMap
from .coverage import coverage
from .frames import smooth_frames
from .graycode_fill import fill_unread_bits

MIN_REACH_PIXELS = 16  # camera pixels on the object: fewer and a projector reaches nothing we can model
MIN_REACH_SHARE = 0.005  # of the object the camera sees


@dataclass(frozen=True)
class MultiDeviceInfo:
    name: str
    projector_sizes: tuple  # (width, height) per projector
    camera_size: tuple[int, int]  # (width, height) of the grabbed images
    details: dict = field(default_factory=dict)  # recorded in setup.json as they are


class MultiProjectorDevice(Closing):
    """K projectors and one camera. Implement describe() and capture(); the rest has defaults.

    capture(frame_sets): frame_sets is a list of frame sets, each one uint8 (h_k,w_k,3) frame per projector
    (None: that projector shows black); returns the camera's image of each set, uint8 (H,W,3)."""

    main_thread = False  # True: every call from Blender's main thread (Cycles)

    def describe(self) -> MultiDeviceInfo:
        raise NotImplementedError

    def capture(self, frame_sets) -> list[np.ndarray]:
        raise NotImplementedError

    def lock_exposure(self, white_frames: Sequence[np.ndarray]) -> None:
        """Fix the camera's exposure for every projector showing white together (the brightest set)."""

    def vary_noise(self, draw: int) -> None:
        """Make the next captures a new noise draw (refinement's repeats; CaptureDevice.vary_noise's rule)."""

    def object_mask(self) -> np.ndarray | None:
        """(H,W) bool: where the camera sees the surface object, where the device knows it (None: it does
        not; the union of the projectors' reach stands in)."""
        return None


def training_frames(projector_size, count: int, seed: int) -> np.ndarray:
    """(count,h,w,3) uint8 frames a projector shows alone: full white first, then smooth colour fields."""
    frames = smooth_frames(projector_size, count + 1, seed=seed)[1:]  # black is the shared all-black capture
    return np.round(frames * 255).astype(np.uint8)


def _alone(k: int, count: int, frame) -> list:
    shown = [None] * count
    shown[k] = frame
    return shown


def _white(size) -> np.ndarray:
    w, h = size
    return np.full((h, w, 3), 255, np.uint8)


def reach_problem(name: str, camera_map: CameraMap, object_mask: np.ndarray) -> str:
    """Why a projector's registration is too small to use ('' when it is not)."""
    reached = int((camera_map.valid & object_mask).sum())
    if reached < max(MIN_REACH_PIXELS, MIN_REACH_SHARE * int(object_mask.sum())):
        return (f"projector '{name}' reaches nothing the camera sees of the object: aim it at the object, "
                f"or remove it from the rig (the previous capture is kept)")
    return ""


def run_multi_capture(device: MultiProjectorDevice, s: CaptureSettings, names: Sequence[str],
                      extra_meta: dict | None = None, holder: str = "a LAPIG capture", fill_blurred_bits: bool = True):
    """Capture every projector of ``device`` into settings.out_dir/setups/<setup_name>; ``names``: the
    projectors' names, in the device's order. ``fill_blurred_bits``: register lit pixels whose finest Gray-code
    bits blur (multi/graycode_fill; False: the strict decode only, for comparisons). A generator; returns
    {"setup_dir", "meta"}."""
    t0 = time.perf_counter()
    info = device.describe()
    sizes = [tuple(int(v) for v in size) for size in info.projector_sizes]
    count = len(sizes)
    if len(names) != count or count < 1:
        raise CaptureError(f"one name per projector: {count} projectors, {len(names)} names")
    if s.train_count < 3:
        raise CaptureError(f"several projectors need at least 3 training images each, got {s.train_count}")
    frames = [training_frames(size, s.train_count, s.seed + 101 * k) for k, size in enumerate(sizes)]
    timings = {}
    with StagedCapture(ds.DatasetLayout(s.out_dir, s.setup_name), holder) as staged:
        yield 0.01, "preparing the capture of %d projectors" % count
        whites = [_white(size) for size in sizes]
        device.lock_exposure(whites)
        mask = device.object_mask()
        maps, filled = [], []
        t = time.perf_counter()
        for k, (w, h) in enumerate(sizes):
            patterns = graycode_patterns(w, h)
            caps = []
            for start in range(0, len(patterns), s.chunk):
                chunk = patterns[start:start + s.chunk]
                caps += device.capture([_alone(k, count, np.repeat(p[..., None], 3, axis=-1)) for p in chunk])
                done = (k + len(caps) / len(patterns)) / count
                yield 0.02 + 0.5 * done, f"{names[k]}: structured light {len(caps)}/{len(patterns)}"
            # grazing surfaces blur the finest stripes: their pixels get the position the coarse bits allow
            partial = decode_graycode_partial(caps, w, h)  # the captures read once: the strict decode and the rest
            fill = fill_unread_bits(partial.decoded(), partial, max_unknown_bits=None if fill_blurred_bits else -1)
            decoded = fill.decoded
            filled.append(int(fill.filled.sum()))
            reserved = getattr(device, "reserved_rows", None)  # a real rig's frame code lit these rows
            top, bottom = reserved(k) if reserved is not None else (0, 0)
            if top or bottom:
                decoded.valid = decoded.valid & (decoded.proj_y >= top) & (decoded.proj_y < h - bottom)
            code = getattr(device, "code_pixels", None)  # where any projector's code lights the object: the
            lit_by_code = code() if code is not None else None  # joint captures (black, white) carry it there
            if lit_by_code is not None:
                decoded.valid = decoded.valid & ~lit_by_code
            camera_map = CameraMap.from_decoded(decoded, (w, h))
            seen = mask if mask is not None else np.ones(camera_map.camera_shape, bool)
            problem = reach_problem(names[k], camera_map, seen)
            if problem:
                raise CaptureError(problem)
            maps.append(camera_map)
        timings["structured_light_s"] = time.perf_counter() - t

        t = time.perf_counter()
        alone = []
        total = count * s.train_count
        for k in range(count):
            caps = []
            for start in range(0, s.train_count, s.chunk):
                caps += device.capture([_alone(k, count, f) for f in frames[k][start:start + s.chunk]])
                yield 0.52 + 0.4 * (k * s.train_count + len(caps)) / total, \
                    f"{names[k]}: captures alone {len(caps)}/{s.train_count}"
            alone.append(caps)
        probe = probe_frames(maps)
        black, together, probed = device.capture([[None] * count, whites, probe])
        timings["patterns_s"] = time.perf_counter() - t
        if mask is None:  # a device that does not know the object: what some projector reaches
            mask = np.any([m.valid for m in maps], axis=0)

        yield 0.94, "writing the capture set"
        folder = staged.layout.setup_dir
        layout.save_camera_maps(folder / layout.CAMERA_MAPS, maps)
        write_png(folder / layout.BLACK, black)
        write_png(folder / layout.TOGETHER, together)
        write_png(folder / layout.BLEND_PROBE, probed)
        write_png(folder / layout.OBJECT_MASK, mask.astype(np.uint8) * 255)
        for k in range(count):
            for i, (frame, cap) in enumerate(zip(frames[k], alone[k]), start=1):
                write_png(ds.DatasetLayout.image_path(layout.projector_dir(folder, k) / "prj", i), frame)
                write_png(ds.DatasetLayout.image_path(layout.projector_dir(folder, k) / "cam", i), cap)
            write_png(layout.projector_dir(folder, k) / layout.BLEND_PROBE_FRAME, probe[k])
        cover = coverage(maps, mask)
        described = device.describe()  # after the capture: with the exposure it locked
        meta = {
            layout.MULTI_KEY: {"count": count, "train_count": s.train_count,
                               "projectors": [{"name": n, "size": list(size)} for n, size in zip(names, sizes)]},
            "device": described.name,
            "camera_size": list(described.camera_size),
            **described.details,
            "coverage": {"reached": cover.reached, "per_projector": list(cover.per_projector),
                         "overlap": cover.overlap, "object_pixels": cover.object_pixels},
            "valid_fraction": [float(m.valid.mean()) for m in maps],
            "filled_pixels": filled,  # lit pixels whose finest bits blurred (multi/graycode_fill)
            "seed": s.seed,
            **(extra_meta or {}),
            "timings": {k: round(v, 4) for k, v in {**s.timings, **timings}.items() if isinstance(v, float)},
        }
        meta["timings"]["total_s"] = round(time.perf_counter() - t0, 3)
        ds.write_setup_json(staged.layout, meta)
        staged.commit()
    yield 1.0, "capture of %d projectors complete" % count
    return {"setup_dir": staged.final.setup_dir, "meta": meta}

# SPDX-License-Identifier: GPL-3.0-or-later
"""The capture sequence: a complete, registered data set of one projector-camera setup.

References (black -> I-, white -> I+, gray -> s), Gray code at the projector's native
resolution, then the training and test patterns, all through a CaptureDevice; every capture is
registered into projector space and written in the public layout (lapig_core.capture.dataset),
staged and swapped in at the end (lapig_core.capture.staging).

``run_capture`` is a generator of (progress 0..1, message) for the job engine; closing it
cancels the capture and leaves the data set as it was. Its return value (``yield from``) is
{"setup_dir": ..., "meta": ...}.
"""
from __future__ import annotations

import os
import time

import numpy as np

from ..common.imageio import to_uint8, write_png
from ..optics.camera_model import clipped_fraction
from ..optics.projector_model import quantised_frame
from ..optics.working_frame import WorkingFrameError, working_frame
from . import dataset as ds
from . import patterns as pat
from .device import CaptureDevice, GeometryChecks  # noqa: F401 (GeometryChecks re-exported)
from .registration import Registration
from .registration_check import registration_error_px, summarize_errors
from .settings import CaptureError, CaptureSettings
from .staging import StagedCapture, check_shared_patterns
from .structured_light import (decode_agreement, decode_graycode, finest_bit_indices, graycode_patterns,
                               projector_to_camera_map)


def pattern_images(s: CaptureSettings, frame: tuple[int, int]) -> np.ndarray:
    """The training then test working images of a (width, height) frame: the user's folder, or
    generated from the seed."""
    count = s.train_count + s.test_count
    if s.pattern_folder:
        return pat.load_image_folder(s.pattern_folder, *frame, count=count)
    return pat.generate_patterns(count, *frame, seed=s.seed)


def native_frame(working_image: np.ndarray, width: int, height: int) -> np.ndarray:
    """The 8-bit native frame that shows a working image over the whole projector frame."""
    return quantised_frame(working_image, width, height, 8)


def capture_frame(s: CaptureSettings, width: int, height: int) -> tuple[int, int]:
    """The working frame (width, height) of a capture with a width x height projector."""
    try:
        return working_frame(s.working_size, width, height)
    except WorkingFrameError as exc:
        raise CaptureError(str(exc)) from None


def run_capture(device: CaptureDevice, s: CaptureSettings, checks: GeometryChecks | None = None,
                extra_meta: dict | None = None, holder: str = "a LAPIG capture"):
    """Capture through ``device`` into settings.out_dir/setups/<setup_name>; ``checks``: the device's
    own (None: device.geometry_checks()); ``extra_meta`` joins setup.json; ``holder`` names the job in
    the message that refuses another one into the same root meanwhile. A generator: see the module
    docstring."""
    checks = device.geometry_checks() if checks is None else checks
    t0 = time.perf_counter()
    width, height = device.describe().projector_size
    frame = capture_frame(s, width, height)
    refs = pat.reference_patterns(*frame, gray_level=s.gray_level)
    images = pattern_images(s, frame)
    shown = {"ref": [refs["black"], refs["white"], refs["gray"]],
             "train": images[:s.train_count], "test": images[s.train_count:]}
    with StagedCapture(ds.DatasetLayout(s.out_dir, s.setup_name), holder) as staged:
        if not staged.owns_projector_images:
            check_shared_patterns(staged.final, shown, staged.others)
        yield 0.01, "preparing the capture"
        cover = _check_coverage(checks, s.min_coverage)
        yield 0.03, ("" if cover is None else f"coverage {cover['projector_on_object']:.0%}: ") + \
            "capturing references"

        t = time.perf_counter()
        ref_frames = [native_frame(im, width, height) for im in shown["ref"]]
        device.lock_exposure(ref_frames[1])
        ref_caps = device.capture(ref_frames)
        s.timings["references_s"] = time.perf_counter() - t
        yield 0.06, "capturing Gray-code patterns"

        t = time.perf_counter()
        sl_patterns = graycode_patterns(width, height)
        sl_caps = []
        for start in range(0, len(sl_patterns), s.chunk):
            sl_caps += device.capture([np.repeat(p[..., None], 3, axis=-1) for p in sl_patterns[start:start + s.chunk]])
            yield 0.06 + 0.3 * len(sl_caps) / len(sl_patterns), f"structured light {len(sl_caps)}/{len(sl_patterns)}"
        s.timings["structured_light_render_s"] = time.perf_counter() - t

        t = time.perf_counter()
        decoded = decode_graycode(sl_caps, width, height)
        top, bottom = device.reserved_rows()  # the rig's frame code, not the patterns, lit these rows
        patterned = decoded.valid & (decoded.proj_y >= top) & (decoded.proj_y < height - bottom)
        agreement = yield from _decode_twice(device, sl_patterns, sl_caps, patterned, width, height)
        cam_xy, valid = projector_to_camera_map(decoded, width, height)
        valid[:top] = False
        valid[height - bottom:] = False
        registration = Registration.from_map(cam_xy, valid, width, height, *frame)
        s.timings["registration_build_s"] = time.perf_counter() - t
        registration_extra = {} if agreement is None else {"decode_agreement": round(agreement, 4)}
        if registration.valid.mean() < 0.05:
            raise CaptureError("the Gray code decoded on almost no pixels: the camera does not see "
                               "the projection (check exposure, ambient light and aim)")
        reg_stats = _registration_check(checks, s, cam_xy, valid, width, height)
        yield 0.4, "writing references"

        layout = staged.layout
        _write_captures(staged, "ref", shown["ref"], ref_caps, registration)
        for i, (p, cap) in enumerate(zip(sl_patterns, sl_caps), start=1):
            write_png(layout.image_path(layout.prj_setup_dir("sl"), i), p)
            ds.write_capture(layout, "raw", "sl", i, cap)
        registration.save(os.path.join(layout.setup_dir, ds.REGISTRATION_FILE))

        t = time.perf_counter()
        done = 0
        for kind in ("train", "test"):
            group = shown[kind]
            for start in range(0, len(group), s.chunk):
                chunk = group[start:start + s.chunk]
                caps = device.capture([native_frame(im, width, height) for im in chunk])
                _write_captures(staged, kind, group, caps, registration, first=start + 1)
                done += len(chunk)
                yield 0.4 + 0.58 * done / max(len(images), 1), f"captures {done}/{len(images)}"
        s.timings["patterns_s"] = time.perf_counter() - t
        s.timings["pattern_count"] = len(images)

        meta = {
            "gray_level": s.gray_level,
            "working_size": s.working_size,
            "working_frame": list(frame),  # (width, height) of every registered image
            **_device_meta(device),
            "counts": {"train": s.train_count, "test": s.test_count, "sl": len(sl_patterns)},
            **({} if cover is None else {"coverage": cover}),
            "valid_fraction": float(valid.mean()),
            "working_valid_fraction": float(registration.valid.mean()),
            # share of the camera pixels the projector lights (Gray code decoded) that clip in white
            "white_clipped_fraction": clipped_fraction(to_uint8(ref_caps[1]), decoded.valid),
            "registration": {**reg_stats, **registration_extra},
            "pattern_source": s.pattern_folder or f"generated (seed {s.seed})",
            ds.PRJ_DIGEST_KEY: ds.projector_images_digest(staged.projector_layout.root),
            **(extra_meta or {}),
            "timings": {k: round(v, 4) if isinstance(v, float) else v for k, v in s.timings.items()},
        }
        meta["timings"]["total_s"] = round(time.perf_counter() - t0, 3)
        ds.write_setup_json(layout, meta)
        staged.commit()
    yield 1.0, "capture complete"
    return {"setup_dir": staged.final.setup_dir, "meta": meta}


def _decode_twice(device, patterns, captures, valid, width, height, minimum: float = 0.9):
    """Where the device asks for it (a real camera), capture the finest Gray-code stripes again: the share
    of pixels that decode the same way twice (None: not checked). Too low stops the capture."""
    if not getattr(device, "decode_twice", False):
        return None
    yield 0.37, "checking the decode: the finest stripes again"
    indices = finest_bit_indices(width, height)
    again = device.capture([np.repeat(patterns[i][..., None], 3, axis=-1) for i in indices])
    agreement = decode_agreement(captures, again, indices, valid)
    if agreement < minimum:
        raise CaptureError(f"the same stripes decoded differently twice on {1 - agreement:.0%} of the pixels: "
                           "the camera or the projector moved, the focus breathes, or the picture is too noisy "
                           "(lower the gain, add light or steady the rig), then capture again")
    return agreement


def _write_captures(staged: StagedCapture, kind, projected, caps, registration, first=1):
    """Raw and registered captures from index ``first`` on; with the first ones, the projector
    images of the kind, when this capture owns the root's."""
    if first == 1 and staged.owns_projector_images:
        ds.write_projector_images(staged.layout, kind, projected)
    for i, cap in enumerate(caps, start=first):
        ds.write_capture(staged.layout, "raw", kind, i, cap)
        ds.write_capture(staged.layout, "warp", kind, i, registration.warp(cap))


def _device_meta(device: CaptureDevice) -> dict:
    info = device.describe()  # after the capture: with the exposure it locked
    return {"device": info.name, "device_timing": info.timing(), **info.details}


def _check_coverage(checks: GeometryChecks, minimum: float) -> dict | None:
    if checks.coverage is None:
        return None
    cover = checks.coverage()
    if min(cover.values()) < minimum:
        raise CaptureError(
            f"{checks.surface} covers {cover['projector_on_object']:.0%} of the projector's frame "
            f"and the camera sees {cover['seen_by_camera']:.0%} of it (at least {minimum:.0%} needed): "
            f"{checks.aim_hint}")
    return cover


def _registration_check(checks, s, cam_xy, valid, width, height) -> dict:
    """Registration error against the exact geometry on a grid of projector pixels."""
    if not (s.check_registration and checks.exact_projector_to_camera):
        return {}
    t = time.perf_counter()
    gx = np.arange(s.check_grid_step, width - s.check_grid_step, s.check_grid_step)
    gy = np.arange(s.check_grid_step, height - s.check_grid_step, s.check_grid_step)
    xs, ys = np.meshgrid(gx, gy)
    exact = checks.exact_projector_to_camera(np.stack([xs, ys], -1).astype(float))
    stats = summarize_errors(registration_error_px(cam_xy, valid, gx, gy, exact))
    s.timings["registration_check_s"] = time.perf_counter() - t
    return stats

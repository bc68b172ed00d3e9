"""Project images on the rig and capture them as a capture recorded it: the "real capture".

The device comes from the factory (ports.DeviceFactory.setup_device) with the setup's own exposure,
camera response, ambient light and registration, so a compensated image is judged exactly as its
training captures were taken. The rig must be the one that made the capture (its identity is checked).
Train's rendered choice, Render Real Capture and the benchmarks all come through here.
"""
from __future__ import annotations

import os

import numpy as np

from ...lapig_core.capture import dataset as ds
from ...lapig_core.capture.registration import Registration
from ...lapig_core.capture.settings import CaptureError
from ...lapig_core.optics.projector_model import quantised_frame


def projection_steps(devices, setup_dir, images, seed=0, chunk=8, bit_depth=8):
    """A generator of the fraction done after each chunk; its return value is (registered (N, h, w, 3)
    float32 at the setup's working frame, raw camera images). images: (N, H, W, 3), working frames or
    native ones, sent to the projector as bit_depth frames (quantised_frame: the exported file's pixels)."""
    setup_dir = os.fspath(setup_dir)
    meta = ds.read_setup_json(os.path.join(setup_dir, "setup.json"))
    if meta.get("fingerprint") != devices.rig_identity().key():
        raise CaptureError("the projector, camera or object changed since this setup was captured: capture again")
    registration = Registration.load(os.path.join(setup_dir, ds.REGISTRATION_FILE))
    registered, raw = [], []
    images = [np.asarray(im, np.float32) for im in images]  # working frames and native ones may mix
    with devices.setup_device(meta, seed=seed) as device:
        width, height = device.describe().projector_size
        for start in range(0, len(images), chunk):
            frames = [quantised_frame(im, width, height, bit_depth) for im in images[start:start + chunk]]
            for cap in device.capture(frames):
                raw.append(cap)
                registered.append(registration.warp(cap))
            yield len(registered) / len(images)
    return np.stack(registered).astype(np.float32), np.stack(raw)


def project_and_capture(devices, setup_dir, images, seed=0, chunk=8, bit_depth=8):
    """projection_steps run to the end: (registered, raw)."""
    steps = projection_steps(devices, setup_dir, images, seed, chunk, bit_depth)
    while True:
        try:
            next(steps)
        except StopIteration as done:
            return done.value


def register_at(setup_dir, raw_capture, width: int, height: int) -> tuple[np.ndarray, np.ndarray]:
    """A raw capture of the setup registered into a width x height frame (e.g. native), and where
    it is valid."""
    registration = Registration.load(os.path.join(os.fspath(setup_dir), ds.REGISTRATION_FILE))
    return registration.resized(width, height).warp(raw_capture, return_valid=True)

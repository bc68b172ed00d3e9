"""Project images on the rig and capture them as a capture recorded it: the "real capture".

The device comes from the factory (ports.DeviceFactory.setup_device) with the setup's own exposure,
camera response, ambient light and registration, so a compensated image is judged exactly as its
training captures were taken. The rig must be the one that made the capture (its identity is checked).
Train's rendered choice, Render Real Capture and the benchmarks all come through here.
"""
from __future__ import annotations

import contextlib
import os

import numpy as np

from ....lapig_core.capture import dataset as ds
from ....lapig_core.capture.registration import Registration
from ....lapig_core.capture.settings import CaptureError
from ....lapig_core.common.steps import run_to_end
from ....lapig_core.optics.projector_model import quantised_frame


def projection_steps(devices, setup_dir, images, seed=0, chunk=8, bit_depth=8, stop=None):
    """A generator of the fraction done after each chunk; its return value is (registered (N, h, w, 3)
    float32 at the setup's working frame, raw camera images). images: (N, H, W, 3), working frames or
    native ones, sent to the projector as bit_depth frames (quantised_frame: the exported file's pixels).
    stop: asked before each chunk; True closes the device there and returns the captures made so far
    (N may then be 0: empty lists)."""
    meta, registration = _checked_setup(devices, setup_dir)
    registered, raw = [], []
    images = [np.asarray(im, np.float32) for im in images]  # working frames and native ones may mix
    with devices.setup_device(meta, seed=seed) as device:
        width, height = device.describe().projector_size
        for start in range(0, len(images), chunk):
            if stop is not None and stop():
                return registered, raw
            frames = [quantised_frame(im, width, height, bit_depth) for im in images[start:start + chunk]]
            for cap in device.capture(frames):
                raw.append(cap)
                registered.append(registration.warp(cap))
            yield len(registered) / len(images)
    return np.stack(registered).astype(np.float32), np.stack(raw)


def _checked_setup(devices, setup_dir):
    """(setup.json's meta, its registration), once the rig is known to be the one that captured it."""
    setup_dir = os.fspath(setup_dir)
    meta = ds.read_setup_json(os.path.join(setup_dir, "setup.json"))
    if meta.get("fingerprint") != devices.rig_identity().key():
        raise CaptureError("the projector, camera or object changed since this setup was captured: capture again")
    return meta, Registration.load(os.path.join(setup_dir, ds.REGISTRATION_FILE))


class ProjectionSession:
    """The rig opened once, as the capture recorded it, for many rounds of captures (closed-loop
    refinement): opening a device costs more than a capture (Cycles renders the room light first)."""

    def __init__(self, device, registration: Registration, bit_depth: int):
        self.device, self.registration, self.bit_depth = device, registration, bit_depth
        self.width, self.height = device.describe().projector_size
        self.draws = 0

    def capture(self, images) -> tuple[np.ndarray, list]:
        """(registered (N, h, w, 3) float32 at the working frame, raw camera images) of projecting each
        image; every call is a new noise draw (device.vary_noise), as a real camera's grabs are."""
        self.device.vary_noise(self.draws)
        self.draws += 1
        frames = [quantised_frame(np.asarray(im, np.float32), self.width, self.height, self.bit_depth) for im in images]
        raw = list(self.device.capture(frames))
        return np.stack([self.registration.warp(c) for c in raw]).astype(np.float32), raw


@contextlib.contextmanager
def projection_session(devices, setup_dir, seed=0, bit_depth=8):
    """A ProjectionSession on the rig of setup_dir (refused when the rig changed since), closed on exit."""
    meta, registration = _checked_setup(devices, setup_dir)
    with devices.setup_device(meta, seed=seed) as device:
        yield ProjectionSession(device, registration, bit_depth)


def project_and_capture(devices, setup_dir, images, seed=0, chunk=8, bit_depth=8):
    """projection_steps run to the end: (registered, raw)."""
    return run_to_end(projection_steps(devices, setup_dir, images, seed, chunk, bit_depth))


def register_at(setup_dir, raw_capture, width: int, height: int) -> tuple[np.ndarray, np.ndarray]:
    """A raw capture of the setup registered into a width x height frame (e.g. native), and where
    it is valid."""
    registration = Registration.load(os.path.join(os.fspath(setup_dir), ds.REGISTRATION_FILE))
    return registration.resized(width, height).warp(raw_capture, return_valid=True)

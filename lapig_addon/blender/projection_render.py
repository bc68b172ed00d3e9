"""Project working images onto the real (rendered) surface and capture them: the "real capture".

Uses a captured setup's own exposure, camera response, ambient light and registration, so a
compensated image is judged exactly as its training captures were taken. The rig must not have
moved since the capture (its fingerprint is checked).
"""
from __future__ import annotations

import os

import numpy as np

from ...lapig_core.capture import dataset as ds
from ...lapig_core.optics.camera_model import CameraResponse
from ...lapig_core.capture.registration import Registration
from ...lapig_core.optics.projector_model import quantised_frame
from ..services.capture_job import CaptureError, check_rig
from .cycles_device import CyclesCaptureDevice
from .preview import real_surface
from .scene_state import projector_model, rig_fingerprint


def render_working_images(scene, projector, camera, target, setup_dir, images, samples=None, seed=0,
                          chunk=8, return_raw=False, bit_depth=8):
    """Registered captures (N, h, w, 3) float32 at the setup's working frame of projecting each
    image (N, H, W, 3: working frames, or native ones), sent to the projector as bit_depth frames
    (ProjectorModel.frame_light, like the exported file)."""
    steps = iter_render_working_images(scene, projector, camera, target, setup_dir, images, samples, seed, chunk,
                                       bit_depth)
    for _ in steps:
        pass
    registered, raw = steps.result
    return (registered, raw) if return_raw else registered


class _Steps:
    """A generator of progress fractions that keeps its result (for the job engine's small steps)."""

    def __init__(self, gen):
        self._gen, self.result = gen, None

    def __iter__(self):
        self.result = yield from self._gen

    def close(self):
        """On a cancel: leave the capture studio now (it restores the projector and removes its scene)."""
        self._gen.close()


def iter_render_working_images(scene, projector, camera, target, setup_dir, images, samples=None, seed=0,
                               chunk=8, bit_depth=8):
    """The same work in steps: yields the fraction done after each chunk; .result = (registered, raw)."""
    return _Steps(_render_steps(scene, projector, camera, target, setup_dir, images, samples, seed, chunk,
                                bit_depth))


def _render_steps(scene, projector, camera, target, setup_dir, images, samples, seed, chunk, bit_depth):
    check_rig(scene, projector, camera, target)
    setup_dir = os.fspath(setup_dir)
    meta = ds.read_setup_json(os.path.join(setup_dir, "setup.json"))
    if meta.get("fingerprint") != rig_fingerprint(projector, camera, target):
        raise CaptureError("the projector, camera or object changed since this setup was captured: capture again")
    registration = Registration.load(os.path.join(setup_dir, ds.REGISTRATION_FILE))
    model = projector_model(projector)
    registered, raw = [], []
    images = [np.asarray(im, np.float32) for im in images]  # working frames and native ones may mix
    # the real surface, not a preview's material (which would show the look it is judged against)
    with real_surface(target, projector), \
            CyclesCaptureDevice(scene, projector, camera, target, samples=samples or meta.get("samples", 1),
                                ambient=meta.get("ambient", 0.0), seed=seed,
                                response=CameraResponse(**meta["camera"]["response"]),
                                camera_size=tuple(meta["camera"]["resolution"])) as device:
        for start in range(0, len(images), chunk):
            # the frames of the files Export writes at this bit depth
            frames = [quantised_frame(im, model.width, model.height, bit_depth) for im in images[start:start + chunk]]
            for cap in device.capture(frames):
                raw.append(cap)
                registered.append(registration.warp(cap))
            yield len(registered) / len(images)
    return np.stack(registered).astype(np.float32), np.stack(raw)


def register_at(setup_dir, raw_capture, width: int, height: int) -> tuple[np.ndarray, np.ndarray]:
    """A raw capture of the setup registered into a width x height frame (e.g. native), and where
    it is valid."""
    registration = Registration.load(os.path.join(os.fspath(setup_dir), ds.REGISTRATION_FILE))
    return registration.resized(width, height).warp(raw_capture, return_valid=True)

"""Several projectors in the Cycles studio: the capture device of a rig with more than one projector.

Each projector renders in a studio of its own (a CyclesCaptureDevice), and their linear light is added
before the one camera response makes the saved image. Light adds exactly, and a render with one pinhole
light is noise-free at one sample, where one render of K lights is not (Cycles picks one light per
sample). A frame set costs one render per projector that shows something other than black: a projector
showing black contributes its black-level light, rendered once per capture and kept. The room's light is
rendered once, by the first projector's studio.
"""
from __future__ import annotations

import contextlib

import numpy as np

from ...lapig_core.multi.capture import MultiDeviceInfo, MultiProjectorDevice
from ...lapig_core.optics.camera_model import auto_exposure_stops
from .cycles_device import CyclesCaptureDevice
from .geometry_probe import camera_object_mask


class CyclesMultiDevice(MultiProjectorDevice):
    main_thread = True

    def __init__(self, scene, projectors, camera, target, samples=1, ambient=0.03, seed=0):
        self.scene, self.camera, self.target = scene, camera, target
        # the room light once: in the first projector's renders (each studio adds its own to every render)
        self.devices = [CyclesCaptureDevice(scene, p, camera, target, samples=samples,
                                            ambient=ambient if k == 0 else 0.0, seed=seed)
                        for k, p in enumerate(projectors)]
        first = self.devices[0]
        self.response, self.rng = first.response, first.rng  # one camera: its response and its noise
        self._black = [None] * len(self.devices)  # each projector's linear light showing black, rendered once
        self._stack = None

    def __enter__(self):
        with contextlib.ExitStack() as stack:
            for device in self.devices:
                stack.enter_context(device)
            self._stack = stack.pop_all()  # closed in reverse order: each studio restores what it found
        return self

    def close(self):
        if self._stack is not None:
            self._stack.close()
            self._stack = None

    def describe(self) -> MultiDeviceInfo:
        first = self.devices[0]
        info = first.describe()
        details = dict(info.details)
        details.pop("projector", None)
        details["projectors"] = [d.model.to_dict() for d in self.devices]
        details["camera"] = {**details["camera"], "response": self.response.to_dict()}
        return MultiDeviceInfo("Blender Cycles", tuple((d.model.width, d.model.height) for d in self.devices),
                               info.camera_size, details)

    def lock_exposure(self, white_frames):
        """Auto exposure: the camera's setting, from every projector's white rendered and added up."""
        first = self.devices[0]
        if first.camera_settings.auto_exposure:
            linear = sum(d._linear([w])[0] for d, w in zip(self.devices, white_frames))
            stops = auto_exposure_stops(linear, mask=linear.max(-1) > 1e-6)
            self.response = first.camera_settings.response(stops)

    def vary_noise(self, draw: int) -> None:
        """Every studio's Cycles seed moves on by `draw`: refinement's repeated captures of one set of images
        differ as a camera's grabs do (the kept black renders stay one draw)."""
        for device in self.devices:
            device.vary_noise(draw)

    def object_mask(self) -> np.ndarray:
        first = self.devices[0]
        return camera_object_mask(self.scene, self.camera, self.target, first.studio.scene, first.width, first.height)

    def _black_light(self, k: int) -> np.ndarray:
        if self._black[k] is None:
            d = self.devices[k]
            self._black[k] = d._linear([np.zeros((d.model.height, d.model.width, 3), np.uint8)])[0]
        return self._black[k]

    def capture(self, frame_sets) -> list[np.ndarray]:
        """One batch render per projector of the frames it shows in these sets (black ones: its kept render)."""
        sets = [list(frames) for frames in frame_sets]
        total = [None] * len(sets)
        for k, device in enumerate(self.devices):
            shown = [i for i, frames in enumerate(sets) if frames[k] is not None]
            rendered = dict(zip(shown, device._linear([sets[i][k] for i in shown]))) if shown else {}
            for i in range(len(sets)):
                light = rendered[i] if i in rendered else self._black_light(k)
                total[i] = light if total[i] is None else total[i] + light
        return [self.response.capture(x, self.rng) for x in total]

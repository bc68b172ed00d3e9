"""The device factory of the virtual rig: the Cycles studio over the scene's projector, camera and object.

Its devices render through bpy, so they are opened and driven on Blender's main thread
(main_thread = True). Each one shows the real surface: the viewport preview, which tints the object's
materials, is off while it is open.
"""
from __future__ import annotations

import contextlib

from ...lapig_core.capture.settings import CaptureError, CaptureSettings
from ...lapig_core.optics.camera_model import CameraResponse
from ...lapig_core.rig.simulated import optics_meta
from ..services.panel.panel_state import rig_blocker
from ..services.ports import RigIdentity
from . import preview, scene_state
from .cycles_device import CyclesCaptureDevice


class CyclesDeviceFactory:
    main_thread = True
    opens_several = True  # one Cycles studio per projector (multi_capture_device)

    def __init__(self, scene, projector=None, camera=None, target=None):
        """The given rig objects; None: the scene's own (read when a device opens, so a rig set up
        after the job was made is the one captured)."""
        self.scene = scene
        self._objects = (projector, camera, target)

    def objects(self) -> tuple:
        own = scene_state.rig_objects(self.scene)
        return tuple(given or scene for given, scene in zip(self._objects, own))

    def check(self):
        """CaptureError unless this rig can be captured or rendered."""
        blocker = rig_blocker(scene_state.read_rig(self.scene, *self.objects()))
        if blocker:
            raise CaptureError(blocker)

    def rig_identity(self) -> RigIdentity:
        projector, camera, target = self.objects()
        names = {"projector": getattr(projector, "name", None), "camera": getattr(camera, "name", None),
                 "target": getattr(target, "name", None)}
        complete = rig_blocker(scene_state.read_rig(self.scene, projector, camera, target)) == ""
        # "Cycles": the choice line says "in Cycles captures of"
        return RigIdentity("Cycles", names, scene_state.rig_fingerprint(projector, camera, target) if complete else "")

    @contextlib.contextmanager
    def _studio(self, **device_options):
        self.check()
        projector, camera, target = self.objects()
        # the viewport preview tints the object's materials: capture the real surface
        with preview.real_surface(target, projector), \
                CyclesCaptureDevice(self.scene, projector, camera, target, **device_options) as device:
            yield device

    def capture_device(self, settings: CaptureSettings):
        return self._studio(samples=settings.samples, ambient=settings.ambient, seed=settings.seed)

    @contextlib.contextmanager
    def multi_capture_device(self, settings: CaptureSettings):
        """The studio of every projector of the scene's rig (lapig_core/multi/capture's device)."""
        from .cycles_multi_device import CyclesMultiDevice

        self.check()
        projectors = scene_state.rig_projectors(self.scene)
        _, camera, target = self.objects()
        with preview.real_surface(target, projectors[0]), \
                CyclesMultiDevice(self.scene, projectors, camera, target, samples=settings.samples,
                                  ambient=settings.ambient, seed=settings.seed) as device:
            yield device

    def setup_device(self, setup_meta: dict, seed: int = 0):
        # a capture on the simulated rig was rendered by this studio: its optics' record reopens it
        setup_meta = optics_meta(setup_meta)
        try:
            camera = setup_meta["camera"]
            response, size = CameraResponse(**camera["response"]), tuple(camera["resolution"])
        except (KeyError, TypeError) as exc:
            raise CaptureError(f"the capture's setup.json does not record its camera ({exc})") from None
        return self._studio(samples=setup_meta.get("samples", 1), ambient=setup_meta.get("ambient", 0.0), seed=seed,
                            response=response, camera_size=size)
